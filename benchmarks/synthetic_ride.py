"""A synthetic ride-like motion with a known vertical, for orientation filters (not BROAD; no real data).

Used by ``tests/test_signal_orientation.py`` (seeds 1-4) and, as a guard against regressions on ride-like motion,
by ``orientation_leave_trials_out.py`` (seeds 10 and 11, which the tests do not use).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from spotfree.signal.frame import gravity_direction
from spotfree.units import GRAVITY


def synthetic_ride(seed: int, rate: float = 20.0, seconds: float = 240.0, bias=(0.008, -0.006, 0.004)):
    """Body-frame IMU of a tilting, turning body with braking-like linear accelerations; not BROAD.

    Attitude: yaw turns plus roll/pitch swings (up to ~25 deg, periods 3-13 s); world-frame linear acceleration:
    +-3 m/s^2 pulses of 1.5-3 s along the heading plus 1 m/s^2 lateral sway; gyro bias ``bias`` (rad/s) from
    the first sample (no rest to learn it from) and white noise on both sensors. Returns acc (m/s^2),
    gyr (rad/s) as the interval means the filters assume, and the true unit vertical, all ``(n, 3)``.
    """
    rng = np.random.default_rng(seed)
    sub = 10  # simulate at 10x the rate and average, as a sensor's anti-aliasing does
    dt = 1.0 / (rate * sub)
    t = np.arange(int(seconds * rate * sub) + 1) * dt
    phase = rng.uniform(0, 2 * np.pi, 6)
    yaw = 0.6 * np.sin(2 * np.pi * t / 40 + phase[0]) + 0.05 * t
    roll = 0.25 * np.sin(2 * np.pi * t / 7 + phase[1]) + 0.1 * np.sin(2 * np.pi * t / 3.1 + phase[2])
    pitch = 0.2 * np.sin(2 * np.pi * t / 13 + phase[3]) + 0.08 * np.sin(2 * np.pi * t / 2.3 + phase[4])
    rot = Rotation.from_euler("ZYX", np.column_stack([yaw, pitch, roll]))
    omega = (rot[:-1].inv() * rot[1:]).as_rotvec() / dt  # body-frame mean rate over each step
    pulses = np.zeros_like(t)
    for start in np.arange(5.0, seconds - 5.0, 9.0):
        length = rng.uniform(1.5, 3.0)
        pulses += rng.choice([-3.0, 3.0]) * np.sin(np.pi * np.clip((t - start) / length, 0, 1)) ** 2
    lateral = 1.0 * np.sin(2 * np.pi * t / 4.7 + phase[5])
    lin_world = np.column_stack([pulses * np.cos(yaw) - lateral * np.sin(yaw), pulses * np.sin(yaw) + lateral * np.cos(yaw), 0 * t])
    acc_fine = rot.inv().apply(lin_world + [0.0, 0.0, GRAVITY])[1:]
    up_fine = rot.inv().apply([0.0, 0.0, 1.0])

    def mean(v):
        return v.reshape(-1, sub, 3).mean(axis=1)

    n = len(omega) // sub
    acc = mean(acc_fine[: n * sub]) + rng.normal(0, 0.05, (n, 3))
    gyr = mean(omega[: n * sub]) + np.asarray(bias) + rng.normal(0, 0.003, (n, 3))
    return acc, gyr, up_fine[sub::sub][:n]


def inclination_rmse_deg(roll_pitch: np.ndarray, up: np.ndarray, skip: int = 0) -> float:
    est = gravity_direction(roll_pitch[skip:, 0], roll_pitch[skip:, 1])
    cos = np.clip(np.sum(est * up[skip:], axis=1), -1.0, 1.0)
    return float(np.degrees(np.sqrt(np.mean(np.arccos(cos) ** 2))))
