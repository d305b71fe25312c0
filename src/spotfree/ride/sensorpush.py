"""The Sensor Logger app's HTTP push messages, turned into uniform-rate sample batches.

A message (the app's HTTP push and MQTT schema) is ``{"messageId": n, "sessionId": "...", "deviceId": "...",
"payload": [{"name": "accelerometer", "time": <UNIX ns>, "values": {"x": .., "y": .., "z": ..}}, ...]}``; the
names used here are ``totalacceleration`` (m/s^2, gravity included, Android), ``accelerometer`` + ``gravity``
(m/s^2, without gravity and gravity alone: their sum is the specific force), ``gyroscope`` (rad/s) and
``location`` (``latitude``, ``longitude`` degrees, ``speed`` m/s, negative = invalid; a fix outside the limits of
:mod:`spotfree.limits` refuses its message before anything is kept). Other sensors are ignored.
Without "Standardise Units & Frames", iOS accelerations have the opposite sign of Android's (CoreMotion); the
push carries no platform, so the sender says ``platform=ios`` and they are negated here.

:class:`PushResampler` puts the motion readings of one session on the grid ``k / rate`` (s since the session's
first motion reading): a grid sample is the mean of the readings in ``[(k - 1/2) / rate, (k + 1/2) / rate)`` (a
box anti-aliasing filter centred on the grid time), emitted once a reading of a later slot of both the accelerometer and the gyroscope has
arrived; a slot that one of them missed is skipped (a hole the classifier treats as a gap when it lasts longer
than ``max_gap``). A location fix goes on the first grid sample at or after its time. A slot waits for the other
motion sensor at most :data:`STALE_SECONDS` (a phone with its gyroscope off has its readings dropped and counted),
so what a session holds is bounded; :class:`PushSessions` frees a session when its ride ends or idles.
"""

from __future__ import annotations

import asyncio
import bisect
import math
import threading
import time as clock
from collections import deque
from collections.abc import Mapping
from dataclasses import dataclass, field

from spotfree.errors import InputError
from spotfree.limits import DEGREE_BOUNDS, MAX_SPEED

MAX_READINGS = 20000
"""Readings in one push message (the app's 1 s default batch at 500 Hz from every sensor is far below)."""
PLATFORMS = ("android", "ios")


def _number(value, where: str) -> float:
    """A JSON number as float; text (even "1.5"), booleans and null are refused, not converted."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where}: {value!r:.40} is not a number; send numbers, not text")
    x = float(value)
    if not math.isfinite(x):
        raise InputError(f"{where}: {value!r} is not finite; send finite numbers")
    return x


def _xyz(reading: Mapping, where: str) -> tuple[float, float, float]:
    values = reading.get("values", reading)
    if not isinstance(values, Mapping):
        raise InputError(f"{where}: 'values' must be an object with x, y, z")
    try:
        return tuple(_number(values[axis], f"{where}.values.{axis}") for axis in "xyz")  # type: ignore[return-value]
    except KeyError as exc:
        raise InputError(f"{where}: no field {exc.args[0]!r} in 'values'; send x, y and z") from None


def parse_push(message: object, platform: str = "android") -> tuple[str, list[tuple[str, float, tuple]]]:
    """``(session_id, readings)`` of one push message, readings ``(kind, time_s, values)`` sorted by time with
    ``kind`` in ``acc`` (specific force, m/s^2, Android signs), ``gyr`` (rad/s), ``fix`` (lat, lon, speed);
    :class:`InputError` naming the field for anything malformed (nothing is kept of a refused message)."""
    if platform not in PLATFORMS:
        raise InputError(f"push: platform={platform!r}; use one of {', '.join(PLATFORMS)}")
    if not isinstance(message, Mapping) or not isinstance(message.get("payload"), list):
        raise InputError("push: the body must be a JSON object with a 'payload' list (Sensor Logger HTTP push)")
    session = message.get("sessionId")
    if not isinstance(session, str) or not 0 < len(session) <= 100:
        raise InputError("push: field 'sessionId' must be text of 1 to 100 characters")
    payload = message["payload"]
    if len(payload) > MAX_READINGS:
        raise InputError(f"push: {len(payload)} readings in one message; send at most {MAX_READINGS}")
    sign = -1.0 if platform == "ios" else 1.0
    gravity: dict[float, tuple] = {}
    linear: list[tuple[float, tuple]] = []
    readings: list[tuple[str, float, tuple]] = []
    for k, reading in enumerate(payload):
        where = f"push: payload[{k}]"
        if not isinstance(reading, Mapping):
            raise InputError(f"{where} must be an object with 'name' and 'time'")
        name = reading.get("name")
        if name not in ("totalacceleration", "accelerometer", "gravity", "gyroscope", "location"):
            continue
        t = _number(reading.get("time"), f"{where}.time") * 1e-9
        if not 1e8 < t < 1e10:
            raise InputError(f"{where}.time: {reading.get('time')!r} is not UNIX epoch nanoseconds")
        if name == "location":
            values = reading.get("values", reading)
            if not isinstance(values, Mapping):
                raise InputError(f"{where}: 'values' must be an object with latitude, longitude (and speed)")
            lat = _number(values.get("latitude"), f"{where}.values.latitude")
            lon = _number(values.get("longitude"), f"{where}.values.longitude")
            speed = _number(values.get("speed", -1.0), f"{where}.values.speed")
            for name, value in (("latitude", lat), ("longitude", lon)):
                bound = DEGREE_BOUNDS[name[:3]]
                if abs(value) > bound:
                    raise InputError(f"{where}.values.{name}: {value:g} is not degrees within +-{bound:g}; send "
                                     "WGS-84 degrees")
            if speed > MAX_SPEED:
                raise InputError(f"{where}.values.speed: {speed:g} m/s is over {MAX_SPEED:g}; send m/s (negative: "
                                 "unknown)")
            readings.append(("fix", t, (lat, lon, speed if speed >= 0 else math.nan)))
        elif name == "gyroscope":
            readings.append(("gyr", t, _xyz(reading, where)))
        elif name == "totalacceleration":
            readings.append(("acc", t, tuple(sign * v for v in _xyz(reading, where))))
        elif name == "gravity":
            gravity[t] = _xyz(reading, where)
        else:
            linear.append((t, _xyz(reading, where)))
    if linear and not any(kind == "acc" for kind, _, _ in readings):
        if not gravity:
            raise InputError("push: 'accelerometer' (without gravity) needs 'gravity' or 'totalacceleration' "
                             "readings in the same message; enable Gravity in Sensor Logger")
        times = sorted(gravity)
        for t, values in linear:
            nearest = _nearest(times, t)
            readings.append(("acc", t, tuple(sign * (a + g) for a, g in zip(values, gravity[nearest]))))
    readings.sort(key=lambda r: r[1])
    return session, readings


def _nearest(times: list[float], t: float) -> float:
    """The element of the sorted, non-empty ``times`` closest to ``t`` (the earlier one on a tie): a bisection,
    so that matching every reading of a message costs ``O(n log n)``."""
    k = bisect.bisect_left(times, t)
    if k == 0:
        return times[0]
    if k == len(times):
        return times[-1]
    before, after = times[k - 1], times[k]
    return before if t - before <= after - t else after


STALE_SECONDS = 3.0
"""Seconds a motion reading waits for the other motion sensor: a slot this far behind the latest motion reading
of either sensor is settled (stored when both filled it, its readings dropped and counted otherwise)."""
MAX_PENDING_FIXES = 1000
"""Location fixes of one session waiting for a grid sample; beyond it the oldest are dropped and counted."""


class PushResampler:
    """Motion readings of one session onto the grid ``k / rate`` (see the module docstring).

    The state is bounded whatever arrives: slots within :data:`STALE_SECONDS` of the latest motion reading (a
    phone that sends one motion sensor only, or a sensor that stopped, has its readings dropped and counted once
    they are that old) and at most :data:`MAX_PENDING_FIXES` fixes. :meth:`add` changes the state in place, in
    time linear in the message; :meth:`rollback` undoes the last :meth:`add` (its samples were not stored), in
    time linear in that message too.
    """

    def __init__(self, rate: float = 20.0):
        self.rate = rate
        self.origin: float | None = None
        self._slot = {"acc": None, "gyr": None}
        self._sums: dict[str, dict[int, list[float]]] = {"acc": {}, "gyr": {}}
        self._fixes: deque[tuple[float, tuple]] = deque()
        self._carry: tuple | None = None
        self._emitted = -1
        self._stale = max(1, math.ceil(STALE_SECONDS * rate))
        self._journal: dict | None = None
        self.dropped = 0
        """Readings not stored so far: motion readings of a slot the other motion sensor missed (by
        :data:`STALE_SECONDS` at most), and fixes over :data:`MAX_PENDING_FIXES`."""

    def held(self) -> int:
        """Slots and fixes held, waiting for later readings (at most about ``2 * STALE_SECONDS * rate + 2`` slots
        and :data:`MAX_PENDING_FIXES` fixes)."""
        return len(self._sums["acc"]) + len(self._sums["gyr"]) + len(self._fixes)

    def add(self, readings: list[tuple[str, float, tuple]]) -> dict[str, list[float]]:
        """Take readings from :func:`parse_push`; return the grid samples now complete, as columns of
        :data:`~spotfree.ride.records.SAMPLE_COLUMNS` (time in s since the session's first motion reading).

        A motion reading for a slot already settled (late, sent twice, or older than :data:`STALE_SECONDS`)
        refuses the whole message (InputError) and changes nothing; readings of a slot that only one of the two
        motion sensors filled are counted in :attr:`dropped` (never stored). Until the next call,
        :meth:`rollback` undoes this one."""
        self._journal = None
        if self.origin is not None:
            for kind, t, _ in readings:
                if kind != "fix" and math.floor((t - self.origin) * self.rate + 0.5) <= self._emitted:
                    raise InputError(f"push: a {kind} reading at {t:.3f} s (UNIX) is for a sample already stored; "
                                     "send each reading once, in time order")
        journal = self._journal = {"origin": self.origin, "slot": dict(self._slot), "emitted": self._emitted,
                                   "dropped": self.dropped, "carry": self._carry, "sums": {}, "popped": [],
                                   "appended": 0}
        for kind, t, values in readings:
            if kind == "fix":
                self._fixes.append((t, values))
                journal["appended"] += 1
                continue
            if self.origin is None:
                self.origin = t
            slot = math.floor((t - self.origin) * self.rate + 0.5)
            total = self._touch(kind, slot)
            if total is None:
                total = self._sums[kind][slot] = [0.0, 0.0, 0.0, 0.0]
            for i in range(3):
                total[i] += values[i]
            total[3] += 1
            self._slot[kind] = slot if self._slot[kind] is None else max(self._slot[kind], slot)
        while len(self._fixes) > MAX_PENDING_FIXES:
            journal["popped"].append(self._fixes.popleft())
            self.dropped += 1
        return self._complete()

    def rollback(self) -> None:
        """Undo the last :meth:`add` (nothing when there is none, or it was undone already)."""
        journal, self._journal = self._journal, None
        if journal is None:
            return
        self.origin, self._slot, self._emitted = journal["origin"], journal["slot"], journal["emitted"]
        self.dropped, self._carry = journal["dropped"], journal["carry"]
        for (kind, slot), old in journal["sums"].items():
            if old is None:
                self._sums[kind].pop(slot, None)
            else:
                self._sums[kind][slot] = old
        # before the call the queue was its popped fixes and what is left, less the fixes appended
        fixes = journal["popped"] + list(self._fixes)
        self._fixes = deque(fixes[:len(fixes) - journal["appended"]])

    def _touch(self, kind: str, slot: int) -> list[float] | None:
        """The sums of ``slot``, their value before this call kept in the journal."""
        total = self._sums[kind].get(slot)
        if (kind, slot) not in self._journal["sums"]:
            self._journal["sums"][(kind, slot)] = None if total is None else list(total)
        return total

    def _complete(self) -> dict[str, list[float]]:
        columns: dict[str, list[float]] = {c: [] for c in ("time", "ax", "ay", "az", "gx", "gy", "gz",
                                                           "lat", "lon", "speed")}
        slots = [s for s in self._slot.values() if s is not None]
        if not slots:
            return columns
        done = max(slots) - self._stale
        if len(slots) == 2:
            done = max(done, min(slots) - 1)
        if done <= self._emitted:
            return columns
        for slot in sorted({s for sums in self._sums.values() for s in sums if s <= done}):
            acc, gyr = self._touch("acc", slot), self._touch("gyr", slot)
            self._sums["acc"].pop(slot, None)
            self._sums["gyr"].pop(slot, None)
            t = slot / self.rate
            self._take_fixes(t)
            if acc is None or gyr is None:
                self.dropped += int((acc or gyr)[3])
                continue
            fix, self._carry = self._carry or (math.nan, math.nan, math.nan), None
            for name, value in zip(columns, (t, *(v / acc[3] for v in acc[:3]), *(v / gyr[3] for v in gyr[:3]),
                                             *fix)):
                columns[name].append(value)
        self._take_fixes(done / self.rate)
        self._emitted = done
        return columns

    def _take_fixes(self, t: float) -> None:
        """The fixes at or before ``t`` (s since the origin) leave the queue; the latest waits in ``_carry`` for
        the next grid sample stored."""
        while self._fixes and self._fixes[0][0] - self.origin <= t:
            fix = self._fixes.popleft()
            self._journal["popped"].append(fix)
            self._carry = fix[1]


@dataclass
class PushSession:
    """One push session: its ride (None until started), its resampler, the lock its messages take turns on and
    when it was last used (``time.monotonic`` s)."""

    lock: asyncio.Lock = field(default_factory=asyncio.Lock)
    ride_id: str | None = None
    resampler: PushResampler | None = None
    last: float = field(default_factory=clock.monotonic)


class PushSessions:
    """The push sessions in progress, keyed ``(device token hash, sessionId)``. A session is freed when its ride
    ends (the device ended it, or the service closed it idle: :meth:`~spotfree.ride.service.RideService.on_end`;
    the session's next message starts a new ride) or when no message came for ``idle`` s (checked at most every
    ``sweep`` s, when a message comes)."""

    def __init__(self, service, idle: float = 3600.0, sweep: float = 60.0):
        self.idle, self.sweep = idle, sweep
        self._sessions: dict[tuple[str, str], PushSession] = {}
        self._by_ride: dict[str, tuple[str, str]] = {}
        self._lock = threading.Lock()
        self._swept = clock.monotonic()
        service.on_end(self._ride_ended)

    def __len__(self) -> int:
        return len(self._sessions)

    def get(self, key: tuple[str, str]) -> PushSession:
        """The session of ``key``, new when there is none; marked used now."""
        now = clock.monotonic()
        with self._lock:
            if now - self._swept > self.sweep:
                self._swept = now
                for old, session in list(self._sessions.items()):
                    if now - session.last > self.idle and not session.lock.locked():
                        self._drop(old)
            session = self._sessions.setdefault(key, PushSession())
            session.last = now
        return session

    def started(self, key: tuple[str, str], session: PushSession, ride_id: str, resampler: PushResampler) -> None:
        """``session`` (of ``key``) rides ``ride_id`` from now on."""
        with self._lock:
            session.ride_id, session.resampler = ride_id, resampler
            if self._sessions.get(key) is session:
                self._by_ride[ride_id] = key

    def forget(self, key: tuple[str, str], session: PushSession) -> None:
        """Free ``session`` (its ride could not start)."""
        with self._lock:
            if self._sessions.get(key) is session:
                self._drop(key)

    def _drop(self, key: tuple[str, str]) -> None:
        session = self._sessions.pop(key)
        if session.ride_id is not None:
            self._by_ride.pop(session.ride_id, None)

    def _ride_ended(self, ride_id: str) -> None:
        with self._lock:
            key = self._by_ride.get(ride_id)
            if key is not None:
                self._drop(key)
