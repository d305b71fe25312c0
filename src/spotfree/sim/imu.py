"""The tablet's IMU: from the handlebar's true motion to what Android reports.

Chain, per experiment (all vectors on the axes named, SI units):

1. Mounting. The tablet lies on the handlebar screen up, top edge forward (:data:`spotfree.signal.frame.MOUNT`),
   turned by a small random misalignment ``R_m = R_z(yaw) R_y(pitch) R_x(roll)`` (a few degrees):
   ``v_device = MOUNT^T R_m^T v_handlebar``.
2. The sensor's own low-pass (a 2nd-order Butterworth at ``rate / 2``, as a phone sets its digital filter from the
   output rate). Vibration above it (the handlebar column's 14-22 Hz mode, cobblestone setts) is attenuated, not
   removed, and aliases into the output band as on a real phone.
3. Sampling at ``k / rate + j_k``: ``j_k`` is a few milliseconds of timestamp jitter. The output's time column keeps
   the nominal grid ``k / rate``, as an app that resamples onto a fixed rate would.
4. Errors: white noise ``sigma = N sqrt(rate / 2)`` from the datasheet noise density ``N``; a constant accelerometer
   bias per axis; a gyro bias per axis that starts at a residual offset and random-walks; quantisation to the
   16-bit LSB of the range (+-8 g, +-1000 deg/s) and saturation at full scale.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfilt, sosfilt_zi

from spotfree.signal.frame import vehicle_to_device_axes
from spotfree.units import GRAVITY


SETTLE = 0.1
"""s: the anti-alias filter starts settled on the median of the first ``SETTLE`` seconds of the true motion (the
sensor ran before the log began). Settled on the first internal sample alone, it held that sample's numerical
edge error (the handlebar's pitch acceleration from second differences at the first instant) as if it had lasted
forever, and the first output sample read up to 0.8 m/s^2 of forward force on a vehicle at rest."""


@dataclass(frozen=True)
class ImuSpec:
    """Sensor parameters (SI units). Defaults follow a Bosch BMI160-class phone IMU; see docs/simulator.md."""

    acc_noise_density: float = 180e-6 * GRAVITY
    """m/s^2/sqrt(Hz) (180 ug/sqrt(Hz))."""
    gyro_noise_density: float = float(np.deg2rad(0.008))
    """rad/s/sqrt(Hz) (0.008 deg/s/sqrt(Hz))."""
    acc_bias: float = 0.010 * GRAVITY
    """1-sigma residual accelerometer offset per axis after factory trim, m/s^2."""
    acc_bias_max: float = 0.040 * GRAVITY
    """Offsets are clipped to the datasheet's typical zero-g offset, m/s^2."""
    gyro_bias: float = float(np.deg2rad(0.3))
    """1-sigma residual gyro offset per axis after the phone's runtime calibration, rad/s."""
    gyro_bias_walk: float = float(np.deg2rad(0.003))
    """Gyro bias random walk, rad/s per sqrt(s)."""
    acc_range: float = 8.0 * GRAVITY
    """Full scale, m/s^2."""
    gyro_range: float = float(np.deg2rad(1000.0))
    """Full scale, rad/s."""
    bits: int = 16
    jitter: float = 0.002
    """1-sigma sampling-instant jitter, s (clipped at 3 sigma)."""
    misalignment: float = float(np.deg2rad(2.0))
    """1-sigma mounting misalignment per axis, rad (clipped at :attr:`misalignment_max`)."""
    misalignment_max: float = float(np.deg2rad(5.0))


def rotation_xyz(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """``R_z(yaw) R_y(pitch) R_x(roll)`` (3, 3); pitch positive nose down (right-hand about y left)."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


@dataclass
class ImuReading:
    """Device-frame samples (Android axes: x right, y up the screen, z out of it) and the errors drawn."""

    acc: np.ndarray
    """(n, 3) specific force, m/s^2."""
    gyro: np.ndarray
    """(n, 3) angular rate, rad/s."""
    misalignment: np.ndarray
    """(roll, pitch, yaw) of the tablet on the handlebar, rad."""
    acc_bias: np.ndarray
    """(3,) device axes, m/s^2."""
    gyro_bias: np.ndarray
    """(3,) device axes at the first sample, rad/s."""


def _quantise(x: np.ndarray, full_scale: float, bits: int) -> np.ndarray:
    lsb = 2.0 * full_scale / 2**bits
    return np.clip(np.round(x / lsb) * lsb, -full_scale, full_scale - lsb)


def read_imu(
    time: np.ndarray,
    specific_force: np.ndarray,
    angular_rate: np.ndarray,
    rate: float,
    n_out: int,
    rng: np.random.Generator,
    spec: ImuSpec = ImuSpec(),
) -> ImuReading:
    """Sample the handlebar's true ``specific_force`` (m/s^2) and ``angular_rate`` (rad/s), (n, 3) on handlebar axes
    at the internal ``time`` grid, as the tablet would: ``n_out`` samples at ``rate`` Hz (see the module docstring).
    """
    misalignment = np.clip(rng.normal(0.0, spec.misalignment, 3), -spec.misalignment_max, spec.misalignment_max)
    to_device = vehicle_to_device_axes(rotation_xyz(*misalignment)).T  # MOUNT^T R_m^T
    fs = 1.0 / (time[1] - time[0])
    sos = butter(2, 0.5 * rate, fs=fs, output="sos")
    raw = np.column_stack([specific_force @ to_device.T, angular_rate @ to_device.T])
    settled = np.median(raw[: max(1, int(round(SETTLE * fs)))], axis=0)
    filtered = sosfilt(sos, raw, axis=0, zi=sosfilt_zi(sos)[:, :, None] * settled)[0]
    jitter = np.clip(rng.normal(0.0, spec.jitter, n_out), -3.0 * spec.jitter, 3.0 * spec.jitter)
    instants = np.clip(np.arange(n_out) / rate + jitter, time[0], time[-1])
    sampled = np.column_stack([np.interp(instants, time, filtered[:, k]) for k in range(6)])

    acc_bias = np.clip(rng.normal(0.0, spec.acc_bias, 3), -spec.acc_bias_max, spec.acc_bias_max)
    gyro_bias = rng.normal(0.0, spec.gyro_bias, 3)
    walk = spec.gyro_bias_walk * np.sqrt(1.0 / rate) * np.cumsum(rng.standard_normal((n_out, 3)), axis=0)
    band = np.sqrt(0.5 * rate)
    acc = sampled[:, :3] + acc_bias + spec.acc_noise_density * band * rng.standard_normal((n_out, 3))
    gyro = sampled[:, 3:] + gyro_bias + walk + spec.gyro_noise_density * band * rng.standard_normal((n_out, 3))
    return ImuReading(
        acc=_quantise(acc, spec.acc_range, spec.bits),
        gyro=_quantise(gyro, spec.gyro_range, spec.bits),
        misalignment=misalignment,
        acc_bias=acc_bias,
        gyro_bias=gyro_bias,
    )
