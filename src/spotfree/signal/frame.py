"""Frames: device (phone/tablet) to vehicle, and attitude rotations.

Device frame (Android): x right, y up along the screen, z out of the screen.
Vehicle frame: x forward, y left, z up.

The tablet lies on top of the handlebar, screen up towards the rider, its top edge pointing forward. In that
nominal mount the device axes map to vehicle axes as

    vehicle x = device y,  vehicle y = -device x,  vehicle z = device z        (``MOUNT``)

Any further mounting misalignment (a few degrees) and the handlebar's own roll and pitch are what the attitude
filter estimates. Attitude angles follow the paper's eq. (1) on vehicle-axis measurements:

    roll  phi   = atan2(a_y, a_z)                    right-hand about vehicle x (forward)
    pitch theta = atan2(-a_x, sqrt(a_y^2 + a_z^2))   right-hand about vehicle y (left): positive is nose down

and the body-to-level rotation is ``R = R_y(theta) R_x(phi)``, so at rest ``a_body = R^T [0, 0, g]``.
"""

from __future__ import annotations

import numpy as np

from spotfree.units import GRAVITY

MOUNT = np.array([[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
"""Nominal device-to-vehicle axis map: ``v_vehicle = MOUNT @ v_device``."""


def device_to_vehicle_axes(v: np.ndarray) -> np.ndarray:
    """Re-express ``(n, 3)`` device-frame vectors on the nominal vehicle axes (x forward, y left, z up)."""
    return np.asarray(v, dtype=float) @ MOUNT.T


def vehicle_to_device_axes(v: np.ndarray) -> np.ndarray:
    """Inverse of :func:`device_to_vehicle_axes`: ``(n, 3)`` vehicle-axis vectors in the device frame."""
    return np.asarray(v, dtype=float) @ MOUNT


def accel_roll_pitch(acc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Roll and pitch (rad) of the paper's eq. (1) from ``(n, 3)`` specific force on vehicle axes (m/s^2)."""
    acc = np.asarray(acc, dtype=float)
    roll = np.arctan2(acc[:, 1], acc[:, 2])
    pitch = np.arctan2(-acc[:, 0], np.hypot(acc[:, 1], acc[:, 2]))
    return roll, pitch


def body_to_level(roll: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(n, 3, 3)`` ``R = R_y(pitch) R_x(roll)`` taking vehicle-axis vectors to the level frame."""
    roll = np.atleast_1d(np.asarray(roll, dtype=float))
    pitch = np.atleast_1d(np.asarray(pitch, dtype=float))
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    zero = np.zeros_like(roll)
    return np.stack(
        [
            np.stack([cp, sp * sr, sp * cr], axis=-1),
            np.stack([zero, cr, -sr], axis=-1),
            np.stack([-sp, cp * sr, cp * cr], axis=-1),
        ],
        axis=-2,
    )


def gravity_free_level(acc: np.ndarray, roll: np.ndarray, pitch: np.ndarray, g: float = GRAVITY) -> np.ndarray:
    """Specific force ``(n, 3)`` on vehicle axes rotated to the level frame, gravity removed (m/s^2).

    ``a_level = R_y(pitch) R_x(roll) a_body - [0, 0, g]``: x forward (horizontal), y left, z up.
    """
    rot = body_to_level(roll, pitch)
    level = np.einsum("nij,nj->ni", rot, np.asarray(acc, dtype=float))
    level[:, 2] -= g
    return level


def gravity_direction(roll: np.ndarray, pitch: np.ndarray) -> np.ndarray:
    """Unit vertical ``(n, 3)`` (up, opposite to gravity) in vehicle-axis coordinates for roll and pitch (rad).

    ``u = R^T [0, 0, 1] = [-sin(pitch), sin(roll) cos(pitch), cos(roll) cos(pitch)]``; :func:`accel_roll_pitch`
    of ``u`` returns ``(roll, pitch)`` for ``|pitch| < pi/2``.
    """
    roll = np.asarray(roll, dtype=float)
    pitch = np.asarray(pitch, dtype=float)
    cp = np.cos(pitch)
    return np.stack([-np.sin(pitch), np.sin(roll) * cp, np.cos(roll) * cp], axis=-1)
