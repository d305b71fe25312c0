"""phyphox exports (RWTH Aachen's app): a zip of per-set CSVs, or one CSV, in any of its five CSV dialects.

What the export holds (phyphox-android ``DataExport.java``, phyphox-ios ``ExperimentSensorInput.swift``):

* the zip has one CSV per export set plus ``meta/device.csv`` and ``meta/time.csv`` (events with
  ``experiment time`` and ``system time`` in UNIX s); the "minimal" export is a single CSV.
* built-in experiments name the sensor in the header (their one set is ``Raw Data.csv``, e.g. phyphox-android
  ``assets/experiments/gyroscope.phyphox``): ``"Time (s)","Gyroscope x (rad/s)"``, ``"Acceleration x (m/s^2)"``,
  ``"Linear Acceleration x (m/s^2)"`` (without g), ``"Latitude (°)","Longitude (°)","Height (m)",
  "Velocity (m/s)","Direction (°)","Horizontal Accuracy (m)"``. Android's simple experiments (phyphox-android
  ``SimpleExperimentCreator.java``) write one file per sensor with these headers (``Accelerometer.csv``,
  ``Gyroscope.csv``, ``Linear Acceleration.csv``, ``Location.csv``); iOS's (phyphox-ios
  ``SimpleExperimentData.swift``) name the sensor only in the file name: ``Accelerometer.csv``,
  ``Gyroscope.csv``, ``Linear Accelerometer.csv`` with ``"Time (s)","X (m/s^2)"`` / ``"X (rad/s)"`` headers,
  and ``Gravity.csv`` with ``"Gravity X (m/s^2)"``. An experiment's ``<translation>`` block replaces any string
  it lists with the user's language (phyphox file-format documentation, "Tag: string"), export names included, so
  only the axis letter and the unit in parentheses are relied on where the English name is not found.
* numbers are written ``0.000000000E0``; a shorter column is padded with ``NaN``.
* five dialects: comma/decimal point, tab/decimal point, semicolon/decimal point, tab/decimal comma,
  semicolon/decimal comma. The dialect is read from the file (:func:`~spotfree.io.checks.detect_dialect`).
* phyphox converts iOS readings itself (CoreMotion g times -9.81), so both platforms export m/s^2 in Android's
  sign convention: a phone lying face up reads +9.81 m/s^2 on z.

A column whose unit is seconds starts a new stream (a set may hold several sensors, each with its own time
column). An axis column (its header has a lone ``x``, ``y`` or ``z`` and a unit) in m/s^2 or g is an
acceleration, in rad/s or deg/s a rotation rate (device frame, converted to rad/s). Which acceleration it is comes
from the header or the file name (``linear`` = without g, ``gravity`` = the gravity estimate); when neither says,
from the data: a median magnitude above half of g means gravity is included. Without an acceleration with g,
Linear Acceleration + Gravity give it. What is missing for the ride features is kept, in phyphox's terms, in
``meta['missing']``; an export with no motion or location columns at all is refused. ``meta['start_epoch']`` is
the UNIX time of experiment time zero when ``meta/time.csv`` gives it.
"""

from __future__ import annotations

import re
from pathlib import Path, PurePosixPath

import numpy as np

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.units import GRAVITY

_TIME = re.compile(r"^\W*time\b", re.IGNORECASE)
_AXIS = re.compile(r"(?:^|[\s_])([xyz])(?=$|[\s_(])", re.IGNORECASE)
_LOCATION = [
    (re.compile(r"^latitude\b", re.I), "lat", "°"),
    (re.compile(r"^longitude\b", re.I), "lon", "°"),
    (re.compile(r"^(height|altitude)\b", re.I), "alt", "m"),
    (re.compile(r"^(velocity|speed)\b", re.I), "speed", "m/s"),
    (re.compile(r"^direction\b", re.I), "heading", "°"),
    (re.compile(r"^horizontal accuracy\b", re.I), "gps_accuracy", "m"),
]
"""Location header pattern -> (channel, unit when the header gives none)."""

_ACCELERATION_UNITS = ("m/s^2", "m/s²", "m/s2", "g")
_ROTATION_UNITS = ("rad/s", "°/s", "deg/s")
_UNITS = {
    "s": 1.0, "ms": 1e-3,
    "m/s^2": 1.0, "m/s²": 1.0, "m/s2": 1.0, "g": GRAVITY,
    "rad/s": 1.0, "°/s": np.pi / 180, "deg/s": np.pi / 180,
    "°": 1.0, "deg": 1.0, "rad": 1.0, "m": 1.0, "km": 1000.0, "m/s": 1.0, "km/h": 1 / 3.6,
}
"""Unit in a header -> factor to SI (headings in degrees are converted to rad separately)."""

WITH_G_MIN = 0.5 * GRAVITY
"""An unnamed acceleration whose median magnitude (m/s^2) is above this includes gravity."""

ACCELEROMETER, LINEAR, GRAVITY_SET, GYROSCOPE, LOCATION = (
    "Accelerometer", "Linear Acceleration", "Gravity", "Gyroscope", "Location")
_SENSOR_WORDS = {ACCELEROMETER: "acceleration with g", LINEAR: "linear acceleration (without g)",
                 GRAVITY_SET: "gravity", GYROSCOPE: "gyroscope", LOCATION: "location"}


def is_phyphox_table(text: str) -> bool:
    """True when the first header cell of CSV text is a phyphox time column: ``"Time (s)"``, or any quoted name
    in seconds such as a translated ``"Zeit (s)"`` (phyphox quotes every header)."""
    first = text.lstrip("\ufeff").split("\n", 1)[0]
    return bool(re.match(r'^\s*(?:"?time \((m?s)\)"?|"[^",;\t]*\((m?s)\)")\s*(?:[,;\t]|$)', first, re.IGNORECASE))


def read_phyphox(path: str | Path, rate: float = 20.0, max_gap: float = 0.5) -> Recording:
    """A phyphox export (zip, unzipped folder or one CSV) as a Recording at ``rate`` Hz (see the module docstring)."""
    path = Path(path)
    source = str(path)
    repairs: list[str] = []
    warnings: list[str] = []
    start_epoch = None
    if path.is_dir() or path.suffix.lower() == ".zip":
        with checks.Archive(path) as archive:
            tables = [
                (archive.label(m), PurePosixPath(m).stem, archive.read_text(m))
                for m in archive.members
                if m.lower().endswith(".csv") and not m.lower().startswith("meta/") and "/meta/" not in m.lower()
            ]
            time_member = archive.find("time.csv")
            if time_member is not None and "meta" in time_member.lower():
                start_epoch = _start_epoch(archive.read_text(time_member), archive.label(time_member), warnings)
    else:
        tables = [(source, path.stem, checks.read_text(path))]
    streams: dict[str, Stream] = {}
    for label, set_name, text in tables:
        if not text.strip():
            repairs.append(f"{label}: empty file, not used")
            continue
        for key, stream in _streams(text, label, set_name, repairs):
            if key in streams:
                warnings.append(f"{label}: a second {_SENSOR_WORDS[key]} stream; kept the first one")
            else:
                streams[key] = stream
    _total_from_parts(streams, source, repairs)
    streams.pop(GRAVITY_SET, None)
    missing = _missing(streams)
    if not any(k in streams for k in (ACCELEROMETER, GYROSCOPE, LOCATION)):
        raise InputError(f"{source}: " + (missing["accelerometer"] if LINEAR in streams else
                         "no acceleration, gyroscope or location columns (headers like \"Time (s)\", "
                         "\"Acceleration x (m/s^2)\", \"X (rad/s)\"); in phyphox, record Acceleration (with g) "
                         "and Gyroscope, e.g. ticked in a simple experiment"))
    streams.pop(LINEAR, None)
    rec = merge_streams(streams, rate=rate, max_gap=max_gap, source=source, repairs=repairs)
    if ACCELEROMETER in streams:
        checks.check_acceleration_units(rec.array(["ax", "ay", "az"]), source, "'Acceleration x/y/z'")
    rec.meta.update(repairs=repairs, warnings=warnings, format="phyphox export", missing=missing,
                    sensors=[_SENSOR_WORDS[k] for k in streams])
    if start_epoch is not None:
        rec.meta["start_epoch"] = start_epoch
    return rec


def _missing(streams: dict[str, Stream]) -> dict[str, str]:
    """What the ride features need and the export lacks, said in phyphox's terms (see :func:`checks.require_imu`)."""
    missing = {}
    if ACCELEROMETER not in streams:
        missing["accelerometer"] = (
            "this phyphox export holds linear acceleration (without g) but no acceleration with g; record with "
            "the 'Acceleration (with g)' experiment, or tick Accelerometer in a simple experiment"
            if LINEAR in streams else
            "this phyphox export has no acceleration with g; record with the 'Acceleration (with g)' experiment, "
            "or tick Accelerometer in a simple experiment")
    if GYROSCOPE not in streams:
        missing["gyroscope"] = ("this phyphox export has no gyroscope; record with the 'Gyroscope (rotation rate)' "
                                "experiment together with acceleration, or tick Gyroscope in a simple experiment")
    return missing


def _total_from_parts(streams: dict[str, Stream], source: str, repairs: list[str]) -> None:
    """Acceleration with g as Linear Acceleration + Gravity (interpolated onto its times) when only those exist."""
    if ACCELEROMETER in streams or LINEAR not in streams or GRAVITY_SET not in streams:
        return
    linear, gravity = streams[LINEAR], streams[GRAVITY_SET]
    inside = (linear.time >= gravity.time[0]) & (linear.time <= gravity.time[-1])
    if inside.sum() < 2:
        return
    t = linear.time[inside]
    total = linear.values[inside] + np.column_stack([np.interp(t, gravity.time, g) for g in gravity.values.T])
    streams[ACCELEROMETER] = Stream(t, total, ("ax", "ay", "az"))
    repairs.append(f"{source}: acceleration with g taken as Linear Acceleration + Gravity")


def _streams(text: str, label: str, set_name: str, repairs: list[str]) -> list[tuple[str, Stream]]:
    """The streams of one CSV: each time column with the recognised columns after it, in SI units."""
    sep, decimal = checks.detect_dialect(text)
    table = checks.read_table(text, label, sep, unique=False)
    groups: list[tuple[str, list[str]]] = []
    for column in table.columns:
        if _TIME.match(column) or _unit(column, "") in ("s", "ms"):
            groups.append((column, []))
        elif groups:
            groups[-1][1].append(column)
    out = []
    for time_column, columns in groups:
        recognised = [(c, *_meaning(c, set_name, label)) for c in columns]
        recognised = [r for r in recognised if r[1] is not None]
        if not recognised:
            continue
        for column, _, name, factor in recognised:
            if factor != 1.0 and name != "heading":
                repairs.append(f"{label}: converted {column!r} to SI units (x {factor:.6g})")
        t = checks.numbers(table, time_column, label, decimal) * _factor(time_column, "s", label)
        padded = np.flatnonzero(np.isfinite(t))
        t = t[: padded[-1] + 1] if len(padded) else t
        if not len(t):
            repairs.append(f"{label}: no samples under {time_column!r}, not used")
            continue
        motion = any(r[1] != LOCATION for r in recognised)
        checks.check_time(t, label, time_column, min_rate=checks.MIN_MOTION_RATE if motion else checks.MIN_RATE)
        for key in dict.fromkeys(r[1] for r in recognised):
            part = [r for r in recognised if r[1] == key]
            names = tuple(name for _, _, name, _ in part)
            if key != LOCATION and sorted(names) != sorted({n[0] + a for n in names for a in "xyz"}):
                continue  # not a whole x, y, z triple
            values = np.column_stack([checks.numbers(table, c, label, decimal)[: len(t)] * f for c, _, _, f in part])
            order = np.argsort(names) if key != LOCATION else np.arange(len(names))
            values, names = values[:, order], tuple(names[i] for i in order)
            keep = checks.order_and_deduplicate(t, values, label, time_column, repairs)
            values = values[keep]
            if key in ("acceleration", ACCELEROMETER):
                key = _with_or_without_g(values, label, repairs, named=key == ACCELEROMETER)
            elif key == LOCATION:
                _invalid_negative(values, names, label, repairs)
            out.append((key, Stream(t[keep], values, names)))
        if any(not _unit(c, "") for c, *_ in recognised):
            repairs.append(f"{label}: the headers give no units; read in phyphox's sensor units (s, m/s^2, rad/s, "
                           f"degrees, m, m/s)")
    return out


def _meaning(column: str, set_name: str, label: str) -> tuple[str | None, str | None, float]:
    """``(stream, channel, factor to SI)`` of a header, or ``(None, None, 1)`` for columns not used.

    The stream of an acceleration is ``'acceleration'`` when neither the header nor ``set_name`` (the file name)
    says whether gravity is in it; the data decide (:func:`_with_or_without_g`)."""
    name = column.strip()
    for pattern, channel, default in _LOCATION:
        if pattern.match(name):
            factor = _factor(column, default, label)
            if channel == "heading" and _unit(column, default) in ("°", "deg"):
                factor *= np.pi / 180
            return LOCATION, channel, factor
    axis = _AXIS.search(re.sub(r"\([^()]*\)", " ", name))
    unit = _unit(column, "") or _sensor_unit(name)
    if axis is None or not unit:
        return None, None, 1.0
    words = f"{name} {set_name}".lower()
    if unit in _ROTATION_UNITS:
        stream, prefix = GYROSCOPE, "g"
    elif unit in _ACCELERATION_UNITS and "magnet" not in words:
        stream, prefix = ("acceleration" if not re.search(r"linear|gravity|acceleration|accelerometer", words)
                          else LINEAR if "linear" in words else GRAVITY_SET if "gravity" in words
                          else ACCELEROMETER), "a"
    else:
        if re.search(r"accelera|gyro", name, re.I):
            _factor(column, "", label)  # an acceleration or rotation rate in a unit not understood: refused
        return None, None, 1.0
    return stream, prefix + axis.group(1).lower(), _factor(column, unit, label)


def _sensor_unit(name: str) -> str:
    """The unit phyphox records a sensor in, for a header that names the sensor but gives no unit (a custom
    experiment's export, e.g. ``"Acceleration x"``, ``"Gyroscope x"``), or ``''``."""
    if re.search(r"accel|gravity", name, re.IGNORECASE):
        return "m/s^2"
    if re.search(r"gyro|rotation rate|angular", name, re.IGNORECASE):
        return "rad/s"
    return ""


def _with_or_without_g(values: np.ndarray, label: str, repairs: list[str], named: bool = False) -> str:
    """Accelerometer or Linear Acceleration from the median magnitude of an acceleration, for one its header does
    not name, or one ``named`` as acceleration with g (a file called ``Accelerometer.csv`` may hold linear
    acceleration: the data then overrule the name)."""
    norm = np.linalg.norm(values, axis=1)
    norm = norm[np.isfinite(norm)]
    median = float(np.median(norm)) if len(norm) else float("nan")
    with_g = bool(len(norm)) and median > WITH_G_MIN
    if named:
        if not with_g:
            repairs.append(f"{label}: named as acceleration with g, but its median magnitude {median:.2f} m/s^2 "
                           f"is far below g: read as linear acceleration (without g)")
    else:
        repairs.append(f"{label}: the header does not say whether gravity is included; its median magnitude "
                       f"{median:.2f} m/s^2 says {'it is' if with_g else 'it is not'}")
    return ACCELEROMETER if with_g else LINEAR


_INVALID_WHEN_NEGATIVE = ("speed", "heading", "gps_accuracy")
"""Location channels a phone marks as unknown with a negative value (iOS Core Location writes -1 for an invalid
speed or course, Apple's ``CLLocation`` documentation)."""


def _invalid_negative(values: np.ndarray, names: tuple[str, ...], label: str, repairs: list[str]) -> None:
    """Negative speed, heading or accuracy values of a location stream set to NaN in place (unknown, not data)."""
    for j, name in enumerate(names):
        if name in _INVALID_WHEN_NEGATIVE:
            negative = values[:, j] < 0
            if negative.any():
                values[negative, j] = np.nan
                repairs.append(f"{label}: {int(negative.sum())} negative {name} value(s), the phone's mark for "
                               f"unknown, left out")


def _unit(column: str, default: str) -> str:
    """The unit in a header's last parentheses, lower case (``default`` when it has none)."""
    units = re.findall(r"\(([^()]*)\)", column)
    return (units[-1].strip() if units else default).lower()


def _factor(column: str, default: str, label: str) -> float:
    """The factor to SI of a header's unit (heading degrees are converted by the caller)."""
    unit = _unit(column, default)
    factors = {u.lower(): f for u, f in _UNITS.items()}
    if unit not in factors:
        raise InputError(f"{label}: column {column!r} is in {unit!r}, a unit not understood; export SI units")
    return factors[unit]


def _start_epoch(text: str, label: str, warnings: list[str]) -> float | None:
    """UNIX time of experiment time zero from meta/time.csv (its first START event), or None."""
    try:
        sep, decimal = checks.detect_dialect(text)
        table = checks.read_table(text, label, sep)
        events = table["event"].astype(str).str.upper().to_numpy()
        starts = np.flatnonzero(events == "START")
        if not len(starts):
            return None
        experiment = checks.numbers(table, "experiment time", label, decimal)[starts[0]]
        system = checks.numbers(table, "system time", label, decimal)[starts[0]]
    except (InputError, KeyError) as exc:
        warnings.append(f"{label}: start time not read ({exc}); times stay relative to the experiment start")
        return None
    return float(system - experiment) if np.isfinite(system - experiment) else None
