"""Sets files (`spotfree train --sets`): rows of recording, classes and an optional span; bad files are one-line
InputErrors naming the line, and so is any text a fuzzer writes; a span cuts the log on its time axis."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spotfree.errors import InputError
from spotfree.io.class_sets import Declared, read_class_sets
from spotfree.io.recording import Recording


def _write(tmp_path, text, name="sets.csv"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


@pytest.mark.parametrize("text", [
    "recording,classes,start,end\ntrip.csv,\"other,sudden\",10,20\nclip.csv@2,other,,\n",
    "recording\tclasses\tstart\tend\ntrip.csv\tother,sudden\t10\t20\nclip.csv@2\tother\t\t\n",
    "recording;classes;start;end\ntrip.csv;other,sudden;10,0;20\nclip.csv@2;other;;\n",  # decimal comma
    "Recording,Classes,Start,End\ntrip.csv,other;sudden;other,10,20\nclip.csv@2,other,,\n",
])
def test_every_dialect_gives_the_same_rows(tmp_path, text):
    rows = read_class_sets(_write(tmp_path, text))
    assert rows == [Declared(str(tmp_path / "trip.csv"), ("other", "sudden"), 10.0, 20.0),
                    Declared(str(tmp_path / "clip.csv@2"), ("other",))]
    assert rows[0].name == f"{tmp_path / 'trip.csv'}[10-20 s]"
    assert rows[1].name == str(tmp_path / "clip.csv@2")


def test_without_span_columns_a_row_is_the_whole_log_and_absolute_paths_stay(tmp_path):
    elsewhere = tmp_path / "logs" / "a.csv"
    rows = read_class_sets(_write(tmp_path, f"recording,classes\n{elsewhere},walking\n"))
    assert rows == [Declared(str(elsewhere), ("walking",))]


@pytest.mark.parametrize("text, message", [
    ("", "the file is empty; give a header line"),
    ("recording,start\na.csv,0\n", "no column classes"),
    ("recording,classes\n", "no row; give one row per training recording"),
    ("recording,classes\na.csv,\n", "line 2: no class declared for a.csv"),
    ("recording,classes\n,walking\n", "line 2: no recording"),
    ("recording,classes,start,end\na.csv,walking,5,abc\n", "column 'end', line 2: 'abc' is not a finite number"),
    ("recording,classes,start,end\na.csv,walking,0,1\nb.csv,walking,20,10\n", "line 3: the span ends at 10 s"),
    ("recording,classes,start\na.csv,walking,inf\n", "column 'start', line 2: 'inf' is not a finite number"),
])
def test_a_bad_sets_file_is_one_line_naming_what_to_fix(tmp_path, text, message):
    with pytest.raises(InputError) as caught:
        read_class_sets(_write(tmp_path, text))
    assert message in str(caught.value) and "\n" not in str(caught.value)


def test_a_missing_sets_file_says_so(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        read_class_sets(tmp_path / "none.csv")


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.text(alphabet=st.sampled_from(list("recodingclasstrtnd,;\t\n\"0123456789.-e @x")), max_size=120))
def test_fuzzed_sets_files_are_rows_or_one_line_errors(tmp_path, text):
    try:
        rows = read_class_sets(_write(tmp_path, text))
    except InputError as exc:
        assert "\n" not in str(exc)
        return
    for row in rows:
        assert row.recording and row.classes and all(c.strip() == c and c for c in row.classes)
        assert row.start is None or row.end is None or row.start < row.end


def _log(times, experiment=None):
    return Recording(time=np.asarray(times, dtype=float), rate=10.0, channels={"x": np.arange(len(times), dtype=float)},
                     source="log.csv", experiment=experiment)


def test_a_span_takes_start_inclusive_end_exclusive_and_is_named():
    rec = _log(np.arange(100) / 10.0)
    part = Declared("log.csv", ("a",), 2.0, 3.0).take(rec)
    np.testing.assert_allclose(part.time, np.arange(20, 30) / 10.0)
    assert part.source == "log.csv[2-3 s]"
    assert len(Declared("log.csv", ("a",), None, 1.0).take(rec)) == 10
    assert len(Declared("log.csv", ("a",), 9.5, None).take(rec)) == 5
    assert Declared("log.csv", ("a",)).take(rec) is rec


def test_a_span_without_samples_or_of_several_experiments_is_refused():
    rec = _log(np.arange(100) / 10.0)
    with pytest.raises(InputError, match=r"log.csv\[20-30 s\]: no sample in this span; the log runs from 0 s to 9.9 s"):
        Declared("log.csv", ("a",), 20.0, 30.0).take(rec)
    two = _log(np.r_[np.arange(50), np.arange(50)] / 10.0, experiment=np.repeat([1, 2], 50))
    with pytest.raises(InputError, match="holds 2 experiments, so a time span is ambiguous; name one as PATH@K"):
        Declared("log.csv", ("a",), 1.0, 2.0).take(two)
