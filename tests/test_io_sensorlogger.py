"""Sensor Logger exports: folder, zip and JSON; Android and iOS conventions; bad exports."""

import json
import re
import shutil

import numpy as np
import pandas as pd
import pytest

from spotfree.errors import InputError
from spotfree.io import detect_format, read_recording
from spotfree.io.sensorlogger import read_sensorlogger
from spotfree.signal.features import ride_features
from spotfree.units import GRAVITY

T0_NS = 1_700_000_000_123_456_789
GRAVITY_VECTOR = np.array([0.4, 1.1, np.sqrt(GRAVITY**2 - 0.4**2 - 1.1**2)])  # device frame, Android sign


def specific_force(t):
    """Known specific force (Android convention, m/s^2, device frame) of the recording at times t (s)."""
    linear = np.column_stack([0.5 * np.sin(2 * np.pi * 0.4 * t), 0.3 * np.cos(2 * np.pi * 0.25 * t),
                              0.2 * np.sin(2 * np.pi * 0.3 * t)])
    return linear + GRAVITY_VECTOR


def rotation_rate(t):
    return np.column_stack([0.1 * np.sin(2 * np.pi * 0.5 * t), 0.05 + 0 * t, -0.2 * np.cos(2 * np.pi * 0.2 * t)])


def motion_table(t, xyz):
    """A Sensor Logger motion file: time (epoch ns), seconds_elapsed, then z, y, x."""
    return pd.DataFrame({"time": T0_NS + np.round(t * 1e9).astype(np.int64), "seconds_elapsed": t,
                         "z": xyz[:, 2], "y": xyz[:, 1], "x": xyz[:, 0]})


def location_table():
    t = np.arange(0.3, 20, 1.0)
    speed = np.full(len(t), 2.5)
    speed[3] = -1.0  # invalid
    return pd.DataFrame({
        "time": T0_NS + np.round(t * 1e9).astype(np.int64), "seconds_elapsed": t, "bearingAccuracy": 10.0,
        "speedAccuracy": 0.5, "verticalAccuracy": 3.0, "horizontalAccuracy": 4.0, "speed": speed,
        "bearing": 90.0, "altitude": 40.0, "longitude": 139.7 + 1e-5 * t, "latitude": 35.6 + 1e-5 * t,
    })


def metadata_table(platform, standardised=False, sensors="TotalAcceleration|Gyroscope|Location", rates="10|10|0"):
    return pd.DataFrame([{
        "version": 3, "device name": "test phone", "recording epoch time": T0_NS // 1_000_000,
        "recording time": "2023-11-14_22-13-20", "recording timezone": "UTC", "platform": platform,
        "appVersion": "1.40", "device id": "x", "sensors": sensors, "sampleRateMs": rates,
        "standardisation": str(standardised).lower(), "platform version": "17",
    }])


def export(folder, platform="android", acceleration="total", standardised=False, metadata=True, **metadata_args):
    """Write a Sensor Logger export of the known signals into ``folder`` and return it."""
    folder.mkdir(parents=True, exist_ok=True)
    t_acc = np.arange(0, 20, 0.01)
    t_gyro = 0.004 + np.arange(0, 20, 0.01)
    ios_native = platform == "ios" and not standardised
    sign = -1.0 if ios_native else 1.0
    total = specific_force(t_acc)
    if acceleration == "total":
        motion_table(t_acc, total).to_csv(folder / "TotalAcceleration.csv", index=False)
    if acceleration in ("total", "split", "linear-only"):
        motion_table(t_acc, sign * (total - GRAVITY_VECTOR)).to_csv(folder / "Accelerometer.csv", index=False)
    if acceleration in ("total", "split"):
        gravity = np.tile(GRAVITY_VECTOR, (len(t_acc), 1))
        motion_table(t_acc, sign * gravity).to_csv(folder / "Gravity.csv", index=False)
    if acceleration == "uncalibrated":
        raw = -total / GRAVITY if ios_native else total
        motion_table(t_acc, raw).to_csv(folder / "AccelerometerUncalibrated.csv", index=False)
    motion_table(t_gyro, rotation_rate(t_gyro)).to_csv(folder / "Gyroscope.csv", index=False)
    location_table().to_csv(folder / "Location.csv", index=False)
    if metadata:
        metadata_table(platform, standardised, **metadata_args).to_csv(folder / "Metadata.csv", index=False)
    return folder


def json_export(folder, path):
    """The JSON export of an export folder: one array of records with string values."""
    records = []
    for file in sorted(folder.glob("*.csv")):
        table = pd.read_csv(file, dtype=str, keep_default_na=False)
        records += [{"sensor": file.stem, **row} for row in table.to_dict(orient="records")]
    path.write_text(json.dumps(records))
    return path


def assert_known_signals(rec):
    ok = rec.valid()
    assert ok.mean() > 0.99
    np.testing.assert_allclose(rec.array(["ax", "ay", "az"])[ok], specific_force(rec.time[ok]), atol=2e-3)
    np.testing.assert_allclose(rec.array(["gx", "gy", "gz"])[ok], rotation_rate(rec.time[ok]), atol=2e-3)


def test_an_android_folder_gives_the_known_signals(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "android"))
    assert rec.rate == 20.0 and rec.duration == pytest.approx(20, abs=0.1)
    assert_known_signals(rec)
    assert rec.meta["start_epoch"] == pytest.approx(T0_NS / 1e9) and rec.meta["platform"] == "android"
    assert rec.meta["repairs"] == [] and rec.meta["warnings"] == [] and rec.gaps == []


def test_location_becomes_sparse_gps_in_si_units(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "android"))
    fixes = np.flatnonzero(np.isfinite(rec.channels["lat"]))
    assert len(fixes) == 20
    assert rec.channels["lat"][fixes] == pytest.approx(35.6 + 1e-5 * rec.time[fixes], abs=1e-6)
    assert np.isnan(rec.channels["speed"][fixes[3]]) and rec.channels["speed"][fixes[4]] == 2.5
    assert rec.channels["heading"][fixes] == pytest.approx(np.pi / 2)
    assert rec.channels["alt"][fixes] == pytest.approx(40.0) and rec.channels["gps_accuracy"][fixes] == pytest.approx(4.0)


def test_ios_without_standardisation_is_negated_to_androids_convention(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "ios", platform="ios", acceleration="split"))
    assert_known_signals(rec)
    assert any("negated" in r for r in rec.meta["repairs"])


def test_ios_with_standardisation_is_taken_as_is(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "ios", platform="ios", acceleration="split", standardised=True))
    assert_known_signals(rec)
    assert rec.meta["repairs"] == []


def test_ios_uncalibrated_accelerations_in_g_are_converted(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "ios", platform="ios", acceleration="uncalibrated"))
    assert_known_signals(rec)
    assert any("-9.80665" in r for r in rec.meta["repairs"])


def test_zip_and_json_exports_read_like_the_folder(tmp_path):
    folder = export(tmp_path / "export")
    reference = read_sensorlogger(folder)
    archive = shutil.make_archive(str(tmp_path / "ride"), "zip", tmp_path, "export")
    as_json = json_export(folder, tmp_path / "ride.json")
    for path in (archive, as_json):
        assert detect_format(path) == "sensorlogger"
        rec = read_recording(path)
        np.testing.assert_allclose(rec.array(), reference.array(), rtol=1e-12, equal_nan=True)


def test_a_gyroscope_gap_is_reported(tmp_path):
    folder = export(tmp_path / "gap")
    gyro = pd.read_csv(folder / "Gyroscope.csv")
    gyro[(gyro.seconds_elapsed < 8) | (gyro.seconds_elapsed > 9.5)].to_csv(folder / "Gyroscope.csv", index=False)
    rec = read_sensorlogger(folder)
    assert len(rec.gaps) == 1 and rec.gaps[0].channel == "Gyroscope"
    assert np.isnan(rec.channels["ax"][(rec.time > 8.1) & (rec.time < 9.4)]).all()


def test_duplicated_rows_are_dropped_and_logged(tmp_path):
    folder = export(tmp_path / "dup")
    gyro = pd.read_csv(folder / "Gyroscope.csv")
    pd.concat([gyro.iloc[:500], gyro.iloc[499:]]).to_csv(folder / "Gyroscope.csv", index=False)
    rec = read_sensorlogger(folder)
    assert any("Gyroscope.csv: dropped 1 duplicated row" in r for r in rec.meta["repairs"])


def test_a_rate_far_from_the_declared_one_is_reported(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "slow", rates="1|10|0"))  # TotalAcceleration declared at 1000 Hz
    assert any("TotalAcceleration measured at 100 Hz but declared at 1e+03 Hz" in w for w in rec.meta["warnings"])


def test_split_acceleration_without_metadata_is_refused(tmp_path):
    folder = export(tmp_path / "nometa", platform="ios", acceleration="split", metadata=False)
    with pytest.raises(InputError, match=r"nometa: Accelerometer\.csv \+ Gravity\.csv need Metadata\.csv"):
        read_sensorlogger(folder)


def test_acceleration_without_gravity_is_read_but_refused_for_features_in_the_apps_terms(tmp_path):
    rec = read_sensorlogger(export(tmp_path / "lin", acceleration="linear-only"))
    assert "ax" not in rec.channels and "gx" in rec.channels
    with pytest.raises(InputError, match="Accelerometer.csv holds acceleration without gravity .*enable Gravity in "
                                         "Sensor Logger"):
        ride_features(rec)


def test_a_missing_gyroscope_is_named_with_the_app_setting(tmp_path):
    folder = export(tmp_path / "nogyro")
    (folder / "Gyroscope.csv").unlink()
    rec = read_recording(folder)
    with pytest.raises(InputError, match=r"nogyro: this export has no Gyroscope\.csv: enable Gyroscope in Sensor "
                                         r"Logger"):
        ride_features(rec)


def test_empty_and_unused_files_are_notes_not_errors(tmp_path):
    folder = export(tmp_path / "notes")
    (folder / "AccelerometerUncalibrated.csv").write_text("")  # the app writes it routinely, 0 bytes
    (folder / "Location.csv").write_text("time,seconds_elapsed,bearingAccuracy,speedAccuracy,verticalAccuracy,"
                                         "horizontalAccuracy,speed,bearing,altitude,longitude,latitude\n")
    rec = read_recording(folder)
    assert rec.has_imu and "speed" not in rec.channels
    assert any("AccelerometerUncalibrated.csv: empty file" in r for r in rec.meta["repairs"])
    assert any("Location.csv: no fix" in r for r in rec.meta["repairs"])


def test_a_missing_column_names_the_file_and_the_column(tmp_path):
    folder = export(tmp_path / "col")
    pd.read_csv(folder / "Gyroscope.csv").drop(columns="x").to_csv(folder / "Gyroscope.csv", index=False)
    with pytest.raises(InputError, match=r"col/Gyroscope\.csv: no column 'x'"):
        read_sensorlogger(folder)


def test_a_non_numeric_cell_names_the_file_column_and_line(tmp_path):
    folder = export(tmp_path / "cell")
    gyro = pd.read_csv(folder / "Gyroscope.csv", dtype=str)
    gyro.loc[10, "y"] = "oops"
    gyro.to_csv(folder / "Gyroscope.csv", index=False)
    with pytest.raises(InputError, match=r"Gyroscope\.csv: column 'y', line 12: 'oops' is not a finite number"):
        read_sensorlogger(folder)


def test_an_empty_gyroscope_file_is_a_note_and_then_the_missing_sensor(tmp_path):
    folder = export(tmp_path / "empty")
    (folder / "Gyroscope.csv").write_text("")
    rec = read_sensorlogger(folder)
    assert any("Gyroscope.csv: empty file" in r for r in rec.meta["repairs"])
    with pytest.raises(InputError, match=r"no Gyroscope\.csv: enable Gyroscope"):
        rec.require_imu()


def test_accelerations_in_g_are_refused(tmp_path):
    folder = export(tmp_path / "g")
    total = pd.read_csv(folder / "TotalAcceleration.csv")
    total[["x", "y", "z"]] /= GRAVITY
    total.to_csv(folder / "TotalAcceleration.csv", index=False)
    with pytest.raises(InputError, match="in g; multiply them by 9.80665"):
        read_sensorlogger(folder)


def test_one_sensor_file_alone_is_refused_with_the_fix(tmp_path):
    folder = export(tmp_path / "one")
    with pytest.raises(InputError, match="give the whole export"):
        read_recording(folder / "Gyroscope.csv")


def test_json_that_is_not_an_export_is_refused(tmp_path):
    path = tmp_path / "other.json"
    path.write_text('{"a": 1}')
    with pytest.raises(InputError, match=r"other\.json: not a Sensor Logger JSON export"):
        read_recording(path)
    path.write_text("[{\"sensor\": ")
    with pytest.raises(InputError, match=r"other\.json: not valid JSON"):
        read_recording(path)


@pytest.mark.parametrize("second_start_ns, written", [
    (9_300_000_000_500_000_000, "2264-09-14 21:20 UTC"),  # past pandas' nanosecond dates (2262)
    (10**21, "1e+12 s after 1970"),  # past the year 9999
])
def test_recordings_far_in_the_future_are_refused_with_both_start_times(tmp_path, second_start_ns, written):
    """Two sensors of equal weight from different recordings, one stamped far in the future: the refusal names both
    start times (as seconds beyond the calendar) instead of failing to format one."""
    records = [{"sensor": "Gyroscope", "time": 1_700_000_000_000_000_000, "x": 0.0, "y": 0.0, "z": 0.0},
               {"sensor": "TotalAcceleration", "time": second_start_ns, "x": 0.0, "y": 0.0, "z": 9.8}]
    path = tmp_path / "export.json"
    path.write_text(json.dumps(records))
    expected = f"2 recordings .Gyroscope at 2023-11-14 22:13 UTC; TotalAcceleration at {re.escape(written)}"
    with pytest.raises(InputError, match=expected):
        read_recording(path)
