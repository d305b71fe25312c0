"""Property tests of the readers: CSV round trips, dialects, merging, and junk that must only raise InputError."""

import io
import gzip
import tempfile
import zipfile
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from spotfree.errors import InputError
from spotfree.io import read_recording
from spotfree.io.checks import detect_dialect, numbers, read_table
from spotfree.io.csvlog import read_csv, write_csv
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
DENSE = ("roll", "pitch", "pressure", "temp")
SPARSE = ("lat", "speed")
finite = st.floats(min_value=-1e12, max_value=1e12, allow_nan=False, allow_subnormal=False)
label_text = st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc", "Zl", "Zp")), max_size=6)


@st.composite
def recordings(draw):
    """Arbitrary finite Recordings as the simulator writes them: uniform experiments, sparse GPS, truth."""
    rate = draw(st.sampled_from([0.5, 1.0, 20.0, 100.0, 1000.0]))
    sizes = draw(st.lists(st.integers(2, 15), min_size=1, max_size=3))
    numbers_ = sorted(draw(st.lists(st.integers(0, 99), min_size=len(sizes), max_size=len(sizes), unique=True)))
    starts = [draw(st.floats(0, 2e9)) for _ in sizes]
    time = np.concatenate([t0 + np.arange(n) / rate for t0, n in zip(starts, sizes)])
    n = len(time)
    dense = draw(st.lists(st.sampled_from(DENSE), min_size=1, max_size=len(DENSE), unique=True))
    sparse = draw(st.lists(st.sampled_from(SPARSE), max_size=len(SPARSE), unique=True))
    channels = {c: np.array(draw(st.lists(finite, min_size=n, max_size=n))) for c in dense}
    for c in sparse:
        # a speed of exactly -1 is iOS's mark for an unknown speed, which the reader takes as a missing sample
        cell = finite.filter(lambda v: v != -1.0) if c == "speed" else finite
        values = draw(st.lists(st.one_of(cell, st.just(np.nan)), min_size=n, max_size=n))
        channels[c] = np.array(values)
    truth = {c: np.array(draw(st.lists(label_text, min_size=n, max_size=n)), dtype=str)
             for c in draw(st.lists(st.sampled_from(["label", "event"]), unique=True))}
    experiment = np.repeat(numbers_, sizes) if len(sizes) > 1 or draw(st.booleans()) else None
    if experiment is None:
        time = time[: sizes[0]]
        channels = {c: v[: sizes[0]] for c, v in channels.items()}
        truth = {c: v[: sizes[0]] for c, v in truth.items()}
    return Recording(time=time, channels=channels, rate=rate, truth=truth, experiment=experiment)


@SETTINGS
@given(recordings())
def test_write_then_read_gives_the_same_recording(rec):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "rec.csv"
        write_csv(rec, path)
        back = read_csv(path, rate=rec.rate)
    assert back.names == rec.names and back.rate == rec.rate
    for name in rec.names:
        np.testing.assert_allclose(back.channels[name], rec.channels[name], rtol=1e-9, atol=0, equal_nan=True)
    resolution = 1e-9 + 4 * np.spacing(np.abs(rec.time).max())
    np.testing.assert_allclose(back.time, rec.time, rtol=0, atol=resolution)
    assert {k: v.tolist() for k, v in back.truth.items()} == {k: v.tolist() for k, v in rec.truth.items()}
    assert (back.experiment is None) == (rec.experiment is None)
    if rec.experiment is not None:
        assert back.experiment.tolist() == rec.experiment.tolist()
    assert back.gaps == [] and back.meta["repairs"] == []


def phyphox_number(x, decimal):
    return "NaN" if not np.isfinite(x) else f"{x:.9E}".replace("E+", "E").replace(".", decimal)


@SETTINGS
@given(
    st.sampled_from([(",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ",")]),
    st.integers(2, 5),  # a recording has a time column and at least one value column
    st.lists(st.lists(st.one_of(finite, st.just(np.nan)), min_size=5, max_size=5), min_size=1, max_size=20),
)
def test_every_phyphox_dialect_is_recognised_and_parsed(dialect, width, rows):
    sep, decimal = dialect
    data = np.array(rows)[:, :width]
    header = sep.join(f'"Column {j} (m/s^2)"' for j in range(width))
    text = header + "\n" + "\n".join(sep.join(phyphox_number(x, decimal) for x in row) for row in data) + "\n"
    found_sep, found_decimal = detect_dialect(text)
    assert found_sep == sep
    table = read_table(text, "t.csv", found_sep, unique=False)
    parsed = np.column_stack([numbers(table, c, "t.csv", found_decimal) for c in table.columns])
    np.testing.assert_allclose(parsed, data, rtol=1e-9, equal_nan=True)


@SETTINGS
@given(
    st.lists(st.floats(0.001, 0.3), min_size=2, max_size=200),
    st.floats(0.0, 5.0),
    st.sampled_from([5.0, 20.0, 50.0]),
)
@example([0.04, 0.04, 0.04], 1.7213706884905935, 50.0)  # the last grid time passed the last sample by a rounding error
def test_merged_grids_are_uniform_and_nan_exactly_inside_reported_gaps(steps, start, rate):
    time = start + np.cumsum(steps)
    stream = Stream(time, np.sin(time), ("gx",))
    if 1.0 / stream.native_rate > 0.2:
        return
    rec = merge_streams({"gyro": stream}, rate=rate, max_gap=0.2)
    assert rec.time[0] == time[0] and rec.time[-1] <= time[-1] + 1e-9
    assert np.allclose(np.diff(rec.time), 1 / rate)
    assert [(g.start, g.end) for g in rec.gaps] == [(a, b) for a, b in zip(time[:-1], time[1:]) if b - a > 0.2]
    inside = np.zeros(len(rec), dtype=bool)
    for gap in rec.gaps:
        inside |= (rec.time > gap.start) & (rec.time < gap.end)
    assert np.array_equal(np.isnan(rec.channels["gx"]), inside)


def read_or_refuse(data: bytes, suffix: str) -> None:
    """Read ``data`` saved under ``suffix``; anything but a Recording or an InputError fails the test."""
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"junk{suffix}"
        path.write_bytes(data)
        try:
            assert isinstance(read_recording(path), Recording)
        except InputError as exc:
            assert "\n" not in str(exc)


SUFFIXES = st.sampled_from([".csv", ".txt", ".json", ".gpx", ".zip", ".dat", ""])


@SETTINGS
@given(st.binary(max_size=400), SUFFIXES)
def test_junk_bytes_only_ever_raise_input_error(data, suffix):
    read_or_refuse(data, suffix)


cells = st.sampled_from(["0", "1.5", "-2e3", "", "nan", "NaN", "x", "1,5", "9.81", "0.05", "1e400", '"', " ", "inf"])
headers = st.sampled_from(["time", "Time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "label", "experiment",
                           '"Time (s)"', '"Acceleration x (m/s^2)"', '"Gyroscope z (rad/s)"', "acc_x", "seconds_elapsed"])


@SETTINGS
@given(st.lists(headers, min_size=1, max_size=6), st.lists(st.lists(cells, min_size=0, max_size=7), max_size=30),
       st.sampled_from([",", ";", "\t"]), SUFFIXES)
def test_junk_tables_only_ever_raise_input_error(header, rows, sep, suffix):
    text = sep.join(header) + "\n" + "\n".join(sep.join(row) for row in rows)
    read_or_refuse(text.encode(), suffix)
    read_or_refuse(gzip.compress(text.encode()), suffix + ".gz")  # read as the file it holds


@SETTINGS
@given(st.binary(min_size=2, max_size=400))
def test_junk_after_the_gzip_magic_only_ever_raises_input_error(data):
    read_or_refuse(b"\x1f\x8b" + data, ".csv.gz")


@SETTINGS
@given(st.dictionaries(st.sampled_from(["Metadata.csv", "Gyroscope.csv", "TotalAcceleration.csv", "Location.csv",
                                        "Accelerometer.csv", "meta/time.csv", "Gravity.csv"]),
                       st.binary(max_size=200), min_size=1))
def test_junk_inside_an_export_zip_only_ever_raises_input_error(members):
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    read_or_refuse(buffer.getvalue(), ".zip")


json_values = st.one_of(st.none(), st.booleans(), st.integers(-10**20, 10**20), finite, st.text(max_size=5),
                        st.sampled_from(["1700000000000000000", "0.01", "ios", "android", "x"]))
json_keys = st.sampled_from(["sensor", "time", "seconds_elapsed", "x", "y", "z", "platform", "standardisation",
                             "latitude", "longitude", "speed", "sensors", "sampleRateMs"])
sensor_names = st.sampled_from(["Metadata", "Gyroscope", "TotalAcceleration", "Accelerometer", "Gravity", "Location"])


@SETTINGS
@given(st.lists(st.fixed_dictionaries({"sensor": sensor_names}, optional={}).flatmap(
    lambda d: st.dictionaries(json_keys, json_values, max_size=6).map(lambda extra: {**extra, **d})), max_size=12))
def test_junk_json_exports_only_ever_raise_input_error(records):
    import json

    read_or_refuse(json.dumps(records).encode(), ".json")


gpx_attrs = st.sampled_from(['lat="35"', 'lon="139"', 'lat="x"', 'lon=""', 'lat="1e400"', 'lon="-200"'])
gpx_children = st.sampled_from(["<time>2023-11-14T22:13:20Z</time>", "<time>yesterday</time>", "<ele>x</ele>",
                                "<ele>12</ele>", "<speed>-1</speed>", "<course>400</course>", "<time></time>",
                                "<extensions><speed>oops</speed></extensions>", ""])


@SETTINGS
@given(st.lists(st.tuples(st.lists(gpx_attrs, max_size=2), st.lists(gpx_children, max_size=3)), max_size=6),
       st.sampled_from(["trk><trkseg", "rte"]))
def test_junk_gpx_points_only_ever_raise_input_error(points, container):
    tag = "rtept" if container == "rte" else "trkpt"
    body = "".join(f"<{tag} {' '.join(a)}>{''.join(c)}</{tag}>" for a, c in points)
    close = "</trkseg></trk" if container != "rte" else "</rte"
    text = f'<gpx version="1.1" creator="t"><{container}>{body}{close}></gpx>'
    read_or_refuse(text.encode(), ".gpx")
