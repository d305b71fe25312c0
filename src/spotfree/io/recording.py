"""The Recording: one sensor log on a uniform time grid.

Every reader returns a :class:`Recording` and every later stage (filter, features, windows, classification)
consumes one. Conventions:

* ``time`` is in seconds on a uniform grid of ``rate`` Hz within each experiment (``time[k] = time[0] + k / rate``;
  a file of several experiments may restart the clock in each).
* ``channels`` holds float arrays in SI units (m/s^2, rad/s, rad, m, m/s, degrees only for ``lat``/``lon``).
  Raw IMU channels are ``ax ay az`` (m/s^2, gravity included) and ``gx gy gz`` (rad/s) in the device frame
  (Android: x right, y up, z out of the screen).
* Samples inside a reported gap are NaN in every channel; :meth:`Recording.segments` yields the gap-free pieces.
* GPS channels (``lat lon alt speed heading gps_accuracy``) are sparse: a value where a fix arrived, NaN
  elsewhere; they never make a gap.
* ``meta['repairs']`` lists every repair a reader made (one line each), so the user is told.
* ``truth`` holds string columns of ground truth (``label``, ``event``) for evaluation; training never reads it.
* ``experiment`` numbers separate experiments (rides) held in one file; a window never spans two of them.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
import numpy as np

from spotfree.errors import InputError

IMU_CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz")
ACC_CHANNELS = IMU_CHANNELS[:3]
GYRO_CHANNELS = IMU_CHANNELS[3:]
TRUTH_COLUMNS = ("label", "event")
GPS_CHANNELS = ("lat", "lon", "alt", "speed", "heading", "gps_accuracy")
"""Sparse channels: a value only on the samples where a fix arrived (about 1 Hz), NaN elsewhere."""


@dataclass(frozen=True)
class Gap:
    """A stretch with no measurements, ``start`` to ``end`` in seconds (exclusive of both measured ends)."""

    start: float
    end: float
    channel: str = "*"

    @property
    def duration(self) -> float:
        return self.end - self.start

    def __str__(self) -> str:
        return f"{self.channel}: no data from {self.start:.3f} s to {self.end:.3f} s ({self.duration:.2f} s)"


@dataclass
class Recording:
    """A multichannel signal on a uniform grid; see the module docstring for units and frames."""

    time: np.ndarray
    channels: dict[str, np.ndarray]
    rate: float
    source: str = "<memory>"
    truth: dict[str, np.ndarray] = field(default_factory=dict)
    experiment: np.ndarray | None = None
    gaps: list[Gap] = field(default_factory=list)
    meta: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.time = np.asarray(self.time, dtype=float)
        n = self.time.shape[0]
        self.channels = {k: np.asarray(v, dtype=float) for k, v in self.channels.items()}
        for name, column in [*self.channels.items(), *self.truth.items()]:
            if column.shape != (n,):
                raise InputError(f"{self.source}: column '{name}' has {column.shape[0]} rows, time has {n}")
        if self.experiment is not None:
            self.experiment = np.asarray(self.experiment, dtype=int)
            if self.experiment.shape != (n,):
                raise InputError(f"{self.source}: column 'experiment' has the wrong length")
        if not self.rate > 0:
            raise InputError(f"{self.source}: sampling rate must be positive, got {self.rate}")

    def __len__(self) -> int:
        return self.time.shape[0]

    @property
    def duration(self) -> float:
        """Length in seconds, ``n / rate``."""
        return len(self) / self.rate

    @property
    def names(self) -> list[str]:
        return list(self.channels)

    @property
    def has_imu(self) -> bool:
        """True when the six raw IMU channels are present."""
        return all(c in self.channels for c in IMU_CHANNELS)

    @property
    def has_accelerometer(self) -> bool:
        """True when the three raw accelerometer channels are present."""
        return all(c in self.channels for c in ACC_CHANNELS)

    def missing_advice(self) -> str:
        """What the reader said is missing for the ride features, in the app's terms: the advice of
        ``meta['missing']`` for each absent sensor (accelerometer, then gyroscope), each said once, joined by
        ``'; '``; empty when the reader said nothing."""
        advice = self.meta.get("missing", {})
        said = [advice[sensor] for sensor, channels in (("accelerometer", ACC_CHANNELS), ("gyroscope", GYRO_CHANNELS))
                if sensor in advice and any(c not in self.channels for c in channels)]
        return "; ".join(dict.fromkeys(said))

    def require_imu(self, purpose: str = "the ride features") -> None:
        """Raise an InputError unless the six raw IMU channels are present; its one line names what is missing
        in the recording app's terms when the reader said so (``meta['missing']``: sensor -> advice)."""
        if self.has_imu:
            return
        advice = self.missing_advice()
        if advice:
            raise InputError(f"{self.source}: {advice} (needed for {purpose})")
        missing = [c for c in IMU_CHANNELS if c not in self.channels]
        raise InputError(f"{self.source}: no column {', '.join(missing)}; {purpose} need ax ay az (m/s^2, gravity "
                         f"included) and gx gy gz (rad/s)")

    def array(self, names: list[str] | tuple[str, ...] | None = None) -> np.ndarray:
        """Channels stacked as an ``(n, len(names))`` float array (all channels when ``names`` is None)."""
        names = self.names if names is None else list(names)
        missing = [c for c in names if c not in self.channels]
        if missing:
            raise InputError(
                f"{self.source}: no column {', '.join(repr(m) for m in missing)}; "
                f"available: {', '.join(self.names)}"
            )
        if not names:
            return np.empty((len(self), 0))
        return np.column_stack([self.channels[c] for c in names])

    def take(self, index: np.ndarray | slice) -> "Recording":
        """Rows selected by a boolean mask, integer index or slice, as a new Recording.

        The new Recording has the same rate; gaps outside the selected time span are dropped.
        """
        time = self.time[index]
        lo, hi = (time[0], time[-1]) if len(time) else (0.0, 0.0)
        return replace(
            self,
            time=time,
            channels={k: v[index] for k, v in self.channels.items()},
            truth={k: v[index] for k, v in self.truth.items()},
            experiment=None if self.experiment is None else self.experiment[index],
            gaps=[g for g in self.gaps if g.end >= lo and g.start <= hi],
            meta=dict(self.meta),
        )

    def with_channels(self, channels: dict[str, np.ndarray], keep: bool = False) -> "Recording":
        """A Recording on the same grid with ``channels`` (added to the existing ones when ``keep``)."""
        merged = {**self.channels, **channels} if keep else dict(channels)
        return replace(self, channels=merged, truth=dict(self.truth), meta=dict(self.meta), gaps=list(self.gaps))

    def experiment_numbers(self) -> np.ndarray:
        """The experiment number of every sample (all 1 when there is no column)."""
        return self.experiment if self.experiment is not None else np.ones(len(self), dtype=int)

    def experiments(self) -> list[tuple[int, "Recording"]]:
        """``(number, Recording)`` for each experiment in the file (one, numbered 1, when there is no column)."""
        if self.experiment is None:
            return [(1, self)]
        return [(int(k), self.take(self.experiment == k)) for k in np.unique(self.experiment)]

    def select_experiment(self, k: int) -> "Recording":
        """Experiment ``k`` alone (the ``PATH@K`` syntax of the command line)."""
        for number, part in self.experiments():
            if number == k:
                return part
        available = ", ".join(str(n) for n, _ in self.experiments())
        raise InputError(f"{self.source}: no experiment {k}; the file holds experiments {available}")

    def valid(self) -> np.ndarray:
        """Boolean mask of samples where every dense channel is finite (False inside gaps).

        GPS channels (:data:`GPS_CHANNELS`) are sparse by nature and do not count.
        """
        dense = [c for c in self.channels if c not in GPS_CHANNELS]
        if not dense:
            return np.ones(len(self), dtype=bool)
        return np.all(np.isfinite(self.array(dense)), axis=1)

    def segments(self) -> list[tuple[int, int]]:
        """``(start, stop)`` index ranges of the gap-free stretches, each within one experiment."""
        ok = self.valid()
        starts = ok & ~np.r_[False, ok[:-1]]
        stops = ok & ~np.r_[ok[1:], False]
        if self.experiment is not None and len(self) > 1:
            change = np.diff(self.experiment) != 0
            starts[1:] |= change & ok[1:]
            stops[:-1] |= change & ok[:-1]
        return list(zip(np.flatnonzero(starts).tolist(), (np.flatnonzero(stops) + 1).tolist()))
