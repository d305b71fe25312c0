"""phyphox exports: the five CSV dialects, zip and single-CSV exports, units, bad exports."""

import zipfile

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io import detect_format, read_recording
from spotfree.io.phyphox import read_phyphox

DIALECTS = {
    "comma-point": (",", "."),
    "tab-point": ("\t", "."),
    "semicolon-point": (";", "."),
    "tab-comma": ("\t", ","),
    "semicolon-comma": (";", ","),
}
START_EPOCH = 1_700_000_000.25


def number(x, decimal):
    """A number as phyphox's Java DecimalFormat("0.000000000E0") writes it."""
    if not np.isfinite(x):
        return "NaN"
    exponent = 0 if x == 0 else int(np.floor(np.log10(abs(x))))
    mantissa = x / 10.0**exponent
    if round(abs(mantissa), 9) >= 10:
        mantissa, exponent = mantissa / 10, exponent + 1
    return f"{mantissa:.9f}E{exponent}".replace(".", decimal)


def phyphox_csv(columns: dict, sep=",", decimal="."):
    """A phyphox CSV: quoted headers, scientific numbers, shorter columns padded with NaN."""
    rows = max(len(v) for v in columns.values())
    lines = [sep.join(f'"{name}"' for name in columns)]
    for i in range(rows):
        lines.append(sep.join(number(v[i], decimal) if i < len(v) else "NaN" for v in columns.values()))
    return "\n".join(lines) + "\n"


def acceleration(t):
    return np.column_stack([0.4 * np.sin(2 * np.pi * 0.5 * t), 0.2 + 0 * t, 9.81 + 0.3 * np.cos(2 * np.pi * 0.3 * t)])


def rotation(t):
    return np.column_stack([0.2 * np.cos(2 * np.pi * 0.4 * t), -0.1 + 0 * t, 0.05 * np.sin(2 * np.pi * 0.2 * t)])


def sets(acc_unit="m/s^2"):
    t_acc = np.arange(0, 15, 1 / 200)
    t_gyro = 0.003 + np.arange(0, 15, 1 / 100)
    t_gps = np.arange(0.5, 15, 1.0)
    acc, gyro = acceleration(t_acc), rotation(t_gyro)
    scale = 9.80665 if acc_unit == "g" else 1.0
    return {
        "Accelerometer.csv": {
            "Time (s)": t_acc, **{f"Acceleration {a} ({acc_unit})": acc[:, i] / scale for i, a in enumerate("xyz")},
            "Absolute acceleration (m/s^2)": np.linalg.norm(acc, axis=1),
        },
        "Gyroscope.csv": {"Time (s)": t_gyro, **{f"Gyroscope {a} (rad/s)": gyro[:, i] for i, a in enumerate("xyz")}},
        "Location.csv": {
            "Time (s)": t_gps, "Latitude (°)": 50.77 + 1e-5 * t_gps, "Longitude (°)": 6.08 + 1e-5 * t_gps,
            "Height (m)": 180 + 0 * t_gps, "Velocity (m/s)": 1.5 + 0 * t_gps, "Direction (°)": 180 + 0 * t_gps,
            "Horizontal Accuracy (m)": 5 + 0 * t_gps, "Vertical Accuracy (m)": 8 + 0 * t_gps,
        },
    }


def export_zip(path, dialect="comma-point", tables=None):
    sep, decimal = DIALECTS[dialect]
    tables = sets() if tables is None else tables
    with zipfile.ZipFile(path, "w") as archive:
        for name, columns in tables.items():
            archive.writestr(name, phyphox_csv(columns, sep, decimal))
        archive.writestr("meta/device.csv", f'"property"{sep}"value"\n"model"{sep}"test"\n')
        start = f"{START_EPOCH:.3f}".replace(".", decimal)  # phyphox writes system time as ###0.000
        archive.writestr(
            "meta/time.csv",
            f'"event"{sep}"experiment time"{sep}"system time"{sep}"system time text"\n'
            f'"START"{sep}{number(0.0, decimal)}{sep}{start}{sep}"2023-11-14 22:13:20.250 UTC+00:00"\n'
            f'"PAUSE"{sep}{number(15.0, decimal)}{sep}{start}{sep}"later"\n',
        )
    return path


def assert_known(rec):
    ok = rec.valid()
    assert ok.all()
    np.testing.assert_allclose(rec.array(["ax", "ay", "az"]), acceleration(rec.time), atol=2e-3)
    np.testing.assert_allclose(rec.array(["gx", "gy", "gz"]), rotation(rec.time), atol=2e-3)


@pytest.mark.parametrize("dialect", list(DIALECTS))
def test_every_dialect_of_a_zip_export_gives_the_known_signals(tmp_path, dialect):
    path = export_zip(tmp_path / f"{dialect}.zip", dialect)
    assert detect_format(path) == "phyphox"
    rec = read_recording(path)
    assert_known(rec)
    fixes = np.flatnonzero(np.isfinite(rec.channels["lat"]))
    assert len(fixes) == 15
    assert rec.channels["heading"][fixes] == pytest.approx(np.pi)
    assert rec.channels["speed"][fixes] == pytest.approx(1.5)
    assert rec.meta["start_epoch"] == pytest.approx(START_EPOCH, abs=1e-3)


@pytest.mark.parametrize("dialect", ["comma-point", "semicolon-comma", "tab-comma"])
def test_a_single_csv_export_is_read_with_its_dialect(tmp_path, dialect):
    sep, decimal = DIALECTS[dialect]
    path = tmp_path / "Accelerometer.csv"
    path.write_text(phyphox_csv(sets()["Accelerometer.csv"], sep, decimal))
    assert detect_format(path) == "phyphox"
    rec = read_recording(path)
    np.testing.assert_allclose(rec.array(["ax", "ay", "az"]), acceleration(rec.time), atol=2e-3)
    assert rec.names == ["ax", "ay", "az"]


def test_an_unzipped_export_folder_is_read(tmp_path):
    with zipfile.ZipFile(export_zip(tmp_path / "e.zip")) as archive:
        archive.extractall(tmp_path / "export")
    assert detect_format(tmp_path / "export") == "phyphox"
    assert_known(read_phyphox(tmp_path / "export"))


def test_one_set_with_two_time_columns_gives_two_streams(tmp_path):
    tables = sets()
    combined = {**tables["Accelerometer.csv"], **{f"{k} ": v for k, v in tables["Gyroscope.csv"].items()}}
    path = tmp_path / "combined.csv"
    path.write_text(phyphox_csv(combined))  # the gyroscope columns are shorter: NaN padding
    rec = read_phyphox(path)
    assert_known(rec)


def test_accelerations_in_g_are_converted_and_logged(tmp_path):
    tables = sets(acc_unit="g")
    rec = read_phyphox(export_zip(tmp_path / "g.zip", tables=tables))
    assert_known(rec)
    assert any("Acceleration x (g)" in r and "9.80665" in r for r in rec.meta["repairs"])


def test_linear_acceleration_alone_is_refused(tmp_path):
    t = np.arange(0, 5, 0.01)
    path = tmp_path / "Linear Acceleration.csv"
    path.write_text(phyphox_csv({"Time (s)": t, **{f"Linear Acceleration {a} (m/s^2)": 0 * t for a in "xyz"}}))
    with pytest.raises(InputError, match="holds linear acceleration \\(without g\\) but no acceleration with g"):
        read_recording(path)


def test_an_unknown_unit_is_named_with_its_column(tmp_path):
    t = np.arange(0, 5, 0.01)
    path = tmp_path / "acc.csv"
    path.write_text(phyphox_csv({"Time (s)": t, **{f"Acceleration {a} (ft/s^2)": 0 * t for a in "xyz"}}))
    with pytest.raises(InputError, match=r"acc\.csv: column 'Acceleration x \(ft/s\^2\)' is in 'ft/s\^2'"):
        read_phyphox(path)


def test_a_non_numeric_cell_names_the_member_column_and_line(tmp_path):
    tables = sets()
    path = export_zip(tmp_path / "bad.zip", tables=tables)
    with zipfile.ZipFile(path) as archive:
        members = {n: archive.read(n).decode() for n in archive.namelist()}
    lines = members["Gyroscope.csv"].splitlines()
    cells = lines[5].split(",")
    cells[2] = "abc"
    lines[5] = ",".join(cells)
    members["Gyroscope.csv"] = "\n".join(lines)
    with zipfile.ZipFile(path, "w") as archive:
        for name, text in members.items():
            archive.writestr(name, text)
    with pytest.raises(InputError, match=r"bad\.zip:Gyroscope\.csv: column 'Gyroscope y \(rad/s\)', line 6"):
        read_recording(path)


def test_an_export_without_motion_columns_is_refused(tmp_path):
    path = tmp_path / "light.csv"
    t = np.arange(0, 5, 0.1)
    path.write_text(phyphox_csv({"Time (s)": t, "Illuminance (lx)": 0 * t + 100}))
    with pytest.raises(InputError, match=r"light\.csv: no acceleration, gyroscope or location columns"):
        read_phyphox(path)


def test_time_in_the_wrong_unit_is_refused(tmp_path):
    tables = sets()
    tables["Gyroscope.csv"]["Time (s)"] = tables["Gyroscope.csv"]["Time (s)"] * 1000
    with pytest.raises(InputError, match=r"Gyroscope\.csv: column 'Time \(s\)'.*milliseconds"):
        read_phyphox(export_zip(tmp_path / "ms.zip", tables=tables))


def test_a_zip_that_is_neither_export_is_refused(tmp_path):
    path = tmp_path / "other.zip"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("notes.txt", "hello")
    with pytest.raises(InputError, match=r"other\.zip: holds neither a Sensor Logger export"):
        read_recording(path)
