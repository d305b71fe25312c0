"""Body-frame channels of a raw IMU log that is not a handlebar ride (a phone in a pocket, a watch on a wrist).

Nothing is rotated: the device is carried in an unknown and changing orientation, so the channels are the device
frame's own (Android: x right, y up, z out of the screen) and three that do not depend on the orientation at all,

    acc_norm      = ||a||                  m/s^2, gravity included          a = (ax, ay, az)
    gyro_norm     = ||w||                  rad/s                            w = (gx, gy, gz)
    gyro_vertical = |h * (w . g / ||g||)|  rad/s, g the low-passed a, h a low-pass

``gyro_vertical`` is the rate of turning about the vertical, to either side: ``g``, the acceleration through a causal
first-order low-pass of time constant :data:`GRAVITY_SECONDS` (:func:`~spotfree.signal.butterworth.lowpass`), points
along gravity once the device's own accelerations average out, so ``w . g / ||g||`` is the component of the rotation
rate about the vertical, whatever the device's orientation. A person turning round turns about the vertical; an
arm's swing or a step's sway rotates the device mostly about horizontal axes, which the norm mixes in. The rotation
rate about the vertical is the usual signal of turns in gait monitoring (El-Gohary et al., "Continuous monitoring of
turning in patients with movement disability", Sensors 14(1), 2014).

Walking also rotates the device to and fro about the vertical, once per stride (the arm swings back and forth, the
pelvis twists), so the signed rate ``w . g / ||g||`` is passed through ``h``, a second-order Butterworth low-pass at
:data:`TURN_CUTOFF` Hz, before its magnitude is taken: the to-and-fro of a stride averages out (at 1 Hz the filter
keeps about a quarter of the amplitude), a turn, a second or more one way, passes. Rectified first, the stride's
rotation would add to the channel as much as a slow turn does. The low-pass delays the channel by about
``sqrt(2) / (2 pi TURN_CUTOFF)`` s (its group delay at low frequency). Both filters run over each gap-free stretch
alone and are causal, so that a window's value does not depend on the samples after it (live labels).

A log with an accelerometer and no gyroscope (many activity recordings hold only acceleration) gives the
acceleration's channels alone, ``ax ay az acc_norm`` (:data:`ACC_BODY_CHANNELS`).

``BODY_CHANNELS`` lists them in the order :func:`body_features` returns them.
"""

from __future__ import annotations

import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS, IMU_CHANNELS, Recording
from spotfree.signal.butterworth import butter_lowpass, lowpass

BODY_CHANNELS = IMU_CHANNELS + ("acc_norm", "gyro_norm", "gyro_vertical")
ACC_BODY_CHANNELS = ACC_CHANNELS + ("acc_norm",)
"""The body channels of a log without a gyroscope."""
GRAVITY_SECONDS = 1.0
"""Time constant of the low-pass that estimates gravity's direction for ``gyro_vertical``, s (cut-off
``1 / (2 pi GRAVITY_SECONDS)`` Hz): long against a step or an arm's swing, short against a change of how the device
is held."""
TURN_CUTOFF = 0.5
"""Cut-off of the low-pass ``h`` of the signed rotation rate about the vertical, Hz: half the stride frequency of
walking (a stride, two steps, takes about a second), so that the to-and-fro rotation of each stride averages out
while a turn of the body passes (module docstring)."""


def body_features(rec: Recording) -> Recording:
    """The :data:`BODY_CHANNELS` of a raw IMU log, or the :data:`ACC_BODY_CHANNELS` of a log without a gyroscope,
    on its grid; ``meta['features']`` is ``"body"``."""
    if not rec.has_accelerometer:
        raise InputError(f"{rec.source}: body channels need the accelerometer's columns {', '.join(ACC_CHANNELS)} "
                         f"(m/s^2, gravity included; with gx gy gz in rad/s when there is a gyroscope); the log has "
                         f"{', '.join(rec.names) or 'none'}")
    channels = {c: rec.channels[c] for c in (IMU_CHANNELS if rec.has_imu else ACC_CHANNELS)}
    channels["acc_norm"] = np.linalg.norm(rec.array(ACC_CHANNELS), axis=1)
    if rec.has_imu:
        channels["gyro_norm"] = np.linalg.norm(rec.array(GYRO_CHANNELS), axis=1)
        channels["gyro_vertical"] = vertical_rotation(rec)
    out = rec.with_channels(channels)
    out.meta.update(features="body")
    return out


def vertical_rotation(rec: Recording) -> np.ndarray:
    """``|h * (w . g / ||g||)|`` per sample, rad/s (module docstring); NaN outside the gap-free stretches. Where the
    low-passed acceleration vanishes (free fall) its norm is taken as at least 1e-9 m/s^2, so that the signed rate
    is bounded by ``||w||`` and the channel by ``||w||``'s largest value so far times the gain ``sum |h|`` of the
    low-pass."""
    acc, gyro = rec.array(ACC_CHANNELS), rec.array(GYRO_CHANNELS)
    gravity = butter_lowpass(rec.rate, cutoff=1.0 / (2 * np.pi * GRAVITY_SECONDS), order=1)
    turn = butter_lowpass(rec.rate, cutoff=TURN_CUTOFF, order=2)
    out = np.full(len(rec), np.nan)
    for start, stop in rec.segments():
        g = lowpass(acc[start:stop], gravity)
        signed = np.einsum("ij,ij->i", gyro[start:stop], g) / np.maximum(np.linalg.norm(g, axis=1), 1e-9)
        out[start:stop] = np.abs(lowpass(signed[:, None], turn)[:, 0])
    return out
