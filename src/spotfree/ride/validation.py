"""Checks on what a device sends before anything is written: a batch that fails any check raises
:class:`~spotfree.errors.InputError` naming the field, the row and the fix, and the store writes nothing of it.

Limits (SI units; the physical ones are shared with the command line's readers, :mod:`spotfree.limits`):

* a batch holds 1 to :data:`MAX_BATCH` rows; each column is a list of JSON numbers (``null`` where allowed):
  text such as ``"1.5"`` and booleans are refused, never converted;
* ``time`` (s since the ride started) is finite, at least 0, at most :data:`~spotfree.limits.MAX_RIDE_SECONDS`,
  strictly increasing within the batch and after the last time already stored for the ride, each step at most
  :data:`~spotfree.limits.MAX_STEP` s; the batch's mean rate ``(n - 1) / (t_last - t_first)`` is at most
  :data:`MAX_RATE` Hz and, from 3 samples, its median step at most ``1 / MIN_RATE`` s (a larger one is
  milliseconds);
* ``ax ay az`` are finite with ``|a| <= MAX_ACCELERATION`` (16 g, the widest range of phone IMUs) and
  ``gx gy gz`` finite with ``|w| <= MAX_ROTATION`` (2000 deg/s);
* ``lat``, ``lon`` are both present or both NaN, within [-90, 90] and [-180, 180]; ``speed`` is NaN or within
  [0, :data:`MAX_SPEED`];
* features, when given, are finite or NaN (NaN before the filters have settled), one row per sample;
* labels are short text or None (None before the first full window), one per sample;
* text fields are at most :data:`MAX_TEXT` printable characters.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numba
import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS
from spotfree.limits import (MAX_ACCELERATION, MAX_RATE, MAX_RIDE_SECONDS, MAX_ROTATION, MAX_SPEED, MAX_STEP,
                             MIN_RATE)
from spotfree.ride.records import FEATURE_COLUMNS, GPS_COLUMNS, SAMPLE_COLUMNS

MAX_BATCH = 5000
"""Rows per batch: 250 s at 20 Hz, 25 s at 200 Hz."""
MAX_TEXT = 100
"""Characters in a text field (ids, names, labels, event kinds)."""


def sample_batch(samples: Mapping[str, Sequence[float]] | np.ndarray, last_time: float | None,
                 where: str) -> np.ndarray:
    """The batch as a read-only :class:`CheckedSamples` array ``(n, len(SAMPLE_COLUMNS))`` in
    :data:`SAMPLE_COLUMNS` order.

    ``samples`` maps column names to equal-length sequences (``None`` reads as NaN; ``lat lon speed`` may be
    left out: no fix), or is such an array (a :class:`CheckedSamples` has passed every check but the time order,
    which is checked again). ``last_time`` is the last time stored for the ride (None when it has none yet).
    """
    if isinstance(samples, CheckedSamples) and samples.ndim == 2:
        check_times(samples[:, 0], last_time, where)
        return samples
    if isinstance(samples, np.ndarray):
        if samples.ndim != 2 or samples.shape[1] != len(SAMPLE_COLUMNS) or not 1 <= len(samples) <= MAX_BATCH:
            raise InputError(f"{where}: a sample array must have 1 to {MAX_BATCH} rows of {len(SAMPLE_COLUMNS)} "
                             f"columns ({', '.join(SAMPLE_COLUMNS)}), not shape {samples.shape}")
        table = samples.astype(float)
    else:
        table = _sample_table(samples, where)
    if _passes(table, -math.inf if last_time is None else float(last_time)):
        return _checked(table)
    check_times(table[:, 0], last_time, where)
    for names, bound, unit in ((ACC_CHANNELS, MAX_ACCELERATION, "m/s^2"), (GYRO_CHANNELS, MAX_ROTATION, "rad/s")):
        for name in names:
            column = table[:, SAMPLE_COLUMNS.index(name)]
            bad = ~np.isfinite(column) | (np.abs(column) > bound)
            _refuse(bad, column, where, name, f"send finite values within +-{bound:.4g} {unit}")
    _check_gps(table, where)
    return _checked(table)


class CheckedSamples(np.ndarray):
    """A read-only batch that :func:`sample_batch` returned: its values need no second check."""


def _checked(table: np.ndarray) -> CheckedSamples:
    checked = table.view(CheckedSamples)
    checked.flags.writeable = False
    return checked


_LOWER = np.array([0.0, *[-MAX_ACCELERATION] * 3, *[-MAX_ROTATION] * 3, -90.0, -180.0, 0.0])
_UPPER = np.array([MAX_RIDE_SECONDS, *[MAX_ACCELERATION] * 3, *[MAX_ROTATION] * 3, 90.0, 180.0, MAX_SPEED])
_OPTIONAL = np.array([name in GPS_COLUMNS for name in SAMPLE_COLUMNS])
_NO_FIX = [None] * MAX_BATCH
_LAT, _LON = SAMPLE_COLUMNS.index("lat"), SAMPLE_COLUMNS.index("lon")


def _passes(table: np.ndarray, last_time: float) -> bool:
    """Whether ``table`` passes every check of :func:`sample_batch` after ``last_time`` (-inf for none), in one
    compiled pass; the checks that name the first failing field and row run only when this is False."""
    return _passes_compiled(table, _LOWER, _UPPER, _OPTIONAL, last_time, MAX_RATE, _LAT, _LON, MAX_STEP) \
        and _median_step_ok(table[:, 0])


@numba.njit(cache=True, nogil=True)
def _passes_compiled(table, lower, upper, optional, last_time, max_rate, lat, lon,
                     max_step):  # pragma: no cover - compiled
    n, m = table.shape
    previous = last_time
    for k in range(n):
        t = table[k, 0]
        if not (math.isfinite(t) and t >= 0.0 and t > previous and (t - previous <= max_step or k == 0
                                                                     and previous == -math.inf)):
            return False
        previous = t
        for j in range(m):
            v = table[k, j]
            if math.isnan(v):
                if not optional[j]:
                    return False
            elif not lower[j] <= v <= upper[j]:
                return False
        if math.isnan(table[k, lat]) != math.isnan(table[k, lon]):
            return False
    return n < 2 or (n - 1) / (table[n - 1, 0] - table[0, 0]) <= max_rate


def _sample_table(samples: Mapping[str, Sequence[float]], where: str) -> np.ndarray:
    """The columns of ``samples`` as one float array, or InputError naming the first field that is not a list of
    numbers of the batch's length."""
    if not isinstance(samples, Mapping) and not hasattr(samples, "columns"):
        raise InputError(f"{where}: samples must map column names ({', '.join(SAMPLE_COLUMNS)}) to lists")
    unknown = [c for c in samples if c not in SAMPLE_COLUMNS]
    if unknown:
        raise InputError(f"{where}: unknown sample field {unknown[0]!r}; the fields are {', '.join(SAMPLE_COLUMNS)}")
    missing = [c for c in SAMPLE_COLUMNS[:7] if c not in samples]
    if missing:
        raise InputError(f"{where}: sample field {missing[0]!r} is missing; send time, ax, ay, az, gx, gy, gz")
    n = _length(samples, where, "samples")
    for name in samples:
        _plain_numbers(samples[name], where, name, optional=name in GPS_COLUMNS)
    try:  # one conversion for the whole batch; a column that fails is found and named below
        table = np.array([samples[name] if name in samples else _NO_FIX[:n] for name in SAMPLE_COLUMNS],
                         dtype=float).T
    except (TypeError, ValueError):
        table = None
    if table is None or table.shape != (n, len(SAMPLE_COLUMNS)):
        table = np.full((n, len(SAMPLE_COLUMNS)), np.nan)
        for j, name in enumerate(SAMPLE_COLUMNS):
            if name in samples:
                table[:, j] = _floats(samples[name], n, where, name)
    return table


def check_times(t: np.ndarray, last_time: float | None, where: str) -> None:
    """Times in seconds since the ride started (see the module docstring): finite, within [0, MAX_RIDE_SECONDS],
    strictly increasing after ``last_time`` by steps of at most MAX_STEP, at a mean rate of at most MAX_RATE and
    a median step of at most ``1 / MIN_RATE``."""
    times = t.tolist()  # a phone's batch is a few samples: plain floats beat array calls
    if not (math.isfinite(times[0]) and 0 <= times[0] <= MAX_RIDE_SECONDS and math.isfinite(times[-1])
            and times[-1] <= MAX_RIDE_SECONDS and all(a < b <= a + MAX_STEP for a, b in zip(times, times[1:]))):
        steps = np.diff(t)
        _refuse(~np.isfinite(t) | (t < 0) | (t > MAX_RIDE_SECONDS), t, where, "time",
                f"send seconds since the ride started, at most {MAX_RIDE_SECONDS:g} (a longer ride is two)")
        _refuse(np.r_[False, ~(steps > 0)], t, where, "time", "times must increase strictly within a batch")
        _refuse(np.r_[False, steps > MAX_STEP], t, where, "time",
                f"a pause of more than {MAX_STEP:g} s ends the ride; start a new ride")
    if last_time is not None and times[0] <= last_time:
        raise InputError(f"{where}: field 'time', row 1: {times[0]!r} s is not after the last stored time "
                         f"{float(last_time)!r} s; send only new samples, in order")
    if last_time is not None and times[0] - last_time > MAX_STEP:
        raise InputError(f"{where}: field 'time', row 1: {times[0]!r} s is more than {MAX_STEP:g} s after the last "
                         f"stored time {float(last_time)!r} s; start a new ride")
    if len(times) > 1 and (len(times) - 1) / (times[-1] - times[0]) > MAX_RATE:
        raise InputError(f"{where}: field 'time': {len(times)} samples in {times[-1] - times[0]:.6g} s is faster "
                         f"than {MAX_RATE:g} Hz; send times in seconds")
    if not _median_step_ok(t):
        step = float(np.median(np.diff(t)))
        raise InputError(f"{where}: field 'time': a median step of {step:.6g} s is slower than {MIN_RATE:g} Hz; "
                         "send times in seconds (steps this long look like milliseconds)")


def _median_step_ok(t: np.ndarray) -> bool:
    """Whether a batch of fewer than 3 times, or its median step, is at most ``1 / MIN_RATE`` s (the median as
    :func:`numpy.median` takes it, on plain floats: a phone's batch is a few samples)."""
    if len(t) < 3:
        return True
    times = t.tolist()
    steps = sorted([b - a for a, b in zip(times, times[1:])])
    half = len(steps) // 2
    median = steps[half] if len(steps) % 2 else (steps[half - 1] + steps[half]) / 2
    return median <= 1.0 / MIN_RATE


def feature_batch(features: Mapping[str, Sequence[float]] | np.ndarray, n: int, where: str) -> np.ndarray:
    """Features as an ``(n, len(FEATURE_COLUMNS))`` array (columns left out are NaN), from a mapping of columns or
    such an array; infinities refused."""
    if isinstance(features, np.ndarray):
        if features.shape != (n, len(FEATURE_COLUMNS)):
            raise InputError(f"{where}: a feature array must have shape ({n}, {len(FEATURE_COLUMNS)}), "
                             f"not {features.shape}")
        if np.isinf(features).any():
            raise InputError(f"{where}: a feature array holds an infinity; send finite features or NaN")
        return features.astype(float)
    unknown = [c for c in features if c not in FEATURE_COLUMNS]
    if unknown:
        raise InputError(f"{where}: unknown feature {unknown[0]!r}; the features are {', '.join(FEATURE_COLUMNS)}")
    try:  # one conversion for all features; a column that fails is found and named below
        table = np.array([features[name] if name in features else _NO_FIX[:n] for name in FEATURE_COLUMNS],
                         dtype=float).T
    except (TypeError, ValueError):
        table = None
    if table is not None and table.shape == (n, len(FEATURE_COLUMNS)) and not np.isinf(table).any():
        return table
    table = np.full((n, len(FEATURE_COLUMNS)), np.nan)
    for j, name in enumerate(FEATURE_COLUMNS):
        if name in features:
            column = _floats(features[name], n, where, name)
            _refuse(np.isinf(column), column, where, name, "send finite features or NaN")
            table[:, j] = column
    return table


def label_batch(labels: Sequence[str | None], n: int, where: str, field: str) -> list[str | None]:
    """One label (short text, or None where the classifier has no window yet) per sample."""
    if isinstance(labels, str) or len(labels) != n:
        raise InputError(f"{where}: labels {field!r} must be a list of {n} labels, one per sample")
    try:  # a batch holds a few distinct labels: each is checked once, and only a refusal looks for its row
        distinct = set(labels)
    except TypeError:  # an unhashable value: the rows name it
        distinct = None
    if distinct is not None and all(label is None or _is_text(label) for label in distinct):
        return list(labels)
    return [None if label is None else text(label, where, f"{field} row {k + 1}") for k, label in enumerate(labels)]


def _is_text(value: object) -> bool:
    """Whether :func:`text` takes ``value`` as a non-empty text."""
    return isinstance(value, str) and 0 < len(value) <= MAX_TEXT and value.isprintable()


def text(value: object, where: str, field: str, required: bool = True) -> str | None:
    """A text field: non-empty printable text of at most MAX_TEXT characters (None allowed when not required)."""
    if value is None or value == "":
        if required:
            raise InputError(f"{where}: field {field!r} is empty; give it a value")
        return None
    if not _is_text(value):
        raise InputError(f"{where}: field {field!r} must be printable text of at most {MAX_TEXT} characters")
    return value


def _check_gps(table: np.ndarray, where: str) -> None:
    lat, lon, speed = (table[:, SAMPLE_COLUMNS.index(c)] for c in ("lat", "lon", "speed"))
    half = np.isnan(lat) != np.isnan(lon)
    _refuse(half, lat, where, "lat", "send lat and lon together, or neither")
    _refuse(np.isinf(lat) | (np.abs(lat) > 90), lat, where, "lat", "send degrees within [-90, 90] or no value")
    _refuse(np.isinf(lon) | (np.abs(lon) > 180), lon, where, "lon", "send degrees within [-180, 180] or no value")
    _refuse(np.isinf(speed) | (speed < 0) | (speed > MAX_SPEED), speed, where, "speed",
            f"send m/s within [0, {MAX_SPEED:g}] or no value")


def _length(columns: Mapping[str, Sequence], where: str, what: str) -> int:
    lengths = {name: _len(values, where, name) for name, values in columns.items()}
    sizes = set(lengths.values())
    if len(sizes) > 1:
        listed = ", ".join(f"{k}: {v}" for k, v in lengths.items())
        raise InputError(f"{where}: {what} fields differ in length ({listed}); send one value per row in each")
    n = sizes.pop()
    if not 1 <= n <= MAX_BATCH:
        raise InputError(f"{where}: {n} {what} in one batch; send 1 to {MAX_BATCH}")
    return n


def _len(values: Sequence, where: str, name: str) -> int:
    if isinstance(values, (str, bytes, Mapping, set, frozenset)) or not hasattr(values, "__len__"):
        raise InputError(f"{where}: field {name!r} must be a list of numbers")
    return len(values)


def _floats(values: Sequence, n: int, where: str, name: str) -> np.ndarray:
    try:
        column = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: field {name!r} holds a value that is not a number; send numbers") from None
    if column.shape != (n,):
        raise InputError(f"{where}: field {name!r} has shape {column.shape}, expected {n} numbers")
    return column


def _is_number_type(kind: type, optional: bool) -> bool:
    if kind is float or kind is int or (optional and kind is type(None)):
        return True
    return issubclass(kind, (int, float, np.integer, np.floating)) and not issubclass(kind, (bool, np.bool_))


def _plain_numbers(values: Sequence, where: str, name: str, optional: bool) -> None:
    """Refuse a column holding anything but numbers (and None where ``optional``): a JSON string such as "1.5"
    or a boolean is an error of the sender, never converted. NumPy numbers and arrays of them pass."""
    if isinstance(values, np.ndarray):
        if values.dtype.kind in "fiu":
            return
        values = values.tolist()
    if all(_is_number_type(kind, optional) for kind in set(map(type, values))):
        return
    k = next(k for k, v in enumerate(values) if not _is_number_type(type(v), optional))
    expected = "numbers or null" if optional else "numbers"
    raise InputError(f"{where}: field {name!r}, row {k + 1}: {values[k]!r:.40} is not a number; send {expected}, "
                     "not text")


def _refuse(bad: np.ndarray, column: np.ndarray, where: str, name: str, fix: str) -> None:
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(f"{where}: field {name!r}, row {row + 1}: {float(column[row])!r} refused; {fix}")
