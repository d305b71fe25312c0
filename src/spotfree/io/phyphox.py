"""phyphox exports (RWTH Aachen's app): a zip of per-set CSVs, or one CSV, in any of its five CSV dialects.

What the export holds (phyphox-android ``DataExport.java``, phyphox-ios ``ExperimentSensorInput.swift``):

* the zip has one CSV per export set (``Accelerometer.csv``, ``Gyroscope.csv``, ``Location.csv``, ...) plus
  ``meta/device.csv`` and ``meta/time.csv`` (events with ``experiment time`` and ``system time`` in UNIX s);
  the "minimal" export is a single CSV.
* header names are quoted and carry their unit: ``"Time (s)","Acceleration x (m/s^2)", ...``,
  ``"Gyroscope x (rad/s)"``, ``"Latitude (°)","Longitude (°)","Height (m)","Velocity (m/s)","Direction (°)",
  "Horizontal Accuracy (m)"``; ``"Linear Acceleration x (m/s^2)"`` is acceleration without g.
* numbers are written ``0.000000000E0``; a shorter column is padded with ``NaN``.
* five dialects: comma/decimal point, tab/decimal point, semicolon/decimal point, tab/decimal comma,
  semicolon/decimal comma. The dialect is read from the file (:func:`~spotfree.io.checks.detect_dialect`).
* phyphox converts iOS readings itself (CoreMotion g times -9.81), so both platforms export m/s^2 in Android's
  sign convention: a phone lying face up reads +9.81 m/s^2 on z.

Columns are recognised by name and unit; a ``Time`` column starts a new stream (a set may hold several sensors,
each with its own time column). Units are converted to SI (``g`` -> m/s^2, deg/s -> rad/s, km/h -> m/s, direction
in degrees -> heading in rad). Acceleration with g is required for ``ax ay az``; a set holding only linear
acceleration is refused. ``meta['start_epoch']`` is the UNIX time of experiment time zero when ``meta/time.csv``
gives it.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.signal.frame import GRAVITY

_TIME = re.compile(r"^\W*time\b", re.IGNORECASE)
_COLUMNS = [
    (re.compile(r"^linear acceleration ([xyz])\b", re.I), "Linear Acceleration", "a{}", "m/s^2"),
    (re.compile(r"^acceleration ([xyz])\b", re.I), "Accelerometer", "a{}", "m/s^2"),
    (re.compile(r"^gyroscope ([xyz])\b", re.I), "Gyroscope", "g{}", "rad/s"),
    (re.compile(r"^latitude\b", re.I), "Location", "lat", "°"),
    (re.compile(r"^longitude\b", re.I), "Location", "lon", "°"),
    (re.compile(r"^(height|altitude)\b", re.I), "Location", "alt", "m"),
    (re.compile(r"^(velocity|speed)\b", re.I), "Location", "speed", "m/s"),
    (re.compile(r"^direction\b", re.I), "Location", "heading", "°"),
    (re.compile(r"^horizontal accuracy\b", re.I), "Location", "gps_accuracy", "m"),
]
"""Header pattern -> (stream, channel, unit when the header gives none); ``{}`` takes the axis letter."""

_UNITS = {
    "s": 1.0, "ms": 1e-3,
    "m/s^2": 1.0, "m/s²": 1.0, "m/s2": 1.0, "g": GRAVITY,
    "rad/s": 1.0, "°/s": np.pi / 180, "deg/s": np.pi / 180,
    "°": 1.0, "deg": 1.0, "rad": 1.0, "m": 1.0, "km": 1000.0, "m/s": 1.0, "km/h": 1 / 3.6,
}
"""Unit in a header -> factor to SI (headings in degrees are converted to rad separately)."""


def is_phyphox_table(text: str) -> bool:
    """True when the first header cell of CSV text is a phyphox time column such as ``"Time (s)"``."""
    first = text.lstrip("\ufeff").split("\n", 1)[0]
    return bool(re.match(r'^\s*"?time \((m?s)\)"?\s*(?:[,;\t]|$)', first, re.IGNORECASE))


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
                (archive.label(m), archive.read_text(m))
                for m in archive.members
                if m.lower().endswith(".csv") and not m.lower().startswith("meta/") and "/meta/" not in m.lower()
            ]
            time_member = archive.find("time.csv")
            if time_member is not None and "meta" in time_member.lower():
                start_epoch = _start_epoch(archive.read_text(time_member), archive.label(time_member), warnings)
    else:
        tables = [(source, checks.read_text(path))]
    streams: dict[str, Stream] = {}
    for label, text in tables:
        for key, stream in _streams(text, label, repairs):
            if key in streams:
                warnings.append(f"{label}: a second '{key}' stream; kept the first one")
            else:
                streams[key] = stream
    if "Accelerometer" in streams:
        streams.pop("Linear Acceleration", None)
    elif "Linear Acceleration" in streams:
        raise InputError(
            f"{source}: holds only 'Linear Acceleration' (without g); record with phyphox's "
            f"'Acceleration (with g)' sensor"
        )
    if not any(k in streams for k in ("Accelerometer", "Gyroscope")):
        raise InputError(
            f"{source}: no acceleration or gyroscope columns (expected headers like \"Time (s)\", "
            f"\"Acceleration x (m/s^2)\", \"Gyroscope x (rad/s)\"); export the raw sensor data from phyphox"
        )
    rec = merge_streams(streams, rate=rate, max_gap=max_gap, source=source)
    if "Accelerometer" in streams:
        checks.check_acceleration_units(rec.array(["ax", "ay", "az"]), source, "'Acceleration x/y/z'")
    rec.meta.update(repairs=repairs, warnings=warnings)
    if start_epoch is not None:
        rec.meta["start_epoch"] = start_epoch
    return rec


def _streams(text: str, label: str, repairs: list[str]) -> list[tuple[str, Stream]]:
    """The streams of one CSV: each time column with the recognised columns after it, in SI units."""
    sep, decimal = checks.detect_dialect(text)
    table = checks.read_table(text, label, sep, unique=False)
    groups: list[tuple[str, list[str]]] = []
    for column in table.columns:
        if _TIME.match(column):
            groups.append((column, []))
        elif groups:
            groups[-1][1].append(column)
    out = []
    for time_column, columns in groups:
        recognised = [(c, *_meaning(c, label)) for c in columns]
        recognised = [r for r in recognised if r[1] is not None]
        if not recognised:
            continue
        for column, _, name, factor in recognised:
            if factor != 1.0 and name != "heading":
                repairs.append(f"{label}: converted {column!r} to SI units (x {factor:.6g})")
        t = checks.numbers(table, time_column, label, decimal) * _factor(time_column, "s", label)
        padded = np.flatnonzero(np.isfinite(t))
        t = t[: padded[-1] + 1] if len(padded) else t
        motion = any(r[1] != "Location" for r in recognised)
        checks.check_time(t, label, time_column, min_rate=checks.MIN_MOTION_RATE if motion else checks.MIN_RATE)
        for key in dict.fromkeys(r[1] for r in recognised):
            part = [r for r in recognised if r[1] == key]
            values = np.column_stack([checks.numbers(table, c, label, decimal)[: len(t)] * f for c, _, _, f in part])
            names = tuple(name for _, _, name, _ in part)
            keep = checks.order_and_deduplicate(t, values, label, time_column, repairs)
            out.append((key, Stream(t[keep], values[keep], names)))
    return out


def _meaning(column: str, label: str) -> tuple[str | None, str | None, float]:
    """``(stream, channel, factor to SI)`` of a header, or ``(None, None, 1)`` for columns not used."""
    for pattern, stream, channel, default in _COLUMNS:
        match = pattern.match(column.strip())
        if match:
            name = channel.format(match.group(1).lower()) if "{}" in channel else channel
            factor = _factor(column, default, label)
            if name == "heading" and _unit(column, default) in ("°", "deg"):
                factor *= np.pi / 180
            return stream, name, factor
    return None, None, 1.0


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
