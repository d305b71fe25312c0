"""Physical and temporal limits of what a phone can record, shared by every input path: the service's HTTP,
WebSocket and Sensor Logger push (:mod:`spotfree.ride.validation`) and the command line's readers
(:func:`check_recording`). A value outside them is a unit mistake, a corrupt file or a forged message, never a
ride: it is refused with one line naming the field and the fix, not clipped or converted.

Limits (SI units; device frame for the motion sensors):

* acceleration ``|a| <= MAX_ACCELERATION`` per axis (16 g, the widest range of phone IMUs), rotation rate
  ``|w| <= MAX_ROTATION`` per axis (2000 deg/s);
* latitude within [-90, 90] and longitude within [-180, 180] degrees, GPS speed within [0, MAX_SPEED] m/s;
* times in seconds since the ride started: at most :data:`MAX_RIDE_SECONDS`, consecutive samples at most
  :data:`MAX_STEP` s apart; a batch of 3 or more samples has a median step of at most ``1 / MIN_RATE`` s (a
  larger one means milliseconds) and a mean rate of at most :data:`MAX_RATE` Hz.
"""

from __future__ import annotations

import numpy as np

from spotfree.errors import InputError
from spotfree.units import GRAVITY

MAX_ACCELERATION = 16 * GRAVITY
"""m/s^2 per axis."""
MAX_ROTATION = float(np.deg2rad(2000.0))
"""rad/s per axis."""
MAX_SPEED = 100.0
"""m/s; a GPS speed above it is a receiver fault."""
MAX_RATE = 1000.0
"""Hz, highest mean sampling rate of a batch."""
MIN_RATE = 2.0
"""Hz, lowest plausible median sampling rate of a phone's motion sensors."""
MAX_RIDE_SECONDS = 2 * 86400.0
"""Seconds since the ride started of its last sample at most: a longer ride is two rides."""
MAX_STEP = 3600.0
"""Seconds between consecutive samples of one ride at most: a longer pause starts a new ride."""
DEGREE_BOUNDS = {"lat": 90.0, "lon": 180.0}
"""Absolute bound of each GPS coordinate, degrees."""


def check_recording(rec) -> None:
    """Refuse (InputError, one line naming the source, the channel and the first bad sample) a recording whose
    accelerations (``ax ay az``, m/s^2), rotation rates (``gx gy gz``, rad/s), GPS coordinates (``lat lon``,
    degrees) or ``speed`` (m/s) leave the limits above; NaN is a gap, not a refusal."""
    bounds = {**{c: (MAX_ACCELERATION, "m/s^2") for c in ("ax", "ay", "az")},
              **{c: (MAX_ROTATION, "rad/s") for c in ("gx", "gy", "gz")},
              **{c: (b, "degrees") for c, b in DEGREE_BOUNDS.items()}}
    for name, values in rec.channels.items():
        if name not in bounds and name != "speed":
            continue
        column = np.asarray(values, dtype=float)
        if name == "speed":
            bad = np.isinf(column) | (column < 0) | (column > MAX_SPEED)
            fix = f"m/s within [0, {MAX_SPEED:g}]"
        else:
            bound, unit = bounds[name]
            bad = np.isinf(column) | (np.abs(column) > bound)
            fix = f"{unit} within +-{bound:.4g}"
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise InputError(f"{rec.source}: channel {name!r}, sample {k + 1} (t = {rec.time[k]:.3f} s): "
                             f"{float(column[k]):g} is outside what a phone records; give {fix}")
