"""A corpus of phone exports, one per documented file and header layout, all of one known motion.

Each layout below says where its file names and header strings come from. The motion: a phone held still at a
known tilt for 3 s, then turning about the vertical (device frame as Android's: x right, y up, z out of the
screen). Every export with acceleration with g and a gyroscope must read to the known tilt and rotation rate;
every other one must read what it has and refuse the ride features with one line in the app's own terms.
"""

import zipfile

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from spotfree.errors import InputError
from spotfree.io import describe, detect_format, read_recording
from spotfree.signal.features import ride_features
from spotfree.units import GRAVITY

T0_NS = 1_700_000_000_000_000_000
DURATION = 12.0
TILT = Rotation.from_euler("xy", [25.0, -10.0], degrees=True)  # device -> level frame at t = 0
YAW_RATE = 0.6  # rad/s about the vertical from 5 s on


def truth(t):
    """Specific force (m/s^2) and rotation rate (rad/s) in the device frame at times ``t`` (s)."""
    u = np.clip(t - 3.0, 0.0, 2.0)  # the turn rate ramps up smoothly from 3 s to 5 s
    speed_up = 0.5 * (1 - np.cos(np.pi * u / 2))
    yaw = YAW_RATE * (0.5 * (u - 2 / np.pi * np.sin(np.pi * u / 2)) + np.clip(t - 5.0, 0.0, None))
    attitude = Rotation.from_euler("z", yaw[:, None]) * TILT  # device -> world
    force = attitude.inv().apply(np.tile([0.0, 0.0, GRAVITY], (len(t), 1)))
    rate = TILT.inv().apply(np.tile([0.0, 0.0, YAW_RATE], (len(t), 1))) * speed_up[:, None]
    return force, rate


T_ACC = np.arange(0, DURATION, 1 / 100)
T_GYRO = 0.002 + np.arange(0, DURATION, 1 / 100)
T_GPS = np.arange(0.5, DURATION, 1.0)
FORCE, _ = truth(T_ACC)
_, RATE = truth(T_GYRO)
LINEAR = np.zeros_like(FORCE)


def sci(x, decimal="."):
    """A number as phyphox writes it (Java DecimalFormat "0.000000000E0")."""
    return np.format_float_scientific(x, precision=9, unique=False, exp_digits=1).replace("e+", "E").replace(
        "e-", "E-").replace(".", decimal)


def phyphox_text(columns, sep=",", decimal="."):
    """A phyphox CSV: every header quoted, numbers in scientific notation, shorter columns padded with NaN."""
    rows = max(len(v) for v in columns.values())
    lines = [sep.join(f'"{name}"' for name in columns)]
    for i in range(rows):
        lines.append(sep.join(sci(v[i], decimal) if i < len(v) else "NaN" for v in columns.values()))
    return "\n".join(lines) + "\n"


def xyz(names, values):
    return {name: values[:, i] for i, name in enumerate(names)}


PHYPHOX_LOCATION = {  # the Location set of both simple-experiment templates (files cited below)
    "Time (s)": T_GPS, "Latitude (°)": 50.77 + 1e-5 * T_GPS, "Longitude (°)": 6.08 + 0 * T_GPS,
    "Height (m)": 180 + 0 * T_GPS, "Velocity (m/s)": 1.1 + 0 * T_GPS, "Direction (°)": 0 * T_GPS,
    "Horizontal Accuracy (m)": 4 + 0 * T_GPS, "Vertical Accuracy (m)": 6 + 0 * T_GPS,
}

PHYPHOX = {
    # phyphox-android app/src/main/java/de/rwth_aachen/phyphox/ExperimentList/handler/SimpleExperimentCreator.java
    # (writeExportDefinitions): one set per ticked sensor, named after it, headers naming the sensor.
    "android-simple": {
        "Accelerometer.csv": {"Time (s)": T_ACC, **xyz([f"Acceleration {a} (m/s^2)" for a in "xyz"], FORCE)},
        "Gyroscope.csv": {"Time (s)": T_GYRO, **xyz([f"Gyroscope {a} (rad/s)" for a in "xyz"], RATE)},
        "Linear Acceleration.csv": {"Time (s)": T_ACC,
                                    **xyz([f"Linear Acceleration {a} (m/s^2)" for a in "xyz"], LINEAR)},
        "Location.csv": PHYPHOX_LOCATION,
    },
    # phyphox-ios SimpleExperimentData.swift (getExports): the sensor only in the set (file) name, X/Y/Z headers;
    # the gravity set's headers are "Gravity X (m/s^2)".
    "ios-simple": {
        "Accelerometer.csv": {"Time (s)": T_ACC, **xyz([f"{a} (m/s^2)" for a in "XYZ"], FORCE)},
        "Gyroscope.csv": {"Time (s)": T_GYRO, **xyz([f"{a} (rad/s)" for a in "XYZ"], RATE)},
        "Linear Accelerometer.csv": {"Time (s)": T_ACC, **xyz([f"{a} (m/s^2)" for a in "XYZ"], LINEAR)},
        "Gravity.csv": {"Time (s)": T_ACC, **xyz([f"Gravity {a} (m/s^2)" for a in "XYZ"], FORCE)},
        "Location.csv": PHYPHOX_LOCATION,
    },
    # the same template with Accelerometer left unticked: acceleration with g is Linear Accelerometer + Gravity.
    "ios-simple-linear-and-gravity": {
        "Gyroscope.csv": {"Time (s)": T_GYRO, **xyz([f"{a} (rad/s)" for a in "XYZ"], RATE)},
        "Linear Accelerometer.csv": {"Time (s)": T_ACC, **xyz([f"{a} (m/s^2)" for a in "XYZ"], LINEAR)},
        "Gravity.csv": {"Time (s)": T_ACC, **xyz([f"Gravity {a} (m/s^2)" for a in "XYZ"], FORCE)},
    },
    # one set holding two sensors, each after its own time column (phyphox-android DataExport.java writes a set's
    # columns side by side, a shorter one padded with NaN), as in a custom experiment's "Raw Data" set. The
    # header words are a translation (not taken from a real export): the reader relies on the axis letter and
    # the unit only, and the rotation rate is in degrees per second, as a custom experiment may convert it.
    "custom-translated-deg": {
        "Rohdaten.csv": {"Zeit (s)": T_ACC, **xyz([f"Beschleunigung {a} (m/s^2)" for a in "xyz"], FORCE),
                         "Zeit (s) ": T_GYRO, **xyz([f"Drehrate {a} (°/s)" for a in "xyz"], np.degrees(RATE))},
    },
}

PHYPHOX_INCOMPLETE = {
    # phyphox-android assets/experiments/accelerometer.phyphox: the built-in experiment's one set "Raw Data".
    "builtin-acceleration-only": ({"Raw Data.csv": {"Time (s)": T_ACC,
                                                    **xyz([f"Acceleration {a} (m/s^2)" for a in "xyz"], FORCE)}},
                                  "no gyroscope.*tick Gyroscope in a simple experiment"),
    # gyroscope and linear acceleration ticked, acceleration with g not: the unread export.
    "gyroscope-and-linear": ({"Gyroscope.csv": PHYPHOX["ios-simple"]["Gyroscope.csv"],
                              "Linear Accelerometer.csv": PHYPHOX["ios-simple"]["Linear Accelerometer.csv"]},
                             r"linear acceleration \(without g\) but no acceleration with g.*Acceleration \(with g\)"),
}

DIALECTS = [(",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ",")]  # phyphox's five CSV formats


def write_phyphox(path, tables, sep=",", decimal="."):
    with zipfile.ZipFile(path, "w") as archive:
        for name, columns in tables.items():
            archive.writestr(name, phyphox_text(columns, sep, decimal))
        archive.writestr("meta/device.csv", f'"property"{sep}"value"\n"model"{sep}"test"\n')
    return path


def assert_known_motion(rec):
    ok = rec.valid()
    assert ok.mean() > 0.98
    force, rate = truth(rec.time[ok])
    measured = rec.array(["ax", "ay", "az"])[ok]
    cosine = np.sum(measured * force, axis=1) / np.linalg.norm(measured, axis=1) / np.linalg.norm(force, axis=1)
    assert np.degrees(np.median(np.arccos(np.clip(cosine, -1, 1)))) < 1.0  # tilt as the phone's gravity says
    np.testing.assert_allclose(rec.array(["gx", "gy", "gz"])[ok], rate, atol=0.02)


@pytest.mark.parametrize("layout", list(PHYPHOX))
@pytest.mark.parametrize("dialect", DIALECTS, ids=["comma", "tab", "semicolon", "tab-decimal-comma",
                                                   "semicolon-decimal-comma"])
def test_every_phyphox_layout_in_every_dialect_reads_the_known_motion(tmp_path, layout, dialect):
    path = write_phyphox(tmp_path / f"{layout}.zip", PHYPHOX[layout], *dialect)
    assert detect_format(path) == "phyphox"
    rec = read_recording(path)
    assert_known_motion(rec)
    assert "phyphox export" in describe(rec) and "gyroscope" in describe(rec)
    ride_features(rec)  # the ride features accept it


def test_a_phyphox_per_sensor_file_alone_is_detected_and_read(tmp_path):
    path = tmp_path / "Accelerometer.csv"
    path.write_text(phyphox_text(PHYPHOX["ios-simple"]["Accelerometer.csv"], ";", ","))
    assert detect_format(path) == "phyphox"
    rec = read_recording(path)
    assert rec.names == ["ax", "ay", "az"]
    with pytest.raises(InputError, match="no gyroscope"):
        ride_features(rec)


@pytest.mark.parametrize("layout", list(PHYPHOX_INCOMPLETE))
def test_an_incomplete_phyphox_export_names_the_missing_sensor_in_phyphox_terms(tmp_path, layout):
    tables, message = PHYPHOX_INCOMPLETE[layout]
    path = write_phyphox(tmp_path / f"{layout}.zip", tables)
    with pytest.raises(InputError, match=message):
        ride_features(read_recording(path))


def test_a_gravity_set_alone_is_not_taken_for_the_accelerometer(tmp_path):
    tables = {"Gravity.csv": PHYPHOX["ios-simple"]["Gravity.csv"], "Gyroscope.csv": PHYPHOX["ios-simple"]["Gyroscope.csv"]}
    rec = read_recording(write_phyphox(tmp_path / "g.zip", tables))
    assert "ax" not in rec.channels and "gx" in rec.channels


# ------------------------------------------------------------------ Sensor Logger


def motion_file(t, values, order="zyx"):
    """A Sensor Logger motion file: ``time`` (UNIX ns), ``seconds_elapsed`` (s), then the axes in ``order``
    (github.com/tszheichoi/awesome-sensor-logger UNITS.md; the app writes z, y, x; some versions x, y, z)."""
    table = {"time": T0_NS + np.round(t * 1e9).astype(np.int64), "seconds_elapsed": t}
    table.update({a: values[:, "xyz".index(a)] for a in order})
    return pd.DataFrame(table)


def location_file(ios=False):
    """Location.csv columns of UNITS.md (altitudeAboveMeanSeaLevel is iOS only)."""
    t = T_GPS
    table = {"time": T0_NS + np.round(t * 1e9).astype(np.int64), "seconds_elapsed": t, "bearingAccuracy": 10.0,
             "speedAccuracy": 0.5, "verticalAccuracy": 3.0, "horizontalAccuracy": 4.0, "speed": 1.1 + 0 * t,
             "bearing": 0.0, "altitude": 40.0, "longitude": 139.7 + 0 * t, "latitude": 35.6 + 1e-5 * t}
    if ios:
        table["altitudeAboveMeanSeaLevel"] = 2.0
    return pd.DataFrame(table)


def metadata_file(platform, version="1.40", standardisation=None):
    """Metadata.csv (the columns the reader's docstring lists); early versions had no standardisation column."""
    row = {"version": 3, "device name": "phone", "recording epoch time": T0_NS // 1_000_000,
           "recording time": "2023-11-14_22-13-20", "recording timezone": "UTC", "platform": platform,
           "appVersion": version, "device id": "x", "sensors": "Accelerometer|Gravity|Gyroscope|Location",
           "sampleRateMs": "10|10|10|0"}
    if standardisation is not None:
        row["standardisation"] = standardisation
    return pd.DataFrame([row])


def sensor_logger(folder, platform, standardised=False, order="zyx", version="1.40", gyroscope=True,
                  early=False):
    """An export folder as Sensor Logger writes it (UNITS.md, CROSSPLATFORM.md of awesome-sensor-logger):
    Android: TotalAcceleration.csv (with g) and Accelerometer.csv (without); iOS: Accelerometer.csv (without g)
    and Gravity.csv, both negated (CoreMotion's sign) unless "Standardise Units & Frames" is on; the
    AccelerometerUncalibrated.csv that the app leaves at 0 bytes; Location.csv; Metadata.csv."""
    folder.mkdir(parents=True)
    sign = -1.0 if platform == "ios" and not standardised else 1.0
    if platform == "android":
        motion_file(T_ACC, FORCE, order).to_csv(folder / "TotalAcceleration.csv", index=False)
    motion_file(T_ACC, sign * LINEAR, order).to_csv(folder / "Accelerometer.csv", index=False)
    motion_file(T_ACC, sign * FORCE, order).to_csv(folder / "Gravity.csv", index=False)
    if gyroscope:
        motion_file(T_GYRO, RATE, order).to_csv(folder / "Gyroscope.csv", index=False)
    (folder / "AccelerometerUncalibrated.csv").write_bytes(b"")
    location_file(platform == "ios").to_csv(folder / "Location.csv", index=False)
    standardisation = None if early else str(standardised).lower()
    metadata_file(platform, version, standardisation).to_csv(folder / "Metadata.csv", index=False)
    return folder


SENSOR_LOGGER = {
    "android-1.40": dict(platform="android"),
    "ios-1.40": dict(platform="ios"),
    "ios-standardised": dict(platform="ios", standardised=True),
    "android-xyz-order": dict(platform="android", order="xyz"),
    "ios-early-no-standardisation-column": dict(platform="ios", version="1.10", early=True),
}


@pytest.mark.parametrize("layout", list(SENSOR_LOGGER))
def test_every_sensor_logger_layout_reads_the_known_motion(tmp_path, layout):
    folder = sensor_logger(tmp_path / layout, **SENSOR_LOGGER[layout])
    rec = read_recording(folder)
    assert_known_motion(rec)
    assert any("AccelerometerUncalibrated.csv: empty file" in r for r in rec.meta["repairs"])
    line = describe(rec)
    assert "Sensor Logger export" in line and "gyroscope" in line and "12.0 s" in line and "no gaps" in line
    zipped = tmp_path / f"{layout}.zip"
    with zipfile.ZipFile(zipped, "w") as archive:
        for file in folder.iterdir():
            archive.write(file, f"{layout}/{file.name}")
    assert_known_motion(read_recording(zipped))


def test_a_sensor_logger_export_without_gyroscope_names_the_app_setting(tmp_path):
    folder = sensor_logger(tmp_path / "nogyro", "android", gyroscope=False)
    with pytest.raises(InputError, match=r"no Gyroscope\.csv: enable Gyroscope in Sensor Logger"):
        ride_features(read_recording(folder))


def test_the_same_motion_from_phyphox_and_sensor_logger_gives_the_same_features(tmp_path):
    a = ride_features(read_recording(write_phyphox(tmp_path / "p.zip", PHYPHOX["ios-simple"])))
    b = ride_features(read_recording(sensor_logger(tmp_path / "s", "ios")))
    n = min(len(a), len(b))
    np.testing.assert_allclose(a.array(["roll", "pitch"])[:n], b.array(["roll", "pitch"])[:n], atol=0.01)


def test_the_command_line_says_what_it_read_and_refuses_in_one_line(tmp_path):
    from typer.testing import CliRunner

    from spotfree.cli import app

    runner = CliRunner()
    good = runner.invoke(app, ["features", str(sensor_logger(tmp_path / "good", "android")), "-o",
                               str(tmp_path / "f.csv")])
    assert good.exit_code == 0, good.output
    assert "read: " in good.stderr and "Sensor Logger export 1.40 (Android)" in good.stderr
    assert "native rate: TotalAcceleration 100 Hz, Gyroscope 100 Hz, Location 1 Hz" in good.stderr
    bad = runner.invoke(app, ["features", str(sensor_logger(tmp_path / "bad", "ios", gyroscope=False)), "-o",
                              str(tmp_path / "g.csv")])
    assert bad.exit_code == 2
    errors = [line for line in bad.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "enable Gyroscope in Sensor Logger" in errors[0]


def test_a_sensor_logger_export_without_the_time_column_uses_seconds_elapsed(tmp_path):
    folder = sensor_logger(tmp_path / "trimmed", "android")
    for name in ("TotalAcceleration", "Gyroscope", "Location", "Accelerometer", "Gravity"):
        table = pd.read_csv(folder / f"{name}.csv")
        table.drop(columns="time").to_csv(folder / f"{name}.csv", index=False)
    rec = read_recording(folder)
    assert_known_motion(rec)
    assert rec.meta["start_epoch"] == pytest.approx(0.0)


# ------------------------------------------------------------------ layouts found in real exports


def test_a_phyphox_custom_experiment_without_units_in_its_headers_reads_the_known_motion(tmp_path):
    """A custom experiment's export names its columns as its author wrote them, here without units (header strings
    as in a phyphox 1.1.11 iOS export: github.com/Shantanu-Mandpe/Motion-Analysis-Project, Data/bus_to_home/
    Acceleration.csv, Gyroscope.csv, GPS.csv); phyphox records these sensors in s, m/s^2, rad/s, degrees, m and
    m/s (phyphox.org/sensors), and iOS Core Location writes -1 for an unknown speed or course (Apple's CLLocation
    documentation)."""
    speed = 1.1 + 0 * T_GPS
    speed[:2] = -1.0
    tables = {
        "Acceleration.csv": {"time": T_ACC, **xyz([f"Acceleration {a}" for a in "xyz"], FORCE),
                             "abs Acceleration": np.linalg.norm(FORCE, axis=1)},
        "Gyroscope.csv": {"time": T_GYRO, **xyz([f"Gyroscope {a}" for a in "xyz"], RATE),
                          "abs Gyroscope": np.linalg.norm(RATE, axis=1)},
        "GPS.csv": {"time": T_GPS, "Latitude": 53.59 + 1e-5 * T_GPS, "Longitude": 9.95 + 0 * T_GPS,
                    "Altitude": 15 + 0 * T_GPS, "Direction": np.where(speed < 0, -1.0, 35.0), "Speed": speed},
    }
    rec = read_recording(write_phyphox(tmp_path / "custom.zip", tables))
    assert_known_motion(rec)
    assert any("give no units" in r for r in rec.meta["repairs"])
    assert any("2 negative speed value(s)" in r for r in rec.meta["repairs"])
    speeds = rec.array(["speed"])[:, 0]
    assert np.nanmin(speeds) >= 0 and np.nanmax(speeds) == pytest.approx(1.1)
    ride_features(rec)


def test_an_accelerometer_file_that_holds_no_gravity_is_read_as_linear_acceleration(tmp_path):
    """phyphox's iOS simple-experiment layout (file name Accelerometer.csv, X/Y/Z headers) whose numbers lack g,
    as in github.com/rimputus/fysiikkaloppu: the data overrule the file name, and the refusal names both sensors."""
    tables = {"Accelerometer.csv": {"Time (s)": T_ACC, **xyz([f"{a} (m/s^2)" for a in "XYZ"], LINEAR + 0.5)},
              "Location.csv": PHYPHOX_LOCATION}
    rec = read_recording(write_phyphox(tmp_path / "walk.zip", tables))
    assert "ax" not in rec.channels and "lat" in rec.channels
    assert any("named as acceleration with g" in r for r in rec.meta["repairs"])
    with pytest.raises(InputError, match=r"linear acceleration \(without g\).*; this phyphox export has no gyroscope"):
        ride_features(rec)


def mix_recordings(folder, names, days=3):
    """Move the time stamps of the named Sensor Logger files ``days`` later: an export unzipped over another one
    (as github.com/selen-s/CNV CNV_csvs and github.com/jmandzak/ActivityDetection's top folder hold)."""
    for name in names:
        table = pd.read_csv(folder / f"{name}.csv")
        table["time"] = table["time"] + days * 86_400 * 10**9
        table.to_csv(folder / f"{name}.csv", index=False)


def test_a_sensor_logger_file_of_another_recording_is_left_out_and_named(tmp_path):
    folder = sensor_logger(tmp_path / "mixed", "ios")
    mix_recordings(folder, ["Gyroscope"])
    rec = read_recording(folder)
    assert "gx" not in rec.channels
    assert any("Gyroscope.csv: from another recording" in r for r in rec.meta["repairs"])
    with pytest.raises(InputError, match=r"Gyroscope\.csv is from another recording \(it starts 2023-11-17 "
                                         r"22:13 UTC\): enable Gyroscope in Sensor Logger"):
        ride_features(rec)


def test_metadata_says_which_recording_an_export_is(tmp_path):
    folder = sensor_logger(tmp_path / "mixed", "ios")
    table = pd.read_csv(folder / "Metadata.csv")
    table["recording epoch time"] += 3 * 86_400 * 1000  # the recording is the later one: Gravity and Gyroscope
    table.to_csv(folder / "Metadata.csv", index=False)
    mix_recordings(folder, ["Gravity", "Gyroscope"])
    with pytest.raises(InputError, match=r"Accelerometer\.csv is from another recording \(it starts 2023-11-14"):
        ride_features(read_recording(folder))


def test_an_unused_file_of_another_recording_does_not_stop_the_export(tmp_path):
    folder = sensor_logger(tmp_path / "mixed", "android")
    mix_recordings(folder, ["Location"], days=-30)
    rec = read_recording(folder)
    assert_known_motion(rec)
    assert "lat" not in rec.channels and any("Location.csv: from another recording" in r for r in rec.meta["repairs"])


def test_two_recordings_of_as_many_files_are_refused_in_one_line(tmp_path):
    folder = sensor_logger(tmp_path / "mixed", "ios", early=True)
    table = pd.read_csv(folder / "Metadata.csv").drop(columns="recording epoch time")
    table.to_csv(folder / "Metadata.csv", index=False)
    mix_recordings(folder, ["Gravity", "Gyroscope"])
    with pytest.raises(InputError, match=r"come from 2 recordings \(Accelerometer, Location at 2023-11-14 22:13 "
                                         r"UTC; Gravity, Gyroscope at 2023-11-17 22:13 UTC\)"):
        read_recording(folder)
