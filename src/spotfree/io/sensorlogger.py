"""Sensor Logger exports (the app by Kelvin Choi, tszheichoi): a folder or zip of per-sensor CSVs, or the JSON export.

What the export holds (github.com/tszheichoi/awesome-sensor-logger: README.md, UNITS.md, COORDINATES.md,
CROSSPLATFORM.md):

* one CSV per sensor, e.g. ``Accelerometer.csv``, ``Gyroscope.csv``, ``Gravity.csv``, ``TotalAcceleration.csv``,
  ``Location.csv``, ``Metadata.csv``; motion sensors have the columns ``time,seconds_elapsed,z,y,x`` (z first).
  ``time`` is UNIX epoch nanoseconds, ``seconds_elapsed`` seconds since the recording started.
* the JSON export is one array of records, each ``{"sensor": "Gyroscope", "time": "...", "z": "...", ...}`` with
  the values as strings; the ``Metadata`` record holds ``platform``, ``sensors``, ``sampleRateMs``, ...
* ``Metadata.csv``: ``version, device name, recording epoch time, recording time, recording timezone, platform
  (android | ios), appVersion, device id, sensors, sampleRateMs, standardisation, platform version``.
* units: Accelerometer (gravity removed), Gravity and TotalAcceleration in m/s^2 (g = 9.80665), Gyroscope rad/s,
  Location latitude/longitude degrees, altitude m, speed m/s, bearing degrees (negative = invalid).
* TotalAcceleration (gravity included) is logged on Android only; on iOS, total = Accelerometer + Gravity.
* iOS vs Android, when "Standardise Units & Frames" is off (the default): Accelerometer and Gravity differ by a
  negative sign on all three axes (iOS follows CoreMotion: a phone lying face up reads gravity on -z), and
  AccelerometerUncalibrated is in g on iOS. Gyroscope agrees on both platforms. With standardisation on, iOS
  follows Android's convention and units.

The Recording uses Android's convention (specific force: face up reads az = +9.81 m/s^2), so iOS data without
standardisation is negated (and uncalibrated accelerations multiplied by -9.80665); each conversion is logged in
``meta['repairs']``. Specific force comes from TotalAcceleration when present, else Accelerometer + Gravity
(gravity interpolated onto the accelerometer's times), else AccelerometerUncalibrated. Times are seconds since
the first motion sample; ``meta['start_epoch']`` is that instant in UNIX seconds. A measured rate far from the
declared ``sampleRateMs`` (factor 2) is reported in ``meta['warnings']``.
"""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.units import GRAVITY

SENSORS = (
    "TotalAcceleration", "Accelerometer", "Gravity", "AccelerometerUncalibrated", "Gyroscope", "Location", "Metadata",
)
"""The Sensor Logger files this reader uses."""

LOCATION_COLUMNS = {
    "latitude": "lat", "longitude": "lon", "altitude": "alt", "speed": "speed", "bearing": "heading",
    "horizontalAccuracy": "gps_accuracy",
}
"""Location.csv column -> channel; speed, bearing and accuracy are invalid when negative."""

RATE_FACTOR = 2.0
"""A measured rate more than this factor away from the declared one is reported."""


class _Sensor:
    """One sensor's table of strings and the name used for it in messages."""

    def __init__(self, table: pd.DataFrame, label: str) -> None:
        self.table, self.label = table, label

    def times(self, min_rate: float = checks.MIN_MOTION_RATE) -> np.ndarray:
        """Sample times in UNIX seconds (``time`` is in ns), checked for their unit; a file without ``time``
        gives ``seconds_elapsed`` (s since the recording started, the same origin in every file)."""
        column, scale = ("time", 1e-9) if "time" in self.table.columns or "seconds_elapsed" not in self.table.columns \
            else ("seconds_elapsed", 1.0)
        self._require(column)
        seconds = checks.numbers(self.table, column, self.label) * scale
        checks.check_time(seconds, self.label, column, min_rate=min_rate)
        return seconds

    def columns(self, names: list[str]) -> np.ndarray:
        """The named columns as floats, ``(n, len(names))``."""
        for name in names:
            self._require(name)
        return np.column_stack([checks.numbers(self.table, n, self.label) for n in names])

    def _require(self, column: str) -> None:
        if column not in self.table.columns:
            raise InputError(
                f"{self.label}: no column {column!r} (found {', '.join(map(repr, self.table.columns))}); "
                f"export the recording again from Sensor Logger"
            )


def read_sensorlogger(path: str | Path, rate: float = 20.0, max_gap: float = 0.5) -> Recording:
    """A Sensor Logger export (folder, zip or ``.json``) as a Recording at ``rate`` Hz (see the module docstring)."""
    path = Path(path)
    sensors, notes = (_json_sensors(path), []) if path.suffix.lower() == ".json" else _archive_sensors(path)
    return _recording(sensors, str(path), rate, max_gap, notes)


def is_sensorlogger_table(header: str) -> bool:
    """True when a CSV header line is a Sensor Logger sensor file (it has ``seconds_elapsed``)."""
    return "seconds_elapsed" in header.split("\n", 1)[0]


def _archive_sensors(path: Path) -> tuple[dict[str, _Sensor], list[str]]:
    """The used sensor files of a folder or zip, and a note for each one left out because it holds no rows."""
    sensors, notes = {}, []
    with checks.Archive(path) as archive:
        for name in SENSORS:
            member = archive.find(f"{name}.csv")
            if member is None:
                continue
            label, text = archive.label(member), archive.read_text(member)
            if not text.strip():
                notes.append(f"{label}: empty file (0 bytes), not used")
                continue
            table = checks.read_table(text, label)
            if not len(table):
                notes.append(f"{label}: " + ("no fix was recorded, so there is no GPS speed" if name == "Location"
                                             else "a header and no samples, not used"))
                continue
            sensors[name] = _Sensor(table, label)
    return sensors, notes


def _json_sensors(path: Path) -> dict[str, _Sensor]:
    try:
        records = json.loads(checks.read_text(path))
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: not valid JSON (line {exc.lineno}: {exc.msg}); export the recording again") from None
    except (ValueError, RecursionError) as exc:  # an integer of thousands of digits, arrays nested thousands deep
        reason = "nested too deeply" if isinstance(exc, RecursionError) else "a number too long"
        raise InputError(f"{path}: not a Sensor Logger JSON export ({reason}); export the recording again") from None
    if not isinstance(records, list) or not records or not all(isinstance(r, dict) and "sensor" in r for r in records):
        raise InputError(f"{path}: not a Sensor Logger JSON export (an array of records with a 'sensor' field)")
    frame = pd.DataFrame.from_records(records)
    sensors = {}
    for name in SENSORS:
        rows = frame[frame["sensor"].astype(str) == name].drop(columns="sensor").dropna(axis=1, how="all")
        if len(rows):
            table = rows.map(lambda v: "" if v is None else str(v)).reset_index(drop=True)
            sensors[name] = _Sensor(table, f"{path}:{name}")
    return sensors


def _recording(sensors: dict[str, _Sensor], source: str, rate: float, max_gap: float,
               notes: list[str]) -> Recording:
    repairs: list[str] = list(notes)
    warnings: list[str] = []
    metadata = _metadata(sensors.get("Metadata"))
    sensors, elsewhere = _one_recording(sensors, metadata, source, repairs)
    missing: dict[str, str] = {}
    motion = dict(_specific_force(sensors, metadata, source, repairs, missing))
    if "accelerometer" in missing and elsewhere.keys() & {"Accelerometer", "TotalAcceleration", "Gravity"}:
        missing["accelerometer"] = (f"{_from_elsewhere(elsewhere, ('TotalAcceleration', 'Accelerometer', 'Gravity'))}"
                                    f": enable Accelerometer and Gravity in Sensor Logger and record again")
    if "Gyroscope" in sensors:
        motion["Gyroscope"] = _xyz(sensors["Gyroscope"], ("gx", "gy", "gz"), repairs)
    elif "Gyroscope" in elsewhere:
        missing["gyroscope"] = (f"{_from_elsewhere(elsewhere, ('Gyroscope',))}: enable Gyroscope in Sensor Logger "
                                f"and record again")
    else:
        missing["gyroscope"] = "this export has no Gyroscope.csv: enable Gyroscope in Sensor Logger and record again"
    streams = dict(motion)
    if "Location" in sensors:
        streams["Location"] = _location(sensors["Location"], repairs)
    if not streams:
        raise InputError(f"{source}: this Sensor Logger export has no TotalAcceleration.csv, Accelerometer.csv + "
                         f"Gravity.csv, Gyroscope.csv or Location.csv with samples: enable Accelerometer, Gravity and "
                         f"Gyroscope in Sensor Logger and record again")
    origin = min(float(s.time[0]) for s in (motion or streams).values())
    streams = {k: Stream(s.time - origin, s.values, s.names) for k, s in streams.items()}
    rec = merge_streams(streams, rate=rate, max_gap=max_gap, source=source, repairs=repairs)
    if "ax" in rec.channels:
        checks.check_acceleration_units(rec.array(["ax", "ay", "az"]), source, "'x', 'y', 'z' of the accelerometer")
    warnings += _rate_warnings(rec.meta["native_rates"], metadata, source)
    platform = metadata.get("platform", "")
    version = metadata.get("appVersion", "")
    ios_native = platform == "ios" and metadata.get("standardisation", "").lower() != "true"
    rec.meta.update(repairs=repairs, warnings=warnings, start_epoch=origin, platform=platform, missing=missing,
                    ios_native=ios_native,
                    format="Sensor Logger export" + (f" {version}" if version else "")
                    + (f" ({'iOS' if platform == 'ios' else 'Android'})" if platform in ("ios", "android") else ""),
                    sensors=[_FILE_WORDS.get(k, k) for k in streams])
    return rec


SAME_RECORDING_SLACK = 5.0
"""Seconds by which two files' time spans may miss each other and still be one recording."""


def _one_recording(sensors: dict[str, _Sensor], metadata: dict[str, str], source: str,
                   repairs: list[str]) -> tuple[dict[str, _Sensor], dict[str, str]]:
    """The sensor files of one recording, and ``{file name: its start (UTC text)}`` for those left out.

    A folder can hold files of two recordings (an export unzipped over another one): files whose time spans
    (``time``, UNIX ns) overlap, give or take :data:`SAME_RECORDING_SLACK`, are one recording. The recording kept
    is the one that contains Metadata.csv's ``recording epoch time`` (ms) when the file gives it, else the one
    with the most files; a tie is refused. Files without a ``time`` column cannot be placed and are kept."""
    spans = {}
    for name, sensor in sensors.items():
        if name != "Metadata" and "time" in sensor.table.columns:
            t = checks.numbers(sensor.table, "time", sensor.label) * 1e-9
            t = t[np.isfinite(t)]
            if len(t):
                spans[name] = (float(t.min()), float(t.max()))
    groups: list[list[str]] = []
    for name in sorted(spans, key=lambda k: spans[k][0]):
        if groups and spans[name][0] <= max(spans[k][1] for k in groups[-1]) + SAME_RECORDING_SLACK:
            groups[-1].append(name)
        else:
            groups.append([name])
    if len(groups) < 2:
        return sensors, {}
    start = {i: min(spans[k][0] for k in g) for i, g in enumerate(groups)}
    try:
        epoch = float(metadata.get("recording epoch time", "")) / 1000.0
    except ValueError:
        epoch = None
    if epoch is not None:
        kept = min(range(len(groups)), key=lambda i: abs(start[i] - epoch))
    else:
        sizes = sorted((len(g) for g in groups), reverse=True)
        if sizes[0] == sizes[1]:
            raise InputError(f"{source}: its files come from {len(groups)} recordings ("
                             + "; ".join(f"{', '.join(g)} at {_utc(start[i])}" for i, g in enumerate(groups))
                             + "); export one recording again, each into its own folder")
        kept = max(range(len(groups)), key=lambda i: len(groups[i]))
    elsewhere = {}
    for i, group in enumerate(groups):
        if i != kept:
            for name in group:
                elsewhere[name] = _utc(spans[name][0])
                repairs.append(f"{sensors[name].label}: from another recording (it starts {elsewhere[name]}, the "
                               f"recording {_utc(start[kept])}), not used")
    return {k: v for k, v in sensors.items() if k not in elsewhere}, elsewhere


def _utc(seconds: float) -> str:
    """UNIX seconds as ``YYYY-MM-DD HH:MM UTC``; as ``S s after 1970`` outside the years 1-9999 (a junk time
    stamp)."""
    try:
        return dt.datetime.fromtimestamp(seconds, tz=dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    except (OverflowError, ValueError, OSError):  # outside the years 1-9999, or not a number
        return f"{seconds:.12g} s after 1970"


def _from_elsewhere(elsewhere: dict[str, str], names: tuple[str, ...]) -> str:
    """``this export's X.csv is from another recording (it starts ...)`` for the first of ``names`` left out."""
    name = next(n for n in names if n in elsewhere)
    return f"this export's {name}.csv is from another recording (it starts {elsewhere[name]})"


_FILE_WORDS = {"TotalAcceleration": "accelerometer (TotalAcceleration.csv)",
               "Accelerometer": "accelerometer + gravity (Accelerometer.csv + Gravity.csv)",
               "AccelerometerUncalibrated": "accelerometer (AccelerometerUncalibrated.csv)",
               "Gyroscope": "gyroscope", "Location": "location"}


def _metadata(sensor: _Sensor | None) -> dict[str, str]:
    """The first row of Metadata.csv as strings ('platform' lower-cased); empty without the file."""
    if sensor is None or not len(sensor.table):
        return {}
    row = {str(k).strip(): str(v).strip() for k, v in sensor.table.iloc[0].items()}
    row["platform"] = row.get("platform", "").lower()
    return row


def _xyz(sensor: _Sensor, names: tuple[str, str, str], repairs: list[str]) -> Stream:
    """A motion sensor's ``x, y, z`` columns (the file stores them z, y, x) as a stream in UNIX seconds."""
    t = sensor.times()
    values = sensor.columns(["x", "y", "z"])
    keep = checks.order_and_deduplicate(t, values, sensor.label, "time", repairs)
    return Stream(t[keep], values[keep], names)


def _specific_force(
    sensors: dict[str, _Sensor], metadata: dict[str, str], source: str, repairs: list[str], missing: dict[str, str]
) -> list[tuple[str, Stream]]:
    """``[(file name, stream)]`` of accelerations with gravity (Android's convention, m/s^2, device frame), or []
    with ``missing['accelerometer']`` saying what to enable in Sensor Logger."""
    names = ("ax", "ay", "az")
    if "TotalAcceleration" in sensors:
        return [("TotalAcceleration", _xyz(sensors["TotalAcceleration"], names, repairs))]
    ios_native = metadata.get("platform") == "ios" and metadata.get("standardisation", "").lower() != "true"
    if "Accelerometer" in sensors and "Gravity" in sensors:
        _require_platform(metadata, source, "Accelerometer.csv + Gravity.csv")
        linear = _xyz(sensors["Accelerometer"], names, repairs)
        gravity = _xyz(sensors["Gravity"], names, repairs)
        inside = (linear.time >= gravity.time[0]) & (linear.time <= gravity.time[-1])
        if inside.sum() < 2:
            raise InputError(f"{source}: Accelerometer.csv and Gravity.csv do not overlap in time; export again")
        t = linear.time[inside]
        total = linear.values[inside] + np.column_stack([np.interp(t, gravity.time, g) for g in gravity.values.T])
        if ios_native:
            total = -total
            repairs.append(f"{source}: iOS export without standardised frames: negated Accelerometer + Gravity "
                           f"to Android's sign convention")
        return [("Accelerometer", Stream(t, total, names))]
    if "AccelerometerUncalibrated" in sensors:
        _require_platform(metadata, source, "AccelerometerUncalibrated.csv")
        raw = _xyz(sensors["AccelerometerUncalibrated"], names, repairs)
        if ios_native:
            repairs.append(f"{source}: iOS uncalibrated accelerations in g with CoreMotion's sign: multiplied by "
                           f"-{GRAVITY} to m/s^2 in Android's convention")
            raw = Stream(raw.time, -GRAVITY * raw.values, names)
        return [("AccelerometerUncalibrated", raw)]
    if "Accelerometer" in sensors:
        missing["accelerometer"] = ("this export's Accelerometer.csv holds acceleration without gravity and there is "
                                    "no Gravity.csv or TotalAcceleration.csv: enable Gravity in Sensor Logger and "
                                    "record again")
    else:
        missing["accelerometer"] = ("this export has no Accelerometer.csv (nor TotalAcceleration.csv): enable "
                                    "Accelerometer and Gravity in Sensor Logger and record again")
    return []


def _require_platform(metadata: dict[str, str], source: str, files: str) -> None:
    """iOS and Android differ in sign for these files, so Metadata.csv must say which one recorded them."""
    if metadata.get("platform") not in ("ios", "android"):
        raise InputError(
            f"{source}: {files} need Metadata.csv (column 'platform') to tell iOS from Android signs; "
            f"export the whole recording, Metadata.csv included"
        )


def _location(sensor: _Sensor, repairs: list[str]) -> Stream:
    """Location.csv as a GPS stream: lat, lon (deg), alt (m), speed (m/s), heading (rad), gps_accuracy (m)."""
    t = sensor.times(min_rate=checks.MIN_RATE)
    present = {c: n for c, n in LOCATION_COLUMNS.items() if c in sensor.table.columns or n in ("lat", "lon")}
    values = sensor.columns(list(present))
    for j, column in enumerate(present):
        if column in ("speed", "bearing", "horizontalAccuracy"):
            values[values[:, j] < 0, j] = np.nan
        if column == "bearing":
            values[:, j] = np.deg2rad(values[:, j])
    keep = checks.order_and_deduplicate(t, values, sensor.label, "time", repairs)
    return Stream(t[keep], values[keep], tuple(present.values()))


def _rate_warnings(native: dict[str, float], metadata: dict[str, str], source: str) -> list[str]:
    """Sensors whose measured rate is more than :data:`RATE_FACTOR` away from ``sampleRateMs`` in Metadata.csv."""
    names = metadata.get("sensors", "").split("|")
    periods = metadata.get("sampleRateMs", "").split("|")
    declared = {}
    for name, period in zip(names, periods):
        try:
            if float(period) > 0:
                declared[name] = 1000.0 / float(period)
        except ValueError:
            continue
    out = []
    for key, measured in native.items():
        expected = declared.get(key, 0.0)
        if expected > 0 and not expected / RATE_FACTOR <= measured <= expected * RATE_FACTOR:
            out.append(f"{source}: {key} measured at {measured:.3g} Hz but declared at {expected:.3g} Hz "
                       f"(sampleRateMs); check the phone did not throttle the sensor")
    return out
