"""The generic CSV log (and the simulator's files): a ``time`` column in seconds plus numeric channels.

Layout: one header line, then one row per sample, comma separated (tab or semicolon with a decimal comma are
read too)::

    experiment,time,ax,ay,az,gx,gy,gz,lat,lon,speed,label,event

* ``time`` (required): seconds, increasing within each experiment.
* ``experiment`` (optional): integer ride number; the rows of one experiment are contiguous.
* ``label``, ``event`` (optional): text ground truth, read into ``Recording.truth``.
* any other column is a numeric channel in SI units: ``ax ay az`` specific force in m/s^2 (gravity included,
  device frame: x right, y up, z out of the screen), ``gx gy gz`` rad/s, ``lat lon`` degrees, ``alt`` m,
  ``speed`` m/s. GPS cells are empty where there is no fix.

Reading rules (every repair is logged in ``meta['repairs']``, every doubt in ``meta['warnings']``):

* a name that differs from a standard one only in case or surrounding spaces (``Time``, ``ax ``) is renamed;
  one that looks like a standard name (``acc_x``, ``gyro_z``, ``tiem``) is refused with the right name.
  ``acc_x acc_y acc_z`` are accepted as they are when they hold gravity-free ride features (no gravity in their
  magnitude and no gyroscope column in the file).
* time: a few out-of-order rows are sorted and repeated timestamps dropped; many are refused. The median step
  must be a plausible sampling period in seconds (2 Hz to 10 kHz with IMU columns, 0.1 Hz to 10 kHz without),
  else the unit is wrong.
* a **uniform** experiment (every step within +-25 % of the median) keeps the file's own rate
  ``f = (n - 1) / (t_last - t_first)`` (as the shortest decimal within the estimate's uncertainty: the time
  resolution over the duration, at least 1 ppm) and its
  rows are snapped to ``t_0 + k / f``, when ``f`` is within 10 % of the requested ``rate`` (a phone's nominal rate
  is seldom exact). Runs of at most two missing dense samples inside an experiment are interpolated; longer runs
  stay NaN and are reported as gaps.
* an **irregular** experiment, or a uniform file sampled more than 10 % away from ``rate``, is merged onto a
  ``rate`` Hz grid by :func:`~spotfree.io.resample.merge_streams` (anti-aliased; ground truth: the nearest row),
  and a note says so: logs of several rates go onto one grid.
* ``ax ay az`` whose median magnitude is near 1 are in g and refused with the factor to apply.
* a ``speed`` of exactly -1 (iOS's mark for an unknown speed) or NaN is a missing sample, and a note says how
  many; any other negative speed is refused.

Writing uses ``%.10g`` for channels (about 1e-10 relative), the shortest exact form of the time rounded to the
nanosecond, empty cells for NaN, and replaces the target only once the whole file is written.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.recording import GPS_CHANNELS, GYRO_CHANNELS, IMU_CHANNELS, TRUTH_COLUMNS, Gap, Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.units import GRAVITY

STANDARD = ("experiment", "time", *IMU_CHANNELS, *GPS_CHANNELS, *TRUTH_COLUMNS)
"""Column names with a fixed meaning."""

FEATURE_ACC = ("acc_x", "acc_y", "acc_z")
"""Gravity-free vehicle-frame accelerations written by the ride features; not raw ``ax ay az``."""

_SPELLINGS = {
    "time": "t timestamp times sec secs seconds timesec timeseconds elapsed secondselapsed",
    "experiment": "exp experiments ride rides run trial",
    "ax": "accx accelx accelerationx accelerometerx a_x xacc xaccel",
    "ay": "accy accely accelerationy accelerometery a_y yacc yaccel",
    "az": "accz accelz accelerationz accelerometerz a_z zacc zaccel",
    "gx": "gyrx gyrox gyroscopex omegax xgyr xgyro", "gy": "gyry gyroy gyroscopey omegay ygyr ygyro",
    "gz": "gyrz gyroz gyroscopez omegaz zgyr zgyro",
    "lat": "latitude", "lon": "lng long longitude", "alt": "altitude height elevation ele",
    "speed": "velocity spd", "heading": "bearing course direction", "gps_accuracy": "accuracy horizontalaccuracy",
    "label": "labels class", "event": "events",
}
_ALIASES = {re.sub(r"[_\s]", "", spelling): name for name, spellings in _SPELLINGS.items() for spelling in spellings.split()}

UNIFORM_JITTER = 0.25
"""A step within this fraction of the median step counts as uniform."""

SAME_RATE = 0.10
"""Relative difference between a uniform file's own rate and the requested one above which it is resampled."""


def read_csv(path: str | Path, rate: float = 20.0, max_gap: float = 0.5) -> Recording:
    """A generic CSV log as a Recording (rules in the module docstring).

    ``rate`` (Hz) is the grid for files whose times are not uniform; ``max_gap`` (s) the longest hole that
    resampling may bridge.
    """
    source = str(path)
    text = checks.read_text(Path(path))
    sep, decimal = checks.detect_dialect(text)
    table = checks.read_table(text, source, sep)
    repairs: list[str] = []
    warnings: list[str] = []
    table = _resolve_columns(table, source, decimal, repairs)
    if len(table) < 2:
        raise InputError(f"{source}: {len(table)} data row(s); a recording needs at least two")

    truth_names = [c for c in TRUTH_COLUMNS if c in table.columns]
    channel_names = [c for c in table.columns if c not in ("time", "experiment", *TRUTH_COLUMNS)]
    if not channel_names:
        raise InputError(f"{source}: no channel columns besides 'time'; add the sensor columns (ax, ay, az, ...)")
    time = checks.numbers(table, "time", source, decimal)
    motion = any(c in IMU_CHANNELS for c in channel_names)
    checks.check_time(time, source, "time", min_rate=checks.MIN_MOTION_RATE if motion else checks.MIN_RATE)
    values = np.column_stack([_channel(table, c, source, decimal) for c in channel_names])
    empty = [c for c, column in zip(channel_names, values.T) if np.isnan(column).all() and c not in GPS_CHANNELS]
    if empty:
        raise InputError(f"{source}: column {empty[0]!r} holds no numbers; fill it or drop the column")
    if "speed" in channel_names:
        _unknown_speed(table["speed"], values[:, channel_names.index("speed")], source, repairs)
    truth = {c: table[c].to_numpy(dtype=str) for c in truth_names}
    experiment = _experiments(table, source, decimal) if "experiment" in table.columns else None

    blocks = _blocks(experiment, len(time))
    parts = []
    for number, rows in blocks:
        where = source if experiment is None else f"{source} (experiment {number})"
        keep = rows.start + checks.order_and_deduplicate(
            time[rows], values[rows], where, "time", repairs, first_line=rows.start + 2
        )
        parts.append((number, where, keep))
    rates = [_uniform_rate(time[keep]) for _, _, keep in parts]
    uniform = all(r is not None for r in rates) and max(rates) <= min(rates) * (1 + 1e-3)
    file_rate = _nice(float(np.mean(rates))) if uniform else rate
    snap = uniform and abs(file_rate - rate) <= SAME_RATE * rate
    if uniform and not snap:
        repairs.append(f"{source}: sampled at {file_rate:g} Hz; resampled onto the {rate:g} Hz grid")

    recordings = []
    for number, where, keep in parts:
        columns = dict(zip(channel_names, values[keep].T))
        labels = {c: v[keep] for c, v in truth.items()}
        if snap:
            part = _snapped(time[keep], columns, labels, file_rate, where, repairs)
        else:
            part = _resampled(time[keep], columns, labels, rate, max_gap, where, repairs, irregular=not uniform)
        if experiment is not None:
            part.experiment = np.full(len(part), number)
        recordings.append(part)
    rec = _concatenate(recordings, source)
    _check_accelerations(rec, source, warnings)
    rec.meta.update(repairs=repairs, warnings=warnings)
    return rec


def write_csv(rec: Recording, path: str | Path, truth: bool = True) -> None:
    """Write ``rec`` as a generic CSV: ``experiment`` (when set), ``time``, the channels, then ``label``/``event``.

    Channels are written with ``%.10g`` (empty where NaN), so :func:`read_csv` gives them back to ~1e-10
    relative. The file is written to a temporary file in the same folder and then moved over ``path``, so an
    existing file is never left half written.
    """
    path = Path(path)
    columns: dict[str, object] = {}
    if rec.experiment is not None:
        columns["experiment"] = rec.experiment
    columns["time"] = [repr(float(t)) for t in np.round(rec.time, 9)]
    for name, values in rec.channels.items():
        text = np.char.mod("%.10g", values)
        columns[name] = np.where(np.isnan(values), "", text)
    if truth:
        for name in TRUTH_COLUMNS:
            if name in rec.truth:
                columns[name] = pd.Series(rec.truth[name], dtype=object).fillna("").astype(str).to_numpy()
    checks.write_text(path, pd.DataFrame(columns).to_csv(index=False, lineterminator="\n"))


# ---------------------------------------------------------------- columns


def _key(name: str) -> str:
    """A column name reduced to compare spellings: lower case, no units in brackets, no separators."""
    return re.sub(r"\(.*?\)|\[.*?\]|[\s_\-./]", "", name.lower())


def _resolve_columns(table: pd.DataFrame, source: str, decimal: str, repairs: list[str]) -> pd.DataFrame:
    """Standard names restored when only case or spaces differ; misspelt standard names refused."""
    present = set(table.columns)
    renames = {c: c.strip().lower() for c in table.columns if c not in STANDARD and c.strip().lower() in STANDARD}
    renames = {c: n for c, n in renames.items() if n not in present and list(renames.values()).count(n) == 1}
    if renames:
        table = table.rename(columns=renames)
        listed = ", ".join(f"{a!r} -> {b!r}" for a, b in renames.items())
        repairs.append(f"{source}: renamed column(s) {listed} (case or spaces only)")
    present = set(table.columns)
    misspelt = {}
    for column in table.columns:
        if column in STANDARD:
            continue
        target = _ALIASES.get(_key(column)) or checks.suggest(column, STANDARD)
        if target and target not in present:
            misspelt[column] = target
    if set(FEATURE_ACC) <= set(misspelt) and not _raw_accelerations(table, source, decimal, misspelt):
        misspelt = {c: n for c, n in misspelt.items() if c not in FEATURE_ACC}
    if misspelt:
        listed = ", ".join(f"{a!r} should be {b!r}" for a, b in misspelt.items())
        raise InputError(f"{source}: misspelt column name(s): {listed}; rename them (standard names: {', '.join(STANDARD)})")
    if "time" not in present:
        raise InputError(
            f"{source}: no 'time' column; found {', '.join(repr(c) for c in table.columns)}; "
            f"add the sample times in seconds as a column named 'time'"
        )
    return table


def _raw_accelerations(table: pd.DataFrame, source: str, decimal: str, misspelt: dict[str, str]) -> bool:
    """True when ``acc_x acc_y acc_z`` are raw accelerations rather than gravity-free ride features.

    They are raw when the file also has gyroscope columns, or when their median magnitude shows gravity
    (above 0.7, i.e. about 1 g or 9.81 m/s^2).
    """
    if any(c in table.columns for c in GYRO_CHANNELS) or any(n in GYRO_CHANNELS for n in misspelt.values()):
        return True
    acc = np.column_stack([checks.numbers(table, c, source, decimal) for c in FEATURE_ACC])
    norm = np.linalg.norm(acc, axis=1)
    norm = norm[np.isfinite(norm)]
    return bool(len(norm)) and float(np.median(norm)) >= checks.G_RANGE[0]


def _channel(table: pd.DataFrame, column: str, source: str, decimal: str) -> np.ndarray:
    """A numeric channel; a column that is mostly text is refused as a whole."""
    try:
        return checks.numbers(table, column, source, decimal)
    except InputError:
        cells = table[column].astype(str).str.strip()
        cells = cells[cells != ""]
        parsed = pd.to_numeric(cells.str.replace(",", ".", regex=False) if decimal == "," else cells, errors="coerce")
        if parsed.isna().mean() > 0.5:
            raise InputError(
                f"{source}: column {column!r} holds text; only 'label' and 'event' may hold text, drop or rename it"
            ) from None
        raise


def _unknown_speed(cells: pd.Series, speed: np.ndarray, source: str, repairs: list[str]) -> None:
    """Speeds (m/s) of exactly -1 (iOS Core Location's mark for an unknown speed) set to NaN in place, and a note
    of how many speeds were unknown: the -1 cells and the cells that spell NaN (an empty cell is no fix, not told).

    Any other negative speed stays and is refused downstream (:func:`spotfree.limits.check_recording`).
    """
    marked = speed == -1.0
    spelt = np.isnan(speed) & (cells.astype(str).str.strip() != "").to_numpy()
    speed[marked] = np.nan
    if marked.any() or spelt.any():
        kinds = [f"-1 (iOS's mark for an unknown speed) in {int(marked.sum())}"] if marked.any() else []
        kinds += [f"NaN in {int(spelt.sum())}"] if spelt.any() else []
        repairs.append(f"{source}: {' and '.join(kinds)} speed cell(s), read as missing GPS speed samples")


def _experiments(table: pd.DataFrame, source: str, decimal: str) -> np.ndarray:
    """The ``experiment`` column as integers, each experiment's rows contiguous."""
    numbers = checks.numbers(table, "experiment", source, decimal)
    bad = ~np.isfinite(numbers) | (numbers != np.round(numbers))
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{source}: column 'experiment', line {row + 2}: {table['experiment'].iloc[row]!r} is not a whole "
            f"number; number every row's experiment 1, 2, ..."
        )
    numbers = numbers.astype(np.int64)
    starts = np.r_[0, np.flatnonzero(np.diff(numbers) != 0) + 1]
    seen: set[int] = set()
    for start in starts:
        if numbers[start] in seen:
            raise InputError(
                f"{source}: column 'experiment', line {start + 2}: experiment {numbers[start]} starts again; "
                f"keep the rows of each experiment together"
            )
        seen.add(int(numbers[start]))
    return numbers


def _blocks(experiment: np.ndarray | None, n: int) -> list[tuple[int, slice]]:
    """``(number, rows)`` of each experiment (one block numbered 1 without the column)."""
    if experiment is None:
        return [(1, slice(0, n))]
    starts = np.r_[0, np.flatnonzero(np.diff(experiment) != 0) + 1]
    stops = np.r_[starts[1:], n]
    return [(int(experiment[a]), slice(int(a), int(b))) for a, b in zip(starts, stops)]


# ---------------------------------------------------------------- time grids


def _uniform_rate(t: np.ndarray) -> float | None:
    """The rate (Hz) of uniformly sampled times, or None when a step or the drift exceeds the jitter bound."""
    if len(t) < 2:
        return None
    steps = np.diff(t)
    median = float(np.median(steps))
    if median <= 0 or np.any(np.abs(steps - median) > UNIFORM_JITTER * median):
        return None
    # a time read back lies within a nanosecond (what the writer keeps) or, for large times, within two float64
    # spacings (the rounding to the nanosecond, then the float) of the sampled one; the span has two ends
    resolution = 2 * max(1e-9, 2 * float(np.spacing(np.abs(t).max())))
    rate = _nice((len(t) - 1) / (t[-1] - t[0]), max(1e-6, resolution / (t[-1] - t[0])))
    drift = np.abs(t - (t[0] + np.arange(len(t)) / rate))
    return rate if drift.max() <= UNIFORM_JITTER / rate else None


def _nice(rate: float, tolerance: float = 1e-6) -> float:
    """The number with the fewest significant digits within ``tolerance`` (relative) of ``rate``.

    The tolerance is the rate estimate's own uncertainty: the time resolution over the duration, at least 1 ppm;
    so a file written at 20 Hz reads back at exactly 20 Hz.
    """
    for digits in range(1, 16):
        rounded = float(f"{rate:.{digits}g}")
        if abs(rounded - rate) <= tolerance * rate:
            return rounded
    return rate


def _snapped(
    t: np.ndarray, columns: dict[str, np.ndarray], truth: dict[str, np.ndarray], rate: float, source: str,
    repairs: list[str],
) -> Recording:
    """A uniform experiment on ``t_0 + k / rate``; short holes filled, longer ones NaN and reported as gaps."""
    time = t[0] + np.arange(len(t)) / rate
    dense = [c for c in columns if c not in GPS_CHANNELS]
    channels = {c: (checks.fill_short_runs(v, c, source, repairs) if c in dense else v) for c, v in columns.items()}
    gaps = []
    if dense:
        missing = np.isnan(np.column_stack([channels[c] for c in dense]))
        invalid = missing.any(axis=1)
        for a, b in checks.true_runs(invalid):
            names = ",".join(c for c, m in zip(dense, missing[a:b].any(axis=0)) if m)
            start = time[a - 1] if a > 0 else time[0] - 1.0 / rate
            end = time[b] if b < len(time) else time[-1] + 1.0 / rate
            gaps.append(Gap(float(start), float(end), names))
        for c in dense:
            channels[c][invalid] = np.nan
    return Recording(time=time, channels=channels, rate=rate, source=source, truth=truth, gaps=gaps)


def _resampled(
    t: np.ndarray, columns: dict[str, np.ndarray], truth: dict[str, np.ndarray], rate: float, max_gap: float,
    source: str, repairs: list[str], irregular: bool = True,
) -> Recording:
    """An experiment merged onto a ``rate`` Hz grid; ground truth taken from the nearest row; ``irregular``: its
    time steps are, which ``repairs`` is told."""
    dense = [c for c in columns if c not in GPS_CHANNELS]
    gps = [c for c in columns if c in GPS_CHANNELS]
    streams = {}
    if dense:
        streams["sensors"] = Stream(t, np.column_stack([columns[c] for c in dense]), tuple(dense))
    if gps:
        values = np.column_stack([columns[c] for c in gps])
        fixes = np.isfinite(values).any(axis=1)
        streams["gps"] = Stream(t[fixes], values[fixes], tuple(gps))
    rec = merge_streams(streams, rate=rate, max_gap=max_gap, source=source, repairs=repairs)
    nearest = np.clip(np.rint(np.interp(rec.time, t, np.arange(len(t)))).astype(int), 0, len(t) - 1)
    rec.truth = {c: v[nearest] for c, v in truth.items()}
    if irregular:
        repairs.append(
            f"{source}: time steps are irregular (median {float(np.median(np.diff(t))):.4g} s); "
            f"resampled onto a {rate:g} Hz grid"
        )
    return rec


def _concatenate(parts: list[Recording], source: str) -> Recording:
    """Experiments one after the other in one Recording (all at the same rate)."""
    first = parts[0]
    if len(parts) == 1:
        first.source = source
        return first
    return Recording(
        time=np.concatenate([p.time for p in parts]),
        channels={c: np.concatenate([p.channels[c] for p in parts]) for c in first.channels},
        rate=first.rate,
        source=source,
        truth={c: np.concatenate([p.truth[c] for p in parts]) for c in first.truth},
        experiment=np.concatenate([p.experiment for p in parts]),
        gaps=[g for p in parts for g in p.gaps],
    )


def _check_accelerations(rec: Recording, source: str, warnings: list[str]) -> None:
    """``ax ay az`` must be m/s^2 with gravity: refused in g, reported when gravity seems missing."""
    acc = [c for c in ("ax", "ay", "az") if c in rec.channels]
    if len(acc) < 3:
        return
    values = rec.array(acc)
    checks.check_acceleration_units(values, source, "'ax', 'ay', 'az'")
    norm = np.linalg.norm(values, axis=1)
    median = float(np.median(norm[np.isfinite(norm)])) if np.isfinite(norm).any() else np.nan
    if median < 0.3 * GRAVITY:
        warnings.append(
            f"{source}: 'ax', 'ay', 'az' have a median magnitude of {median:.3g} m/s^2; raw accelerations "
            f"include gravity (about {GRAVITY} m/s^2)"
        )
