"""Hand-tracking frames: the JSON schema of the Leap Motion / Ultraleap tracking service and spotfree's model of it.

The tracking service (Leap Motion ``leapd``, Ultraleap's WebSocket server) sends one JSON object per frame,
protocol v6 (``ws://127.0.0.1:6437/v6.json``; leapjs ``PROTOCOL.md``, ``lib/frame.js``, ``lib/hand.js``,
``lib/finger.js``). Vectors are in the Leap frame: origin at the centre of the device's top face, x right along
its long side, y up, z toward the user (right-handed); lengths in mm. The fields read are

* frame: ``timestamp`` (integer microseconds since the service started), ``id``, ``hands``, ``pointables``;
* hand: ``id``, ``type`` (``"left"``/``"right"``), ``confidence`` (0..1), ``palmPosition`` (mm),
  ``palmNormal`` (unit, out of the palm), ``direction`` (unit, palm toward fingers), ``palmVelocity`` (mm/s),
  ``palmWidth`` (mm), ``grabStrength`` and ``pinchStrength`` (0..1);
* pointable: ``handId``, ``tool`` (tools are ignored), ``type`` (finger: 0 thumb, 1 index, 2 middle, 3 ring,
  4 pinky), ``extended`` (bool), ``tipPosition`` (mm).

Two spotfree fields extend a frame: ``session`` (integer, one experiment of a log; absent means 1) and, in
simulated frames, ``truth`` = ``{"state": "posture"|"gesture", "label": ..., "person": ..., "pace": ...}``,
ground truth for evaluation that no feature reads (``pace``: the palm's speed relative to the movement's peak, 0 in
a posture). The service's other messages, the version header ``{"version": 6, "serviceVersion": ...}`` and events
``{"event": {...}}``, are not frames.

Inside spotfree a :class:`Hand` is in SI units (m, m/s) in the same Leap frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from spotfree.errors import InputError

FINGERS = ("thumb", "index", "middle", "ring", "pinky")
"""Finger names in the order of the service's finger ``type`` code 0..4."""

MM = 1e-3
"""Metres per millimetre: the service's unit of length."""

POSITION = ("palm_x", "palm_y", "palm_z")
NORMAL = ("normal_x", "normal_y", "normal_z")
DIRECTION = ("dir_x", "dir_y", "dir_z")
VELOCITY = ("vel_x", "vel_y", "vel_z")
EXTENDED = tuple(f"ext_{f}" for f in FINGERS)
TIPS = tuple(f"tip_{f}_{axis}" for f in FINGERS for axis in "xyz")
HAND_CHANNELS = (*POSITION, *NORMAL, *DIRECTION, *VELOCITY, "palm_width", "grab", "pinch", *EXTENDED, *TIPS)
"""Channels of a hand-tracking Recording, all in the Leap frame: palm position (m), palm normal and hand direction
(unit), palm velocity (m/s), palm width (m), grab and pinch strength (0..1), extended flags (1 extended, 0 curled)
and fingertip positions (m)."""

_HAND_VECTORS = {"palmPosition": MM, "palmNormal": 1.0, "direction": 1.0, "palmVelocity": MM}
_HAND_NUMBERS = {"palmWidth": MM, "grabStrength": 1.0, "pinchStrength": 1.0}


@dataclass(frozen=True)
class Hand:
    """One tracked hand in the Leap frame (x right, y up, z toward the user), SI units.

    ``palm_position`` (3,) m; ``palm_normal`` (3,) unit, out of the palm; ``direction`` (3,) unit, palm toward
    fingers; ``palm_velocity`` (3,) m/s; ``palm_width`` m; ``grab`` and ``pinch`` 0..1; ``extended`` (5,) bool and
    ``tips`` (5, 3) m, thumb to pinky (a finger the frame lacks is not extended and has NaN tips).
    """

    palm_position: np.ndarray
    palm_normal: np.ndarray
    direction: np.ndarray
    palm_velocity: np.ndarray
    palm_width: float
    grab: float
    pinch: float
    extended: np.ndarray
    tips: np.ndarray
    side: str = "right"
    confidence: float = 1.0
    id: int = 0

    def vector(self) -> np.ndarray:
        """The hand as one row of :data:`HAND_CHANNELS`."""
        return np.concatenate([
            self.palm_position, self.palm_normal, self.direction, self.palm_velocity,
            [self.palm_width, self.grab, self.pinch], self.extended.astype(float), self.tips.ravel(),
        ])

    @property
    def complete(self) -> bool:
        """True when every number is finite (all five fingers present)."""
        return bool(np.all(np.isfinite(self.vector())))


@dataclass(frozen=True)
class HandFrame:
    """One frame of the tracking service: ``timestamp`` in integer microseconds, the tracked ``hands`` (possibly
    none), the frame ``id``, the ``session`` it belongs to and, for simulated frames, the ground ``truth``."""

    timestamp: int
    hands: tuple[Hand, ...] = ()
    id: int = 0
    session: int = 1
    truth: dict | None = field(default=None, compare=False)

    @property
    def time(self) -> float:
        """Timestamp in seconds."""
        return self.timestamp * 1e-6


def is_frame(message: dict) -> bool:
    """True for a frame, False for the service's version header and events."""
    return "event" not in message and "version" not in message


MAX_TIMESTAMP = 2 ** 53
"""Microseconds: a frame's timestamp is below it (exact as a float; 285 years of a running service)."""


def parse_frame(message: dict, where: str) -> HandFrame:
    """A frame object of the service (already decoded from JSON) as a :class:`HandFrame`.

    ``where`` names the message in errors (``log.jsonl, line 12``). Missing fields and text where a number belongs
    raise an InputError; ``null`` and NaN numbers are kept as NaN (the reader treats such a hand as missing).
    """
    if not isinstance(message, dict):
        raise InputError(f"{where}: a frame must be a JSON object, got {type(message).__name__}")
    timestamp = message.get("timestamp")
    if isinstance(timestamp, bool) or not isinstance(timestamp, (int, float)) or not math.isfinite(timestamp) \
            or not 0 <= timestamp < MAX_TIMESTAMP:
        raise InputError(f"{where}: field 'timestamp' must be the frame time in microseconds (0 to 2^53), got "
                         f"{timestamp!r:.40}")
    hands = _list(message, "hands", where)
    pointables = _list(message, "pointables", where)
    fingers: dict[object, dict[int, dict]] = {}
    for k, pointable in enumerate(pointables):
        if not isinstance(pointable, dict):
            raise InputError(f"{where}: pointables[{k}] must be a JSON object")
        if pointable.get("tool", False):
            continue
        kind = pointable.get("type")
        if isinstance(kind, bool) or not isinstance(kind, int) or not 0 <= kind < len(FINGERS):
            raise InputError(
                f"{where}: pointables[{k}].type is {kind!r}; fingers carry type 0..4 (protocol v6 and later)"
            )
        fingers.setdefault(pointable.get("handId"), {})[kind] = pointable
    parsed = tuple(
        _hand(h, fingers.get(h.get("id") if isinstance(h, dict) else None, {}), f"{where}: hands[{k}]")
        for k, h in enumerate(hands)
    )
    session = message.get("session", 1)
    if isinstance(session, bool) or not isinstance(session, int):
        raise InputError(f"{where}: field 'session' must be a whole number, got {session!r}")
    truth = message.get("truth")
    if truth is not None and not isinstance(truth, dict):
        raise InputError(f"{where}: field 'truth' must be an object with 'state', 'label' and 'person'")
    frame_id = message.get("id", 0)
    return HandFrame(
        timestamp=int(round(timestamp)), hands=parsed, id=frame_id if isinstance(frame_id, int) else 0,
        session=session, truth=truth,
    )


def frame_message(frame: HandFrame) -> dict:
    """A :class:`HandFrame` as the service's JSON object (mm, protocol v6 field names), with ``session`` and
    ``truth`` when the frame has them. Positions are rounded to 1 um, unit vectors and strengths to 1e-6."""
    hands, pointables = [], []
    for hand in frame.hands:
        hands.append({
            "id": hand.id, "type": hand.side, "confidence": _round(hand.confidence, 6),
            "palmPosition": _round(hand.palm_position / MM, 3), "palmNormal": _round(hand.palm_normal, 6),
            "direction": _round(hand.direction, 6), "palmVelocity": _round(hand.palm_velocity / MM, 3),
            "palmWidth": _round(hand.palm_width / MM, 3), "grabStrength": _round(hand.grab, 6),
            "pinchStrength": _round(hand.pinch, 6),
        })
        tips = np.round(hand.tips / MM, 3)
        present = np.all(np.isfinite(tips), axis=1).tolist()
        for kind, (extended, tip, ok) in enumerate(zip(hand.extended.tolist(), tips.tolist(), present)):
            if ok:
                pointables.append({
                    "id": hand.id * 10 + kind, "handId": hand.id, "type": kind, "tool": False,
                    "extended": bool(extended), "tipPosition": tip,
                })
    message = {"id": frame.id, "timestamp": frame.timestamp, "hands": hands, "pointables": pointables}
    if frame.session != 1:
        message["session"] = frame.session
    if frame.truth is not None:
        message["truth"] = frame.truth
    return message


def _round(values, digits: int):
    """JSON numbers: a float or a list of floats rounded to ``digits`` decimals."""
    if np.ndim(values) == 0:
        return round(float(values), digits)
    return np.round(np.asarray(values, dtype=float), digits).tolist()


def _list(message: dict, key: str, where: str) -> list:
    value = message.get(key, [])
    if not isinstance(value, list):
        raise InputError(f"{where}: field {key!r} must be a list, got {type(value).__name__}")
    return value


def _hand(data: object, fingers: dict[int, dict], where: str) -> Hand:
    """One hand object and its fingers (pointables with its ``id`` as ``handId``), converted to SI units."""
    if not isinstance(data, dict):
        raise InputError(f"{where}: a hand must be a JSON object")
    vectors = np.array([_numbers(data, key, where, 3) for key in _HAND_VECTORS], dtype=float)
    vectors *= np.array(list(_HAND_VECTORS.values()))[:, None]
    numbers = np.array([_numbers(data, key, where) for key in _HAND_NUMBERS], dtype=float)
    numbers *= np.array(list(_HAND_NUMBERS.values()))
    extended = np.zeros(len(FINGERS), dtype=bool)
    tips = [[None] * 3] * len(FINGERS)
    for kind, finger in fingers.items():
        where_finger = f"{where}, finger {FINGERS[kind]}"
        flag = finger.get("extended")
        if not isinstance(flag, bool):
            raise InputError(f"{where_finger}: field 'extended' must be true or false, got {flag!r}")
        extended[kind] = flag
        tips[kind] = _numbers(finger, "tipPosition", where_finger, 3)
    side = data.get("type", "right")
    confidence = data.get("confidence", 1.0)
    return Hand(
        palm_position=vectors[0], palm_normal=vectors[1], direction=vectors[2], palm_velocity=vectors[3],
        palm_width=float(numbers[0]), grab=float(numbers[1]), pinch=float(numbers[2]), extended=extended,
        tips=np.array(tips, dtype=float) * MM, side=side if side in ("left", "right") else "right",
        confidence=float(confidence) if type(confidence) in (int, float) else 1.0,
        id=data.get("id", 0) if type(data.get("id", 0)) is int else 0,
    )


_NUMERIC = {int, float, type(None)}


def _numbers(data: dict, key: str, where: str, size: int = 0) -> list | float | None:
    """Field ``key``, checked: a list of ``size`` numbers (one number for 0); null (read as NaN) is allowed."""
    try:
        value = data[key]
    except KeyError:
        raise InputError(
            f"{where}: no field {key!r}; hand logs need the service's protocol v6 fields "
            f"(connect to ws://127.0.0.1:6437/v6.json)"
        ) from None
    if size:
        valid = type(value) is list and len(value) == size and {type(v) for v in value} <= _NUMERIC
    else:
        valid = type(value) in _NUMERIC
    if not valid:
        shape = f"a list of {size} numbers" if size else "a number"
        raise InputError(f"{where}: field {key!r} must be {shape}, got {value!r}")
    return value
