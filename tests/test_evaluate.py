"""`spotfree evaluate`: per-sample scores on hand-made label streams, and one quick run of the whole report."""

import re
import sys
from importlib.util import find_spec
from types import SimpleNamespace

import numpy as np
import pytest
from typer.testing import CliRunner

import spotfree.evaluation.report
import spotfree.evaluation.run
from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.evaluation.lateral_road import MODELS, STREAMS, ModelSpec, Split, scored_labels
from spotfree.evaluation.measure import MINIROCKET, MINIROCKET_OFFLINE
from spotfree.evaluation.report import CONFUSION_FIGURES, GOALS, TIMELINES
from spotfree.sim.scenarios import CLASSES
from spotfree.evaluation.metrics import (
    EventScore,
    Score,
    accuracy,
    class_accuracy,
    confusion_matrix,
    event_detection,
    label_count,
    near_transitions,
)

runner = CliRunner()

SECTIONS = ("## Goals at a glance", "## Summary", "## Protocol", "## Training", "## Accuracy per sample", "## The paper's count", "## Sudden stops as events",
            "## Accuracy per true class", "## Confusion matrices", "## Decision latency",
            "## CRC_RLS vs SRC vs B_SRC", "## Peers on the same tests", "## Lateral manoeuvres and road surface",
            "## The hand", "## Results figures")
FIGURES = ("training.png", "results-normal-braking.png", "results-sudden-braking.png", "results-cruising.png",
           *CONFUSION_FIGURES.values(), *TIMELINES.values())


# ---------------------------------------------------------------- metrics

def test_transition_band_marks_half_a_second_each_side_of_a_change_inside_one_experiment():
    truth = np.array(["c"] * 6 + ["n"] * 6 + ["c"] * 4 + ["n"] * 4)
    experiment = np.array([1] * 16 + [2] * 4)
    mask = near_transitions(truth, experiment, rate=4.0, band=0.5)  # 2 samples each side
    assert np.flatnonzero(mask).tolist() == [4, 5, 6, 7, 10, 11, 12, 13]
    # without the experiment column, the change at sample 16 counts too
    assert np.flatnonzero(near_transitions(truth, None, rate=4.0, band=0.5)).tolist() == [
        4, 5, 6, 7, 10, 11, 12, 13, 14, 15, 16, 17]


def test_accuracy_scores_labelled_samples_only_with_and_without_the_transition_band():
    truth = np.array(["c", "c", "c", "n", "n", "n", "c", "c"])
    label = np.array(["", "c", "n", "n", "c", "n", "c", "n"])
    assert accuracy(label, truth) == Score(4, 7)
    near = near_transitions(truth, rate=1.0, band=1.0)  # samples 2, 3 and 5, 6
    assert np.flatnonzero(near).tolist() == [2, 3, 5, 6]
    assert accuracy(label, truth, ~near) == Score(1, 3)
    assert Score(4, 7).rate == pytest.approx(4 / 7) and np.isnan(Score(0, 0).rate)
    assert Score(1, 2) + Score(3, 4) == Score(4, 6)


def test_class_accuracy_is_recall_per_true_class():
    truth = np.array(["c", "c", "c", "c", "n", "n", "s"])
    label = np.array(["c", "c", "n", "", "n", "s", ""])
    scores = class_accuracy(label, truth, ["c", "n", "s"])
    assert scores == {"c": Score(2, 3), "n": Score(1, 2), "s": Score(0, 0)}


def test_confusion_matrix_rows_truth_columns_labels():
    truth = np.array(["c", "c", "c", "n", "n", "s", "s", "c", "x"])
    label = np.array(["c", "n", "s", "n", "", "s", "n", "unknown", "c"])
    counts = confusion_matrix(label, truth, ["c", "n", "s"])
    np.testing.assert_array_equal(counts, [[1, 1, 1], [0, 1, 0], [0, 1, 1]])
    assert confusion_matrix(np.array(["", ""]), np.array(["c", "n"]), ["c", "n"]).sum() == 0


def test_the_papers_count_is_one_label_out_of_all_labels():
    label = np.array([""] * 19 + ["cruising"] * 6000 + ["normal-braking"] * 1794 + ["sudden-braking"] * 6)
    assert label_count(label, "sudden-braking") == Score(6, 7800)
    assert label_count(label, "sudden-braking").rate == pytest.approx(6 / 7800)


def test_an_event_is_detected_by_a_label_run_within_the_tolerance_and_a_run_meeting_none_is_a_false_alarm():
    truth = np.array(list("ssssskkksssssssssssssssskkkssssssssssssss"))  # events at 5-8 and 24-27
    label = np.array(list("ssssssskkkksssskssssssssssssssskssssssss"  # late by 2; alarm at 15; 31 is 4 after 27
                          "s"))
    # at 10 Hz the tolerance of 0.5 s is 5 samples: the run at 15 starts 7 after the first event, 9 before the second
    # riding without the event: 41 labelled samples less the 6 true kerb samples
    assert event_detection(label, truth, "k", rate=10.0) == EventScore(2, 2, 1, 3.5)
    # 0.3 s (3 samples) still reaches the first (7 < 8 + 3) but not the second from 31 (31 >= 27 + 3)
    assert event_detection(label, truth, "k", rate=10.0, tolerance=0.3) == EventScore(1, 2, 2, 3.5)
    score = event_detection(label, truth, "k", rate=10.0)
    assert score.rate == 1.0 and score.false_alarms_per_hour == pytest.approx(3600 / 3.5)
    assert score.precision == pytest.approx(2 / 3) and score.f1 == pytest.approx(0.8)  # 2 of 3 runs, 2 of 2 events
    assert np.isnan(EventScore(0, 0, 0, 1.0).precision) and np.isnan(EventScore(0, 0, 0, 1.0).f1)


def test_event_detection_scores_each_experiment_alone_and_counts_labelled_seconds_without_the_event_only():
    truth = np.array(list("sskkss" "ssssss"))
    label = np.array(list("ssssss" "kk" + "ss" + "ss"))  # the run would meet the event across the border
    label[0] = ""
    experiment = np.repeat([1, 2], 6)
    # tolerance 1.5 s = 3 samples: the run at 6 would meet the event at 2-4 within one ride (6 < 4 + 3)
    # 11 labelled samples, 2 of them the true event: 9 samples = 4.5 s without it
    assert event_detection(label, truth, "k", experiment, rate=2.0, tolerance=1.5) == EventScore(0, 1, 1, 4.5)
    assert event_detection(label, truth, "k", None, rate=2.0, tolerance=1.5) == EventScore(1, 1, 0, 4.5)
    assert np.isnan(event_detection(label, truth, "x", rate=2.0).rate)


def test_event_detection_refuses_a_bad_rate_tolerance_or_experiment_column():
    truth = np.array(["k", "s"])
    with pytest.raises(InputError, match="rate > 0 Hz and a tolerance >= 0 s"):
        event_detection(truth, truth, "k", rate=0.0)
    with pytest.raises(InputError, match="rate > 0 Hz and a tolerance >= 0 s"):
        event_detection(truth, truth, "k", tolerance=float("nan"))
    with pytest.raises(InputError, match="one number per sample"):
        event_detection(truth, truth, "k", experiment=[1, 1, 1])


def test_road_samples_where_the_vehicle_stands_still_are_not_scored():
    labels = np.array(["smooth", "kerb", "smooth", "cobblestone"])
    data = Split([], None, [], np.array([0.0, 0.29, 0.3, 5.0]))
    assert scored_labels(ModelSpec("road", moving_only=True), labels, data).tolist() == [
        "", "", "smooth", "cobblestone"]
    assert scored_labels(ModelSpec("lateral"), labels, data).tolist() == labels.tolist()
    assert MODELS["road"].moving_only and not MODELS["lateral"].moving_only


def test_metrics_refuse_streams_of_different_lengths():
    with pytest.raises(InputError, match="one label per sample"):
        accuracy(np.array(["c", "c"]), np.array(["c"]))


# ---------------------------------------------------------------- the command

HAS_AEON = find_spec("aeon") is not None


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """One `spotfree evaluate --quick` into a folder that already holds a file of the user's (minutes: the tests that
    read it are marked slow).

    Without aeon (it is in the `eval` extra, not in `test`), the run keeps the one peer that needs no aeon, 1-NN, so
    that everything else is still run; the aeon peers themselves are tested in test_peers.py.
    """
    folder = tmp_path_factory.mktemp("evaluation") / "out"
    folder.mkdir()
    (folder / "notes.txt").write_text("mine")
    with pytest.MonkeyPatch.context() as patch:
        if not HAS_AEON:
            make_peers = spotfree.evaluation.run.make_peers
            patch.setattr(spotfree.evaluation.run, "check_peers", lambda: None)
            patch.setattr(spotfree.evaluation.run, "make_peers", lambda *args: {
                k: v for k, v in make_peers(*args).items() if k == "1-NN (supervised)"})
        result = runner.invoke(app, ["evaluate", "--quick", "-o", str(folder), "--seed", "0"],
                               catch_exceptions=False)
    return folder, result


@pytest.mark.slow
def test_quick_run_writes_report_with_every_section_and_the_figures(quick_run):
    folder, result = quick_run
    assert result.exit_code == 0, result.output
    report = (folder / "report.md").read_text()
    positions = [report.find(section) for section in SECTIONS]
    assert -1 not in positions and positions == sorted(positions), positions
    for figure in FIGURES:
        assert (folder / figure).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert f"]({figure})" in report
    assert (folder / "notes.txt").read_text() == "mine"
    assert not [p for p in folder.parent.iterdir() if p.name.startswith(".out.")]


@pytest.mark.slow
def test_quick_run_report_quotes_the_paper_beside_measured_figures(quick_run):
    folder, result = quick_run
    report = (folder / "report.md").read_text()
    count = re.search(r"sudden-braking labels in the normal-braking tests: (\d+) of (\d+)", result.output)
    assert count, result.output
    assert f"| 6 of 7800 (0.077%) | {count[1]} of {count[2]} (" in report
    crc = re.search(r"\| normal-braking \| 99\.92 [^|]* \| (\d+\.\d\d) \|", report)
    assert crc and f"normal-braking: {crc[1]}% of" in result.output
    assert "0.39" in report and "112" in report
    for peer in ("MiniRocket (supervised)", "1-NN (supervised)", "ClaSP") if HAS_AEON else ("1-NN (supervised)",):
        assert re.search(rf"\| {re.escape(peer)}[^|]* \| \d+\.\d \| \d+\.\d\d \|", report), peer
    for method in ("CRC_RLS", "SRC", "B_SRC"):
        assert re.search(rf"\| {method} \| \d+ \| \d+\.\d\d \|", report), method


PAIR = r"(\d+\.\d\d|-) / (\d+\.\d\d|-)"


def _rate(cell: str) -> float:
    return float("nan") if cell == "-" else float(cell)


@pytest.mark.slow
def test_quick_run_report_scores_every_lateral_and_road_class_in_every_stream_and_times_the_three_models(quick_run):
    folder, _ = quick_run
    report = (folder / "report.md").read_text()
    streams = [*STREAMS, *([MINIROCKET, MINIROCKET_OFFLINE] if HAS_AEON else [])]
    for scenario in ("lateral", "road"):
        section = report.split(f"### {scenario}\n", 1)[1].split("\n### ", 1)[0]
        header = "| true class | scored samples (live) | " + " | ".join(
            f"{s}: strict / away (%)" for s in streams) + " | goal met |"
        assert header in section, scenario
        for name in CLASSES[scenario]:
            row = re.search(rf"\| {name} \| (\d+) \| " + r" \| ".join([PAIR] * len(streams))
                            + r" \| (yes|no|-) \|", section)
            assert row and int(row[1]) > 0, (scenario, name)
            cells = [_rate(x) for x in row.groups()[1:-1]]
            live_away, vote_away = cells[1], cells[5]
            if name in MODELS[scenario].detections:  # a kerb lies within 0.5 s of its changes: no sample away
                assert np.isnan(live_away) and row[row.lastindex] == "-"
            else:
                assert row[row.lastindex] == ("yes" if vote_away >= 98.0 and live_away >= 95.0 else "no")
        assert f"Offline vote: the segment vote at penalty {MODELS[scenario].segments:g}" in section
        assert ("then the event vote outside straight" in section) == MODELS[scenario].events
        assert f"![{scenario} confusion matrices]({CONFUSION_FIGURES[scenario]})" in section
        for name in MODELS[scenario].detections:
            table = section.split(f"{name.capitalize()} strikes as events", 1)[1]
            for stream in streams:
                row = re.search(rf"\| {re.escape(stream)} \| (\d+) / (\d+) \| (\d+) \| ([\d.]+|-) \| ([\d.]+) \| "
                                r"([\d.]+|-) \| (\d+\.\d) \|", table)
                assert row, (scenario, stream)
                hit, events, alarms = int(row[1]), int(row[2]), int(row[3])
                assert 0 < events and float(row[5]) == pytest.approx(hit / events, abs=6e-4)
                if hit + alarms:
                    assert float(row[4]) == pytest.approx(hit / (hit + alarms), abs=6e-4)
        assert ("strikes as events" in section) == bool(MODELS[scenario].detections)
    assert re.search(r"not scored where the simulator's true speed is under\s+0\.3 m/s", report)
    assert re.search(r"- median \d+\.\d us, p99 \d+\.\d us per raw sample, (within|over) the 50 us budget", report)
    assert "- stream labels unlike the batch labels of the same rides: 0." in report


@pytest.mark.slow
def test_quick_run_summary_gives_one_line_per_model_with_its_goal_verdict(quick_run):
    folder, _ = quick_run
    report = (folder / "report.md").read_text()
    glance = report.split("## Goals at a glance", 1)[1].split("\n## ", 1)[0]
    cell = r"(\d+\.\d\d) \(([a-z-]+)\)"
    for model in ("braking (kernel CRC_RLS)", "lateral (offline: the votes)", "road (offline: the votes)"):
        row = re.search(rf"\| {re.escape(model)} \| {cell} \| {cell} \| (?:{cell}|-) \| (?:{cell}|-) \| [^|]+ \| "
                        r"(yes|no) \| (yes|no|-) \|", glance)
        assert row, model
        offline, live = float(row[1]), float(row[3])
        assert row[9] == ("yes" if offline >= 100 * GOALS["offline"] and live >= 100 * GOALS["live"] else "no")
        if HAS_AEON:  # each mode against the peer's same mode
            assert row[10] == ("yes" if offline >= float(row[5]) and live >= float(row[7]) else "no")
        else:
            assert row[5] is None and row[7] is None and row[10] == "-"
    found = {}
    for model in ("sudden stops", "kerb strikes"):
        row = re.search(rf"\| {model} \| F1 ([\d.]+|-), (\d+) / (\d+), (\d+) false alarms \(([\d.]+) per hour\) \|"
                        r" F1 ([\d.]+|-), (\d+) / (\d+), (\d+) false alarms \(([\d.]+) per hour\) \|[^\n]* (yes|no) \| "
                        r"(yes|no|-) \|", glance)
        assert row and int(row[3]) > 0, model
        met = all(f != "-" and float(f) >= 0.95 and float(h) <= 2.0 for f, h in ((row[1], row[5]), (row[6], row[10])))
        assert row[11] == ("yes" if met else "no")
        found[model] = row
    warned = re.search(r"\| sudden stops as the rider is warned \| F1 ([\d.]+|-), (\d+) / (\d+), (\d+) false alarms "
                       r"\(([\d.]+) per hour\) \| F1 ([\d.]+|-), (\d+) / (\d+), (\d+) false alarms", glance)
    raw = found["sudden stops"]
    # the assistant merges label runs into stops and drops runs too short to warn: never more detections or alarms
    assert warned and warned[3] == raw[3] and int(warned[2]) <= int(raw[2]) and int(warned[4]) <= int(raw[4])
    assert int(warned[7]) <= int(raw[7]) and int(warned[9]) <= int(raw[9])
    stops = report.split("## Sudden stops as events", 1)[1].split("\n## ", 1)[0]
    for alignment, (detected, alarms) in (("centred", (2, 4)), ("causal", (7, 9))):  # the goals' offline, live cells
        detail = re.search(rf"\| spotfree kernel CRC_RLS \({alignment}\), as the rider is warned \| (\d+) / \d+ \| "
                           r"(\d+) \|", stops)
        assert detail and (detail[1], detail[2]) == (warned[detected], warned[alarms]), alignment
    postures = re.search(r"\| hand postures \(per frame\) \| (\d+\.\d\d) \| (\d+\.\d\d) \| (\d+\.\d\d|-) \| "
                         r"(\d+\.\d\d|-) \| 100 % \| (yes|no) \| (yes|no|-) \|", glance)
    assert postures and postures[5] == ("yes" if float(postures[1]) == float(postures[2]) == 100.0 else "no")
    gestures = re.search(r"\| hand gestures \(from 10 % of peak speed, 0.1 s collar\) \| (\d+\.\d\d) \| "
                         r"(\d+\.\d\d) \| (\d+\.\d\d|-) \| (\d+\.\d\d|-) \| [^|]+ \| (yes|no) \| (yes|no|-) \|",
                         glance)
    assert gestures and gestures[5] == ("yes" if float(gestures[1]) >= 99.0 and float(gestures[2]) >= 95.0 else "no")
    for row in (postures, gestures):  # the hand's MiniRocket peer offline and live, when aeon is there
        if HAS_AEON:
            assert row[6] == ("yes" if float(row[1]) >= float(row[3]) and float(row[2]) >= float(row[4]) else "no")
        else:
            assert row[3] == row[4] == row[6] == "-"
    assert re.search(r"\| hand gestures \| F1 [\d.]+, \d+ / \d+, \d+ false detections \| F1 [\d.]+, \d+ / \d+, ",
                     glance)


@pytest.mark.slow
def test_quick_run_hand_section_calls_the_hand_evaluation(quick_run):
    folder, _ = quick_run
    report = (folder / "report.md").read_text()
    hand = report.split("## The hand", 1)[1].split("\n## ", 1)[0]
    assert "(`--quick`: fewer people)" in hand
    postures = re.search(r"\| postures per frame \(%\) \| (\d+\.\d\d) \| (\d+\.\d\d) \|", hand)
    # the same figure as the detailed table of evaluation.hand below it
    detail = re.search(r"\| postures, end to end \| \| (\d+\.\d\d) % \| (\d+\.\d\d) % \|", hand)
    assert postures and detail and postures.groups() == detail.groups()
    events = re.search(r"\| gestures as events: precision / recall / F1 \| ([\d.]+) / ([\d.]+) / ([\d.]+) \| "
                       r"([\d.]+) / ([\d.]+) / ([\d.]+) \|", hand)
    assert events
    for p, r, f in (events.groups()[:3], events.groups()[3:]):
        assert float(f) == pytest.approx(2 * float(p) * float(r) / (float(p) + float(r)), abs=2e-3)
    assert "tested on 2 held-out people" in hand and "Gestures as events" in hand
    # the supervised peers beside the recogniser, the same figures in the table at the top and in the detail below
    peers = ("MiniRocket (supervised)", "1-NN (supervised)") if HAS_AEON else ("1-NN (supervised)",)
    header = next(line for line in hand.splitlines() if line.replace(" ", "").startswith("||offline|live|"))
    top = next(line for line in hand.splitlines() if line.startswith("| postures per frame (%) |"))
    columns = [c.strip() for c in header.strip("|").split("|")]
    values = [c.strip() for c in top.strip("|").split("|")]
    for peer in peers:
        row = re.search(rf"\| {re.escape(peer)} \| live \| (\d+\.\d\d) % \| [\d.]+ % \| (\d+\.\d\d) % \|", hand)
        assert row and values[columns.index(f"{peer}, live")] == row[1], peer
    assert f"![hand confusion matrices]({CONFUSION_FIGURES['hand']})" in hand


def test_output_that_is_a_file_is_refused_with_one_line(tmp_path):
    target = tmp_path / "report"
    target.write_text("not a folder")
    result = runner.invoke(app, ["evaluate", "--quick", "-o", str(target)])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "not a folder" in lines[0] and str(target) in lines[0]
    assert target.read_text() == "not a folder"


def test_a_missing_aeon_is_refused_before_the_run_with_the_install_line(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "aeon.classification.convolution_based", None)
    result = runner.invoke(app, ["evaluate", "--quick", "-o", str(tmp_path / "out")])
    assert result.exit_code == 2
    lines = result.output.strip().splitlines()
    assert len(lines) == 1 and "MiniRocketClassifier comes from aeon" in lines[0]
    assert "pip install -e '.[eval]'" in lines[0]
    assert not (tmp_path / "out").exists()


def test_quiet_prints_nothing_but_errors(tmp_path, monkeypatch):
    """``--quiet``: neither the progress nor the headline is printed; the run itself is the same call."""
    calls = []

    def run(output, seed, quick, progress):
        progress("simulating")
        calls.append((output, seed, quick))
        return SimpleNamespace(files=[], seconds=1.0)

    monkeypatch.setattr(spotfree.evaluation.run, "evaluate", run)
    monkeypatch.setattr(spotfree.evaluation.report, "headline", lambda ev: ["a headline"])
    loud = runner.invoke(app, ["evaluate", "--quick", "-o", str(tmp_path / "a")])
    quiet = runner.invoke(app, ["evaluate", "--quick", "-o", str(tmp_path / "b"), "--quiet"])
    assert loud.exit_code == quiet.exit_code == 0
    assert "simulating" in loud.output and "a headline" in loud.output
    assert quiet.output == ""
    assert [c[1:] for c in calls] == [(0, True), (0, True)]
    monkeypatch.undo()
    refused = tmp_path / "report"
    refused.write_text("not a folder")
    result = runner.invoke(app, ["evaluate", "--quick", "-o", str(refused), "--quiet"])
    assert result.exit_code == 2 and "not a folder" in result.output
