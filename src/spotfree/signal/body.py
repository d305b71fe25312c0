"""Body-frame channels of a raw IMU log that is not a handlebar ride (a phone in a pocket, a watch on a wrist).

Nothing is rotated: the device is carried in an unknown and changing orientation, so the channels are the device
frame's own (Android: x right, y up, z out of the screen) and two that do not depend on the orientation at all,

    acc_norm  = ||(ax, ay, az)||   m/s^2, gravity included
    gyro_norm = ||(gx, gy, gz)||   rad/s

``BODY_CHANNELS`` lists them in the order :func:`body_features` returns them.
"""

from __future__ import annotations

import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS, IMU_CHANNELS, Recording

BODY_CHANNELS = IMU_CHANNELS + ("acc_norm", "gyro_norm")


def body_features(rec: Recording) -> Recording:
    """The :data:`BODY_CHANNELS` of a raw IMU log, on its grid; ``meta['features']`` is ``"body"``."""
    if not rec.has_imu:
        raise InputError(f"{rec.source}: body channels need the raw IMU columns {', '.join(IMU_CHANNELS)}; "
                         f"the log has {', '.join(rec.names) or 'none'}")
    channels = {c: rec.channels[c] for c in IMU_CHANNELS}
    channels["acc_norm"] = np.linalg.norm(rec.array(ACC_CHANNELS), axis=1)
    channels["gyro_norm"] = np.linalg.norm(rec.array(GYRO_CHANNELS), axis=1)
    out = rec.with_channels(channels)
    out.meta.update(features="body")
    return out
