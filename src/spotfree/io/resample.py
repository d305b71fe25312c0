"""Merging sensor streams with separate clocks onto one uniform grid.

A :class:`Stream` is what one sensor delivered: sample times ``t`` (s, strictly increasing, its own clock
already expressed on the recording's time axis) and values ``(m, k)`` with ``k`` channel names. Streams whose
channels are all in :data:`~spotfree.io.recording.GPS_CHANNELS` are *sparse*; every other stream is *dense*.

:func:`merge_streams` builds the grid ``t_j = t_start + j / f_g`` (``f_g`` = ``rate``) over the time span that all
dense streams cover (their overlap), then for every dense stream:

1. **gaps** -- two consecutive samples more than ``max_gap`` seconds apart bound a gap; grid samples strictly
   inside it are NaN in every dense channel and the gap is listed in ``Recording.gaps``. Nothing is
   interpolated across a gap.
2. **anti-aliasing** -- when the stream's native rate ``f_s = 1 / median(dt)`` exceeds ``f_g``, each gap-free
   piece is first linearly interpolated onto a uniform grid at ``f_s`` and low-passed by a Butterworth filter of
   order :data:`ANTI_ALIAS_ORDER` with cut-off ``f_c = ANTI_ALIAS_FRACTION * f_g`` run forward and backward
   (zero phase, magnitude ``|H(f)|^2 = 1 / (1 + (f / f_c)^(2 N))``), so a tone above the grid's Nyquist
   frequency ``f_g / 2`` is attenuated instead of folding back into the band;
3. **interpolation** -- linear interpolation of the (filtered) samples onto the grid.

Sparse (GPS) streams are not interpolated: each fix is placed on the nearest grid sample (the later fix wins
when two land on one sample), NaN elsewhere.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import GPS_CHANNELS, Gap, Recording

ANTI_ALIAS_FRACTION = 0.4
"""Anti-aliasing cut-off as a fraction of the grid rate (0.5 would be the grid's Nyquist frequency)."""

ANTI_ALIAS_ORDER = 4
"""Order of the Butterworth anti-aliasing low-pass (applied twice: zero phase)."""


@dataclass(frozen=True)
class Stream:
    """One sensor's samples: ``time`` (m,) in s, strictly increasing; ``values`` (m, k); ``names`` (k channels)."""

    time: np.ndarray
    values: np.ndarray
    names: tuple[str, ...]

    def __post_init__(self) -> None:
        time = np.asarray(self.time, dtype=float)
        values = np.asarray(self.values, dtype=float)
        if values.ndim == 1:
            values = values[:, None]
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "names", tuple(self.names))
        if time.ndim != 1 or values.shape != (time.shape[0], len(self.names)):
            raise ValueError(f"stream of {len(self.names)} channel(s) got time {time.shape}, values {values.shape}")
        sparse = [n in GPS_CHANNELS for n in self.names]
        if any(sparse) and not all(sparse):
            raise ValueError(f"stream {self.names} mixes GPS and dense channels; give them as two streams")

    @property
    def sparse(self) -> bool:
        """True for GPS streams (placed on the nearest grid sample, never interpolated)."""
        return bool(self.names) and self.names[0] in GPS_CHANNELS

    @property
    def native_rate(self) -> float:
        """``1 / median(dt)`` in Hz (inf for fewer than two samples)."""
        if len(self.time) < 2:
            return float("inf")
        return 1.0 / float(np.median(np.diff(self.time)))


def merge_streams(
    streams: Mapping[str, Stream], rate: float = 20.0, max_gap: float = 0.5, source: str = "<memory>",
    repairs: list[str] | None = None,
) -> Recording:
    """Streams with their own clocks on one uniform grid of ``rate`` Hz (see the module docstring).

    ``streams`` maps a sensor name (used in gap reports) to its :class:`Stream`; channel names must be unique
    across streams. Dense samples with any NaN value are treated as missing: dropped before resampling, which
    ``repairs`` (when given) is told in one line per sensor that had any. Returns a Recording whose
    ``meta['native_rates']`` gives each stream's median rate (Hz), whose ``meta['repairs']`` is ``repairs`` (or
    empty) and whose ``gaps`` list every gap.
    """
    if not rate > 0 or not max_gap > 0:
        raise InputError(f"{source}: rate ({rate}) and max_gap ({max_gap}) must be positive")
    names = [n for s in streams.values() for n in s.names]
    if len(set(names)) != len(names):
        raise ValueError(f"channel names repeat across streams: {names}")
    repairs = [] if repairs is None else repairs
    dense = {k: _drop_missing(s, source, repairs) for k, s in streams.items() if not s.sparse}
    sparse = {k: s for k, s in streams.items() if s.sparse}
    for key, stream in dense.items():
        _check_dense(stream, key, max_gap, source)
    grid = _grid([*dense.values()] or [*sparse.values()], rate, source)

    channels: dict[str, np.ndarray] = {}
    gaps: list[Gap] = []
    invalid = np.zeros(len(grid), dtype=bool)
    for key, stream in dense.items():
        values, stream_gaps = _dense_on_grid(stream, grid, rate, max_gap)
        channels.update(zip(stream.names, values.T))
        for start, end in stream_gaps:
            invalid |= (grid > start) & (grid < end)
            gaps.append(Gap(start, end, key))
    for name in channels:
        channels[name][invalid] = np.nan
    for stream in sparse.values():
        channels.update(zip(stream.names, _sparse_on_grid(stream, grid, rate).T))
    gaps.sort(key=lambda g: (g.start, g.channel))
    native = {k: s.native_rate for k, s in streams.items()}
    return Recording(
        time=grid, channels=channels, rate=rate, source=source, gaps=gaps,
        meta={"repairs": repairs, "native_rates": native},
    )


def _drop_missing(stream: Stream, source: str, repairs: list[str]) -> Stream:
    keep = np.all(np.isfinite(stream.values), axis=1) & np.isfinite(stream.time)
    if keep.all():
        return stream
    names = [n for n, ok in zip(stream.names, np.isfinite(stream.values[~keep]).all(axis=0)) if not ok] or ["time"]
    repairs.append(f"{source}: dropped {int((~keep).sum())} sample(s) with a missing (empty or NaN) {', '.join(names)} "
                   "before resampling")
    return Stream(stream.time[keep], stream.values[keep], stream.names)


def _check_dense(stream: Stream, key: str, max_gap: float, source: str) -> None:
    if len(stream.time) < 2:
        raise InputError(f"{source}: sensor '{key}' has {len(stream.time)} usable sample(s); it needs at least two")
    if np.any(np.diff(stream.time) <= 0):
        raise InputError(f"{source}: sensor '{key}' has times that do not increase; sort them and drop repeats")
    if 1.0 / stream.native_rate > max_gap:
        raise InputError(
            f"{source}: sensor '{key}' samples every {1.0 / stream.native_rate:.3g} s, longer than the gap limit "
            f"{max_gap:g} s; check that its times are in seconds, or raise max_gap"
        )


def _grid(streams: list[Stream], rate: float, source: str) -> np.ndarray:
    """Uniform times over the overlap of the streams (first to last sample of each)."""
    streams = [s for s in streams if len(s.time)]
    if not streams:
        raise InputError(f"{source}: no sensor samples to put on a grid")
    start = max(float(s.time[0]) for s in streams)
    end = min(float(s.time[-1]) for s in streams)
    if end < start:
        raise InputError(f"{source}: the sensors do not overlap in time (common span {start:g}..{end:g} s)")
    count = int(np.floor((end - start) * rate + 1e-9)) + 1
    return np.minimum(start + np.arange(count) / rate, end)  # the last time may pass ``end`` by a rounding error


def _dense_on_grid(
    stream: Stream, grid: np.ndarray, rate: float, max_gap: float
) -> tuple[np.ndarray, list[tuple[float, float]]]:
    """Values ``(n, k)`` of a dense stream on the grid (anti-aliased when faster than it), and its gaps
    ``(t_i, t_i+1)``: the steps longer than ``max_gap``."""
    jumps = np.flatnonzero(np.diff(stream.time) > max_gap)
    gaps = [(float(stream.time[i]), float(stream.time[i + 1])) for i in jumps]
    cuts = np.r_[0, jumps + 1, len(stream.time)]
    fs = stream.native_rate
    sos = None
    if fs > rate:
        # imported here: scipy.signal takes about a second to import, which the command line's start would pay
        from scipy import signal

        sos = signal.butter(ANTI_ALIAS_ORDER, ANTI_ALIAS_FRACTION * rate, fs=fs, output="sos")
    out = np.full((len(grid), len(stream.names)), np.nan)
    for a, b in zip(cuts[:-1], cuts[1:]):
        t, v = stream.time[a:b], stream.values[a:b]
        inside = (grid >= t[0]) & (grid <= t[-1])
        if not inside.any():
            continue
        if sos is not None and b - a > 1:
            t, v = _low_pass(t, v, fs, sos)
        out[inside] = np.column_stack([np.interp(grid[inside], t, v[:, c]) for c in range(v.shape[1])])
    return out, gaps


def _low_pass(t: np.ndarray, v: np.ndarray, fs: float, sos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A gap-free piece made uniform at its native rate ``fs`` and low-passed with ``sos`` forward and backward."""
    count = int(np.floor((t[-1] - t[0]) * fs + 1e-9)) + 1
    uniform = t[0] + np.arange(count) / fs
    if uniform[-1] < t[-1]:
        uniform = np.r_[uniform, t[-1]]
    values = np.column_stack([np.interp(uniform, t, v[:, c]) for c in range(v.shape[1])])
    if len(uniform) < 2:
        return uniform, values
    from scipy.signal import sosfiltfilt

    padlen = min(3 * (2 * sos.shape[0] + 1), len(uniform) - 1)
    return uniform, sosfiltfilt(sos, values, axis=0, padlen=padlen)


def _sparse_on_grid(stream: Stream, grid: np.ndarray, rate: float) -> np.ndarray:
    """Values ``(n, k)`` of a GPS stream: each fix on its nearest grid sample, NaN elsewhere."""
    out = np.full((len(grid), len(stream.names)), np.nan)
    index = np.rint((stream.time - grid[0]) * rate).astype(np.int64) if len(stream.time) else np.array([], int)
    keep = (index >= 0) & (index < len(grid))
    index, values = index[keep], stream.values[keep]
    if len(index):
        last = len(index) - 1 - np.unique(index[::-1], return_index=True)[1]
        out[index[last]] = values[last]
    return out
