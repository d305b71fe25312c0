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


class SpeedAidedPitch:
    """The filter of the module docstring, one sample at a time (plain floats: a few microseconds per sample)."""

    def __init__(self, rate: float, parameters: SpeedAidedParameters | None = None):
        self.rate = float(rate)
        self.parameters = parameters or SpeedAidedParameters()
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next sample starts a new segment."""
        self._x: tuple[float, float, float] | None = None
        self._P = (0.0,) * 6  # p00, p01, p02, p11, p12, p22 of the symmetric covariance
        self._has_speed = False

    def update(self, acc, gyr, roll: float, pitch_ref: float, speed: float = math.nan) -> tuple[float, float]:
        """``(a_t, theta)`` for one sample: ``acc`` (m/s^2) and ``gyr`` (rad/s) on vehicle axes, ``roll`` and
        ``pitch_ref`` (rad) from the attitude filter, ``speed`` (m/s) on a GPS fix, NaN otherwise."""
        par, dt = self.parameters, 1.0 / self.rate
        ax, ay, az = float(acc[0]), float(acc[1]), float(acc[2])
        q, r = float(gyr[1]), float(gyr[2])
        sr, cr = math.sin(roll), math.cos(roll)
        across = sr * ay + cr * az
        if self._x is None:
            self._x = (float(pitch_ref), 0.0, 0.0)
            self._P = (par.initial_pitch**2, 0.0, 0.0, par.initial_bias**2, 0.0, par.initial_speed**2)
        theta, bias, v = self._x
        st, ct = math.sin(theta), math.cos(theta)
        a_t = ct * ax + st * across
        s = (-st * ax + ct * across) * dt  # d v / d theta over one step
        p00, p01, p02, p11, p12, p22 = self._P
        self._P = (  # F P F^T + Q, F = [[1, -dt, 0], [0, 1, 0], [s, 0, 1]]
            p00 - 2 * dt * p01 + dt * dt * p11 + par.pitch_noise**2 * dt,
            p01 - dt * p11,
            s * (p00 - dt * p01) + p02 - dt * p12,
            p11 + par.bias_noise**2 * dt,
            s * p01 + p12,
            s * s * p00 + 2 * s * p02 + p22 + (par.accel_noise * dt) ** 2,
        )
        self._x = (theta + (q * cr - r * sr - bias) * dt, bias, v + a_t * dt)
        self._measure(0, float(pitch_ref) - self._x[0], par.reference_noise**2 / dt)
        if speed == speed:  # a GPS fix (not NaN)
            if not self._has_speed:
                p00, p01, _, p11, _, _ = self._P
                self._x, self._P = (self._x[0], self._x[1], float(speed)), (p00, p01, 0.0, p11, 0.0, 0.0)
                self._has_speed = True
            self._measure(2, float(speed) - self._x[2], par.speed_noise**2)
        theta = self._x[0]
        return math.cos(theta) * ax + math.sin(theta) * across, theta

    def _measure(self, k: int, innovation: float, variance: float) -> None:
        """Kalman update for a direct measurement of state ``k`` (0 pitch, 2 speed): ``K = P e_k / (P_kk + var)``,
        ``x += K innovation``, ``P -= K (P e_k)^T``."""
        p00, p01, p02, p11, p12, p22 = self._P
        c0, c1, c2 = (p00, p01, p02) if k == 0 else (p02, p12, p22)
        inv = 1.0 / ((c0 if k == 0 else c2) + variance)
        x0, x1, x2 = self._x
        self._x = (x0 + c0 * inv * innovation, x1 + c1 * inv * innovation, x2 + c2 * inv * innovation)
        self._P = (p00 - c0 * c0 * inv, p01 - c0 * c1 * inv, p02 - c0 * c2 * inv,
                   p11 - c1 * c1 * inv, p12 - c1 * c2 * inv, p22 - c2 * c2 * inv)


def speed_aided_acceleration(acc: np.ndarray, gyr: np.ndarray, roll: np.ndarray, pitch_ref: np.ndarray,
                             speed: np.ndarray | None, rate: float,
                             parameters: SpeedAidedParameters | None = None) -> np.ndarray:
    """``(n, 2)`` columns ``a_t`` (m/s^2) and ``theta`` (rad) of one gap-free segment; ``speed`` (m/s) NaN between
    fixes, or ``None`` without GPS. Runs :class:`SpeedAidedPitch` sample by sample, so batch equals streaming."""
    filt = SpeedAidedPitch(rate, parameters)
    n = len(acc)
    speed = np.full(n, np.nan) if speed is None else np.asarray(speed, dtype=float)
    out = np.empty((n, 2))
    for k in range(n):
        out[k] = filt.update(acc[k], gyr[k], float(roll[k]), float(pitch_ref[k]), float(speed[k]))
    return out
