"""GPX tracks: write and read back, speed from the file or from positions, bad files."""

import datetime as dt

import gpxpy
import gpxpy.geo
import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io import detect_format, read_recording
from spotfree.io.gpx import read_gpx, write_gpx
from spotfree.io.recording import Recording

START = 1_700_000_000.0


def track(n=200, rate=10.0, every=10):
    """A Recording with a fix every ``every`` samples and two experiments."""
    time = np.arange(n) / rate
    fix = np.arange(n) % every == 3
    def sparse(values):
        return np.where(fix, values, np.nan)
    return Recording(
        time=time, rate=rate, experiment=np.repeat([1, 2], n // 2), meta={"start_epoch": START},
        channels={"lat": sparse(35.0 + 1e-5 * time), "lon": sparse(139.0 + 2e-5 * time), "alt": sparse(10 + time),
                  "speed": sparse(2.0 + 0.1 * time), "heading": sparse(np.full(n, 0.5)),
                  "ax": np.zeros(n)},
    )


def test_write_then_read_gives_the_fixes_back(tmp_path):
    rec = track()
    write_gpx(rec, tmp_path / "ride.gpx")
    assert detect_format(tmp_path / "ride.gpx") == "gpx"
    back = read_recording(tmp_path / "ride.gpx", rate=10.0)
    original = np.flatnonzero(np.isfinite(rec.channels["lat"]))
    fixes = np.flatnonzero(np.isfinite(back.channels["lat"]))
    assert len(fixes) == len(original) == 20
    assert back.meta["start_epoch"] == pytest.approx(START + rec.time[original[0]], abs=1e-6)
    np.testing.assert_allclose(back.time[fixes] + back.meta["start_epoch"], START + rec.time[original], atol=1e-6)
    for name in ("lat", "lon", "alt", "speed", "heading"):
        np.testing.assert_allclose(back.channels[name][fixes], rec.channels[name][original], rtol=1e-9)
    assert back.meta["repairs"] == []


def test_one_segment_per_experiment(tmp_path):
    write_gpx(track(), tmp_path / "ride.gpx")
    document = gpxpy.parse((tmp_path / "ride.gpx").read_text())
    assert [len(s.points) for s in document.tracks[0].segments] == [10, 10]


def test_speed_from_a_garmin_extension_is_read(tmp_path):
    points = "".join(
        f'<trkpt lat="{35 + 1e-4 * k}" lon="139"><time>2023-11-14T22:13:{20 + k:02d}Z</time>'
        f"<extensions><gpxtpx:TrackPointExtension><gpxtpx:speed>{1.5 + k}</gpxtpx:speed>"
        f"</gpxtpx:TrackPointExtension></extensions></trkpt>"
        for k in range(5)
    )
    path = tmp_path / "garmin.gpx"
    path.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="t" xmlns="http://www.topografix.com/GPX/1/1" '
        'xmlns:gpxtpx="http://www.garmin.com/xmlschemas/TrackPointExtension/v1">'
        f"<trk><trkseg>{points}</trkseg></trk></gpx>"
    )
    rec = read_gpx(path, rate=5.0)
    assert rec.channels["speed"][np.isfinite(rec.channels["speed"])] == pytest.approx([1.5, 2.5, 3.5, 4.5, 5.5])
    assert rec.meta["start_epoch"] == dt.datetime(2023, 11, 14, 22, 13, 20, tzinfo=dt.timezone.utc).timestamp()


def test_speed_is_derived_from_positions_when_missing(tmp_path):
    lats = 35 + 1e-4 * np.arange(6)
    points = "".join(
        f'<trkpt lat="{lat}" lon="139"><time>2023-11-14T22:13:{20 + 2 * k:02d}Z</time></trkpt>'
        for k, lat in enumerate(lats)
    )
    path = tmp_path / "plain.gpx"
    path.write_text(f'<gpx version="1.1" creator="t"><trk><trkseg>{points}</trkseg></trk></gpx>')
    rec = read_recording(path)
    step = gpxpy.geo.haversine_distance(lats[0], 139, lats[1], 139) / 2.0
    assert rec.channels["speed"][np.isfinite(rec.channels["speed"])] == pytest.approx(np.full(6, step), rel=1e-3)
    assert any("speed derived from consecutive fixes" in r for r in rec.meta["repairs"])


BAD_GPX = {
    "untimed.gpx": ('<gpx version="1.1" creator="t"><trk><trkseg><trkpt lat="1" lon="2"/></trkseg></trk></gpx>',
                    r"untimed\.gpx: track point 1 has no <time>"),
    "empty.gpx": ('<gpx version="1.1" creator="t"></gpx>', r"empty\.gpx: no track or route points"),
    "broken.gpx": ("<gpx><trk>", r"broken\.gpx: not a readable GPX file"),
}


@pytest.mark.parametrize("name", sorted(BAD_GPX))
@pytest.mark.parametrize("reader", [read_gpx, read_recording], ids=["read_gpx", "read_recording"])
def test_unusable_gpx_files_are_refused(name, reader, tmp_path):
    text, message = BAD_GPX[name]
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        reader(path)


def test_writing_without_fixes_is_refused(tmp_path):
    rec = track()
    with pytest.raises(InputError, match="no 'lat' and 'lon' channels"):
        write_gpx(rec.with_channels({"ax": rec.channels["ax"]}), tmp_path / "x.gpx")
    empty = rec.with_channels({"lat": np.full(len(rec), np.nan), "lon": np.full(len(rec), np.nan)})
    with pytest.raises(InputError, match="hold no fix"):
        write_gpx(empty, tmp_path / "x.gpx")
    assert not (tmp_path / "x.gpx").exists()


def test_a_route_without_speed_gets_speed_from_distance_over_time(tmp_path):
    path = tmp_path / "route.gpx"
    path.write_text(
        '<?xml version="1.0"?><gpx version="1.1" creator="t"><rte>'
        '<rtept lat="1" lon="2"><time>2020-01-01T00:00:00Z</time></rtept>'
        '<rtept lat="1.0001" lon="2"><time>2020-01-01T00:00:01Z</time></rtept></rte></gpx>'
    )
    rec = read_gpx(path)
    speed = rec.channels["speed"][np.isfinite(rec.channels["speed"])]
    np.testing.assert_allclose(speed, 11.12, rtol=2e-3)  # 1e-4 degree of latitude in one second
