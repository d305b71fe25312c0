"""The ride assistant: warnings of dangerous manoeuvres and the trip figures, from the label stream and GPS.

:class:`RideAssistant` is fed one sample at a time (its time, the classifier's label, and the GPS fix when one
arrived) and answers with a :class:`Status`.

Warnings (one per manoeuvre): for each dangerous class (``sudden-braking`` by default) an episode starts when the
label has held that class for ``min_duration`` seconds (from its first sample, so a one-window blip does not
warn); the warning is issued at that sample, its onset is the first sample of the run. The episode goes on while
a run of the class that holds for ``min_duration`` comes within ``refractory`` seconds of the last one: a stop
whose label flickers gives one warning, and stray samples of the class neither warn nor prolong it. It ends when
no such run has come for longer than ``refractory``; the :class:`~spotfree.ride.records.Event` (``start`` = onset,
``end`` = the last sample of its last run) is then reported once, and a later run can warn again.

GPS (``lat``, ``lon`` in WGS-84 degrees; ``speed`` in m/s):

* distance between fixes is the haversine great-circle distance
  ``d = 2 R asin(sqrt(sin^2(dphi/2) + cos phi1 cos phi2 sin^2(dlambda/2)))`` with gpxpy's ``R = 6378137`` m;
* a fix is a *jump* when reaching it from the last accepted fix needs more than ``max_speed``; it is ignored
  (no distance, no position). When the next fix is plausible from the ignored one but not from the accepted one,
  the accepted fix was the outlier (or the receiver lost the track): the position moves there without adding
  distance;
* distance is counted from an anchor: an accepted fix less than ``min_step`` from the anchor moves the position
  but adds nothing; one farther adds its distance from the anchor and becomes the anchor. Phone fixes wander by
  about half a metre a second even when standing (:mod:`spotfree.sim.gps` models it): summed fix to fix, that
  wander would count as distance;
* ``speed`` is the receiver's speed of the latest fix, or, when a fix has none, the distance from the previous
  accepted fix over the time between them; it is NaN once no fix has come for ``fix_timeout`` seconds;
* time to destination: ``eta = remaining / v_avg``, ``remaining`` the great-circle distance from the position to
  the destination set by the rider, ``v_avg`` the distance travelled over the last ``speed_window`` seconds
  divided by the time it took (from the last accepted fix at or before ``t - speed_window``, or the first fix).
  It is NaN while ``v_avg`` is below ``min_moving_speed`` (standing, the time is unknown) and 0 within
  ``arrival_radius`` of the destination.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

from gpxpy.geo import haversine_distance

from spotfree.errors import InputError
from spotfree.ride.records import Event
from spotfree.ride.validation import MAX_SPEED

KMH = 3.6
"""km/h per m/s."""

TIME_TOLERANCE = 1e-6
"""s; durations compared with ``min_duration`` and ``refractory`` within it (sample times are sums of floats)."""


@dataclass(frozen=True)
class RideWarning:
    """A dangerous manoeuvre of class ``kind`` whose label began at ``onset`` and was warned of at ``time`` (s)."""

    kind: str
    onset: float
    time: float


@dataclass(frozen=True)
class Status:
    """What the rider sees after a sample: the label, a warning issued at this sample, an event that ended at it,
    and the trip figures (NaN where unknown; s, m, m/s, degrees)."""

    time: float
    label: str | None
    warning: RideWarning | None
    event: Event | None
    lat: float
    lon: float
    speed: float
    distance: float
    remaining: float
    eta: float

    @property
    def speed_kmh(self) -> float:
        """Speed in km/h."""
        return self.speed * KMH

    def figures(self) -> dict:
        """The trip figures as JSON-ready numbers (None where unknown): ``time`` s, ``lat lon`` degrees,
        ``speed`` m/s, ``speed_kmh``, ``distance`` and ``remaining`` m, ``eta`` s."""
        values = {"time": self.time, "lat": self.lat, "lon": self.lon, "speed": self.speed,
                  "speed_kmh": self.speed_kmh, "distance": self.distance, "remaining": self.remaining, "eta": self.eta}
        return {k: v if math.isfinite(v) else None for k, v in values.items()}


class RideAssistant:
    """Warnings and trip figures of one ride (see the module docstring for the rules).

    Parameters
    ----------
    dangerous : tuple of str
        Classes that warn the rider.
    min_duration : float
        s a dangerous label must hold before the warning (0 warns at its first sample).
    refractory : float
        s of absence of the class after which an episode ends; a return within it continues the episode.
    max_speed : float
        m/s; a fix farther than this speed allows from the last accepted one is a jump.
    fix_timeout : float
        s without a fix after which the speed is unknown.
    speed_window : float
        s over which the average speed for the time to destination is taken.
    min_moving_speed : float
        m/s; below it the time to destination is unknown.
    arrival_radius : float
        m from the destination within which the rider has arrived.
    min_step : float
        m an accepted fix must be from the anchor to add distance.
    """

    def __init__(self, dangerous: tuple[str, ...] = ("sudden-braking",), min_duration: float = 0.1,
                 refractory: float = 3.0, max_speed: float = 12.0, fix_timeout: float = 5.0,
                 speed_window: float = 30.0, min_moving_speed: float = 0.3, arrival_radius: float = 10.0,
                 min_step: float = 2.0):
        self.dangerous = tuple(dangerous)
        self.min_duration = min_duration
        self.refractory = refractory
        self.max_speed = max_speed
        self.fix_timeout = fix_timeout
        self.speed_window = speed_window
        self.min_moving_speed = min_moving_speed
        self.arrival_radius = arrival_radius
        self.min_step = min_step
        for name in ("min_duration", "refractory", "max_speed", "fix_timeout", "speed_window", "min_moving_speed",
                     "arrival_radius", "min_step"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0) or (value == 0 and name in ("max_speed", "speed_window")):
                raise InputError(f"RideAssistant: {name}={value!r}; give a finite, non-negative number of SI units")
        if not self.dangerous or not all(isinstance(k, str) and k for k in self.dangerous):
            raise InputError("RideAssistant: dangerous must name at least one class")
        self.destination: tuple[float, float] | None = None
        self.events_: list[Event] = []
        self._popped = 0
        self._status_: Status | None = None
        self._time: float | None = None
        self._run: dict[str, float | None] = dict.fromkeys(self.dangerous)
        self._episode: dict[str, list[float] | None] = dict.fromkeys(self.dangerous)
        self._fix: tuple[float, float, float] | None = None  # t, lat, lon of the last accepted fix
        self._jump: tuple[float, float, float] | None = None
        self._anchor: tuple[float, float] | None = None  # lat, lon where distance was last counted
        self._speed, self._speed_time = math.nan, -math.inf
        self._distance = 0.0
        self._history: deque[tuple[float, float]] = deque()  # (t, distance) at accepted fixes

    def set_destination(self, lat: float, lon: float) -> None:
        """The destination (degrees) the time to destination is counted to."""
        self.destination = _position(lat, lon, "destination")

    def clear_destination(self) -> None:
        self.destination = None

    def update(self, t: float, label: str | None, lat: float = math.nan, lon: float = math.nan,
               speed: float = math.nan) -> Status:
        """Take one sample at ``t`` s: the classifier's ``label`` (None before its first window) and the GPS fix
        (``lat``, ``lon`` degrees and ``speed`` m/s, NaN when no fix arrived with this sample)."""
        warning, event = self._advance(t, label, lat, lon, speed)
        self._status_ = self._status(self._time, label, warning, event)
        return self._status_

    def update_block(self, table: list[tuple], labels: list[str | None]) -> list[RideWarning]:
        """:meth:`update` for each ``(t, lat, lon, speed)`` of ``table`` with its label; the warnings raised, in
        order. The :class:`Status` (:meth:`state`) is made for the last sample only."""
        warnings, warning, event = [], None, None
        for (t, lat, lon, speed), label in zip(table, labels):
            warning, event = self._advance(t, label, lat, lon, speed)
            if warning is not None:
                warnings.append(warning)
        if table:
            self._status_ = self._status(self._time, labels[-1], warning, event)
        return warnings

    def _advance(self, t: float, label: str | None, lat: float, lon: float,
                 speed: float) -> tuple[RideWarning | None, Event | None]:
        """One sample's warning and event (None when none), its debouncing and GPS taken."""
        t, speed = float(t), float(speed)
        if not math.isfinite(t) or (self._time is not None and t <= self._time):
            raise InputError(f"ride assistant: sample time {t!r} s is not after {self._time!r} s; "
                             "feed samples in time order")
        fix = _position(lat, lon, "fix") if math.isfinite(lat) or math.isfinite(lon) else None
        if not math.isnan(speed) and not 0 <= speed <= MAX_SPEED:
            raise InputError(f"ride assistant: GPS speed {speed!r} m/s at {t} s; send m/s within "
                             f"[0, {MAX_SPEED:g}] or NaN")
        self._time = t
        warning, event = None, None
        for kind in self.dangerous:
            if label != kind and self._run[kind] is None and self._episode[kind] is None:
                continue  # nothing of this kind going on: _manoeuvre would change nothing
            warned, ended = self._manoeuvre(kind, t, label == kind)
            warning, event = warning or warned, event or ended
        if fix is not None:
            self._gps(t, *fix, speed)
        elif math.isfinite(speed):
            self._speed, self._speed_time = speed, t
        return warning, event

    def state(self) -> dict:
        """The figures of the latest sample (:meth:`Status.figures`); empty before the first sample."""
        return {} if self._status_ is None else self._status_.figures()

    def pop_events(self) -> list[Event]:
        """The events that ended since the last call (to record them as they end)."""
        new, self._popped = self.events_[self._popped:], len(self.events_)
        return new

    def finish(self) -> list[Event]:
        """End the ride: close the open episodes and return every event of the ride."""
        for kind, episode in self._episode.items():
            if episode is not None:
                self.events_.append(Event(kind, episode[0], episode[1]))
                self._episode[kind] = None
        return sorted(self.events_, key=lambda e: (e.start, e.kind))

    # ------------------------------------------------------------ warnings

    def _manoeuvre(self, kind: str, t: float, present: bool) -> tuple[RideWarning | None, Event | None]:
        """Advance the debouncing of one dangerous class by a sample."""
        episode = self._episode[kind]
        if present:
            if self._run[kind] is None:
                self._run[kind] = t
            if t - self._run[kind] < self.min_duration - TIME_TOLERANCE:
                return None, None
            if episode is not None:
                episode[1] = t
                return None, None
            self._episode[kind] = [self._run[kind], t]
            return RideWarning(kind, self._run[kind], t), None
        self._run[kind] = None
        if episode is not None and t - episode[1] > self.refractory + TIME_TOLERANCE:
            self._episode[kind] = None
            self.events_.append(Event(kind, episode[0], episode[1]))
            return None, self.events_[-1]
        return None, None

    # ------------------------------------------------------------ GPS

    def _gps(self, t: float, lat: float, lon: float, speed: float) -> None:
        """Take a fix: accept it (counting its distance), ignore it as a jump, or re-anchor after an outlier."""
        if self._fix is not None and self._plausible(self._fix, t, lat, lon):
            derived = haversine_distance(self._fix[1], self._fix[2], lat, lon) / (t - self._fix[0])
            step = haversine_distance(*self._anchor, lat, lon)
            if step >= self.min_step:
                self._distance += step
                self._anchor = (lat, lon)
            speed = speed if math.isfinite(speed) else derived
        elif self._fix is None or (self._jump is not None and self._plausible(self._jump, t, lat, lon)):
            self._history.clear()
            self._anchor = (lat, lon)
        else:
            self._jump = (t, lat, lon)
            return
        self._fix, self._jump = (t, lat, lon), None
        self._history.append((t, self._distance))
        while len(self._history) > 2 and self._history[1][0] <= t - self.speed_window:
            self._history.popleft()
        if math.isfinite(speed):
            self._speed, self._speed_time = speed, t

    def _plausible(self, fix: tuple[float, float, float], t: float, lat: float, lon: float) -> bool:
        """Whether the new position is reachable from ``fix`` (t, lat, lon) at ``max_speed``."""
        return haversine_distance(fix[1], fix[2], lat, lon) <= self.max_speed * (t - fix[0])

    def _status(self, t: float, label: str | None, warning: RideWarning | None, event: Event | None) -> Status:
        lat, lon = (self._fix[1], self._fix[2]) if self._fix is not None else (math.nan, math.nan)
        speed = self._speed if t - self._speed_time <= self.fix_timeout else math.nan
        remaining = eta = math.nan
        if self.destination is not None and self._fix is not None:
            remaining = haversine_distance(lat, lon, *self.destination)
            if remaining <= self.arrival_radius:
                eta = 0.0
            else:
                (t0, d0), (t1, d1) = self._history[0], self._history[-1]
                average = (d1 - d0) / (t1 - t0) if t1 > t0 else math.nan
                eta = remaining / average if average >= self.min_moving_speed else math.nan
        return Status(t, label, warning, event, lat, lon, speed, self._distance, remaining, eta)


def _position(lat: float, lon: float, what: str) -> tuple[float, float]:
    lat, lon = float(lat), float(lon)
    if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90 and abs(lon) <= 180):
        raise InputError(f"ride assistant: {what} lat={lat!r}, lon={lon!r}; send degrees within [-90, 90] and "
                         "[-180, 180], both together")
    return lat, lon
