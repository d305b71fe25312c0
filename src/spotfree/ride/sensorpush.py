"""The Sensor Logger app's HTTP push messages, turned into uniform-rate sample batches.

A message (the app's HTTP push and MQTT schema) is ``{"messageId": n, "sessionId": "...", "deviceId": "...",
"payload": [{"name": "accelerometer", "time": <UNIX ns>, "values": {"x": .., "y": .., "z": ..}}, ...]}``; the
names used here are ``totalacceleration`` (m/s^2, gravity included, Android), ``accelerometer`` + ``gravity``
(m/s^2, without gravity and gravity alone: their sum is the specific force), ``gyroscope`` (rad/s) and
``location`` (``latitude``, ``longitude`` degrees, ``speed`` m/s, negative = invalid). Other sensors are ignored.
Without "Standardise Units & Frames", iOS accelerations have the opposite sign of Android's (CoreMotion); the
push carries no platform, so the sender says ``platform=ios`` and they are negated here.

:class:`PushResampler` puts the motion readings of one session on the grid ``k / rate`` (s since the session's
first motion reading): a grid sample is the mean of the readings in ``[(k - 1/2) / rate, (k + 1/2) / rate)`` (a
box anti-aliasing filter centred on the grid time), emitted once a reading of a later slot of both the accelerometer and the gyroscope has
arrived; a slot that one of them missed is skipped (a hole the classifier treats as a gap when it lasts longer
than ``max_gap``). A location fix goes on the first grid sample at or after its time.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from collections.abc import Mapping

from spotfree.errors import InputError

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


class PushResampler:
    """Motion readings of one session onto the grid ``k / rate`` (see the module docstring)."""

    def __init__(self, rate: float = 20.0):
        self.rate = rate
        self.origin: float | None = None
        self._slot = {"acc": None, "gyr": None}
        self._sums: dict[str, dict[int, list[float]]] = {"acc": {}, "gyr": {}}
        self._fixes: deque[tuple[float, tuple]] = deque()
        self._emitted = -1
        self.dropped = 0
        """Motion readings not stored so far: their slot lacked a reading of the other motion sensor."""

    def add(self, readings: list[tuple[str, float, tuple]]) -> dict[str, list[float]]:
        """Take readings from :func:`parse_push`; return the grid samples now complete, as columns of
        :data:`~spotfree.ride.records.SAMPLE_COLUMNS` (time in s since the session's first motion reading).

        A motion reading for a slot already emitted (late, or sent twice) refuses the whole message
        (InputError) and changes nothing; readings of a slot that only one of the two motion sensors filled are
        counted in :attr:`dropped` (never stored)."""
        if self.origin is not None:
            for kind, t, _ in readings:
                if kind != "fix" and math.floor((t - self.origin) * self.rate + 0.5) <= self._emitted:
                    raise InputError(f"push: a {kind} reading at {t:.3f} s (UNIX) is for a sample already stored; "
                                     "send each reading once, in time order")
        for kind, t, values in readings:
            if kind == "fix":
                self._fixes.append((t, values))
                continue
            if self.origin is None:
                self.origin = t
            slot = math.floor((t - self.origin) * self.rate + 0.5)
            total = self._sums[kind].setdefault(slot, [0.0, 0.0, 0.0, 0.0])
            for i in range(3):
                total[i] += values[i]
            total[3] += 1
            self._slot[kind] = slot if self._slot[kind] is None else max(self._slot[kind], slot)
        return self._complete()

    def _complete(self) -> dict[str, list[float]]:
        columns: dict[str, list[float]] = {c: [] for c in ("time", "ax", "ay", "az", "gx", "gy", "gz",
                                                           "lat", "lon", "speed")}
        if self._slot["acc"] is None or self._slot["gyr"] is None:
            return columns
        done = min(self._slot["acc"], self._slot["gyr"]) - 1
        for slot in sorted(s for s in self._sums["acc"] if s <= done):
            acc = self._sums["acc"].pop(slot)
            gyr = self._sums["gyr"].pop(slot, None)
            if gyr is None:
                self.dropped += int(acc[3])
                continue
            t = slot / self.rate
            fix = (math.nan, math.nan, math.nan)
            while self._fixes and self._fixes[0][0] - self.origin <= t:
                fix = self._fixes.popleft()[1]
            for name, value in zip(columns, (t, *(v / acc[3] for v in acc[:3]), *(v / gyr[3] for v in gyr[:3]),
                                             *fix)):
                columns[name].append(value)
        for slot in [s for s in self._sums["gyr"] if s <= done]:
            self.dropped += int(self._sums["gyr"].pop(slot)[3])
        self._emitted = max(self._emitted, done)
        return columns
