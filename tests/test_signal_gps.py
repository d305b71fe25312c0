"""GPS-only tracks: speed, distance and the GPS longitudinal acceleration, or a plain refusal."""

import datetime as dt

import gpxpy
import gpxpy.gpx
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io import read_recording
from spotfree.signal.features import ride_features
from spotfree.signal.gps import gps_features

EAST_PER_METRE = 1 / 111_320.0  # degrees of longitude per metre at the equator


def braking_track(path, with_speed=True):
    """A GPX track along the equator: 4 m/s for 20 s, then braking at 0.5 m/s^2 to a stop (8 s), a fix per second."""
    t = np.arange(0, 29.0)
    speed = np.where(t < 20, 4.0, np.maximum(4.0 - 0.5 * (t - 20), 0.0))
    x = np.where(t < 20, 4.0 * t, 80 + 4.0 * (t - 20) - 0.25 * (t - 20) ** 2)
    gpx = gpxpy.gpx.GPX()
    segment = gpxpy.gpx.GPXTrackSegment()
    start = dt.datetime(2024, 5, 1, 10, 0, 0, tzinfo=dt.timezone.utc)
    for ti, xi, vi in zip(t, x, speed):
        point = gpxpy.gpx.GPXTrackPoint(0.0, xi * EAST_PER_METRE, elevation=5.0, time=start + dt.timedelta(seconds=ti))
        if with_speed:
            point.speed = vi
        segment.points.append(point)
    track = gpxpy.gpx.GPXTrack()
    track.segments.append(segment)
    gpx.tracks.append(track)
    path.write_text(gpx.to_xml(version="1.0"))
    return path, t, x, speed


@pytest.mark.parametrize("with_speed", [True, False])
def test_a_gpx_track_gives_speed_distance_and_braking(tmp_path, with_speed):
    path, t, x, speed = braking_track(tmp_path / "ride.gpx", with_speed)
    feats = gps_features(read_recording(path))
    at = lambda s: int(np.argmin(np.abs(feats.time - s)))  # noqa: E731
    assert feats.channels["distance"][at(28)] == pytest.approx(x[-1], rel=0.01)
    assert feats.channels["speed"][at(10)] == pytest.approx(4.0, abs=0.05)
    assert feats.channels["gps_acc_long"][at(10)] == pytest.approx(0.0, abs=0.05)
    assert feats.channels["gps_acc_long"][at(24)] == pytest.approx(-0.5, abs=0.1)


def test_the_command_writes_gps_features_for_a_track_and_says_why(tmp_path):
    path, *_ = braking_track(tmp_path / "ride.gpx")
    result = CliRunner().invoke(app, ["features", str(path), "-o", str(tmp_path / "f.csv")])
    assert result.exit_code == 0, result.output
    said = " ".join(result.stdout.split())  # the console wraps long lines
    assert "GPS features" in said and "need the accelerometer and gyroscope" in said
    assert "read: " in result.stderr and "GPX track" in result.stderr
    table = pd.read_csv(tmp_path / "f.csv")
    assert list(table.columns) == ["time", "speed", "distance", "gps_acc_long"]


def test_ride_features_of_a_track_say_plainly_that_motion_sensors_are_needed(tmp_path):
    path, *_ = braking_track(tmp_path / "ride.gpx")
    with pytest.raises(InputError, match="GPX track holds GPS fixes only, no motion sensors"):
        ride_features(read_recording(path))


def test_training_on_a_track_is_refused_in_one_line_that_names_the_motion_sensors(tmp_path):
    path, *_ = braking_track(tmp_path / "ride.gpx")
    result = CliRunner().invoke(app, ["train", "-o", str(tmp_path / "m.npz"), "--experiment", f"{path}=cruising"])
    assert result.exit_code == 2 and result.stderr.count("error:") == 1
    said = " ".join(result.stderr.split())
    assert "no motion sensors" in said and "accelerometer and gyroscope" in said and "spotfree features" in said
