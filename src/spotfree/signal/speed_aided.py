"""Speed-aided pitch: the vehicle's longitudinal acceleration from the IMU and the GPS speed.

Why. A self-balancing vehicle leans so that the specific force stays close to its body z axis: in a steady
braking the handlebar accelerometer sees almost no longitudinal force, so any accelerometer-referenced attitude
filter drifts back to "no lean" and the gravity-free acceleration ``acc_x`` decays to zero while the vehicle is
still braking. The GPS speed (1 Hz) observes what the accelerometer cannot: with the pitch off by ``d theta`` the
integrated acceleration runs away from the speed at ``g d theta`` (1 deg: 0.17 m/s per second).

A three-state extended Kalman filter, state ``x = (theta, b, v)``: pitch (rad, positive nose down, the convention
of :mod:`spotfree.signal.frame`), pitch-rate bias ``b`` (rad/s) and forward speed ``v`` (m/s). Per sample, with
vehicle-axis specific force ``(a_x, a_y, a_z)`` (m/s^2), body rates ``(p, q, r)`` (rad/s) and the attitude
filter's roll ``phi``::

    c = sin(phi) a_y + cos(phi) a_z
    a_t = cos(theta) a_x + sin(theta) c                  forward level acceleration (m/s^2), the output
    theta <- theta + (q cos(phi) - r sin(phi) - b) T     Euler pitch rate
    v     <- v + a_t T
    F = [[1, -T, 0], [0, 1, 0], [(-sin(theta) a_x + cos(theta) c) T, 0, 1]]
    P <- F P F^T + diag(s_theta^2 T, s_b^2 T, (s_a T)^2)

then two measurements: the attitude filter's pitch ``theta_ref`` on every sample, variance ``s_ref^2 / T`` (a weak
anchor, about ``s_ref`` over one second: without GPS the filter follows the attitude filter's long-term pitch), and
each GPS fix ``v = speed``, variance ``s_v^2`` (the GPS speed has no sign: riding backwards, at walking pace on
such a vehicle, is taken as forward). The speed starts unknown and is set by the first fix. ``a_t`` is evaluated
with the updated pitch. The GPS latency (0.2 s on a phone) is ignored: the speed corrects drifts over seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from spotfree.signal.recursions import (
    SPEED_AIDED_PARAMETERS, SPEED_AIDED_STATE, speed_aided_run, speed_aided_update,
)


@dataclass(frozen=True)
class SpeedAidedParameters:
    """Noise densities of :class:`SpeedAidedPitch` (SI units)."""

    pitch_noise: float = 0.003
    """``s_theta``, rad/sqrt(s): gyro angle random walk plus model error."""
    bias_noise: float = 2e-5
    """``s_b``, rad/s/sqrt(s): gyro bias instability."""
    accel_noise: float = 1.0
    """``s_a``, m/s^2 per sample: handlebar vibration and accelerometer noise in ``a_t``."""
    reference_noise: float = float(np.deg2rad(8.0))
    """``s_ref``, rad over one second: trust in the attitude filter's pitch."""
    speed_noise: float = 0.15
    """``s_v``, m/s: GPS speed noise."""
    initial_pitch: float = float(np.deg2rad(5.0))
    """rad: initial pitch standard deviation around the attitude filter's first pitch."""
    initial_bias: float = 0.01
    """rad/s"""
    initial_speed: float = 10.0
    """m/s: standard deviation of the speed before the first fix (started at 0, then set by the fix)."""


def speed_aided_parameters(rate: float, parameters: SpeedAidedParameters | None = None) -> np.ndarray:
    """The :data:`~spotfree.signal.recursions.SPEED_AIDED_PARAMETERS` for ``rate`` (Hz) and ``parameters`` (defaults
    when None), one record in an array (numba takes a one-element array faster than a record)."""
    values = vars(parameters or SpeedAidedParameters())
    return np.array([(float(rate), *(float(values[name]) for name in SPEED_AIDED_PARAMETERS.names[1:]))],
                    dtype=SPEED_AIDED_PARAMETERS)


class SpeedAidedPitch:
    """The filter of the module docstring, one sample at a time (compiled:
    :func:`~spotfree.signal.recursions.speed_aided_step`)."""

    def __init__(self, rate: float, parameters: SpeedAidedParameters | None = None):
        self.rate = float(rate)
        self.parameters = parameters or SpeedAidedParameters()
        self._packed = speed_aided_parameters(self.rate, self.parameters)
        self._state = np.zeros(1, SPEED_AIDED_STATE)
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next sample starts a new segment."""
        self._start = True

    def update(self, acc, gyr, roll: float, pitch_ref: float, speed: float = math.nan) -> tuple[float, float]:
        """``(a_t, theta)`` for one sample: ``acc`` (m/s^2) and ``gyr`` (rad/s) on vehicle axes, ``roll`` and
        ``pitch_ref`` (rad) from the attitude filter, ``speed`` (m/s) on a GPS fix, NaN otherwise."""
        out = speed_aided_update(self._packed, self._state, self._start, float(acc[0]), float(acc[1]), float(acc[2]),
                               float(gyr[1]), float(gyr[2]), float(roll), float(pitch_ref), float(speed))
        self._start = False
        return out


def speed_aided_acceleration(acc: np.ndarray, gyr: np.ndarray, roll: np.ndarray, pitch_ref: np.ndarray,
                             speed: np.ndarray | None, rate: float,
                             parameters: SpeedAidedParameters | None = None) -> np.ndarray:
    """``(n, 3)`` columns ``a_t`` (m/s^2), ``theta`` (rad) and the speed state ``v`` (m/s) of one gap-free segment;
    ``speed`` (m/s) NaN between fixes, or ``None`` without GPS. Runs
    :func:`~spotfree.signal.recursions.speed_aided_step` sample by sample, so batch equals streaming."""
    n = len(acc)
    speed = np.full(n, np.nan) if speed is None else np.asarray(speed, dtype=float)
    out = np.empty((n, 3))
    acc, gyr, roll, pitch_ref, speed = (np.ascontiguousarray(v, dtype=float)
                                        for v in (acc, gyr, roll, pitch_ref, speed))
    speed_aided_run(speed_aided_parameters(rate, parameters), np.zeros(1, SPEED_AIDED_STATE), acc.reshape(-1, 3),
                     gyr.reshape(-1, 3), roll, pitch_ref, speed, out)
    return out
