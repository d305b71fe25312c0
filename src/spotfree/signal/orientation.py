"""Roll and pitch from an IMU: the orientation backends ``paper``, ``default`` and ``vqf``.

Every backend takes, per sample, the specific force ``acc`` (m/s^2, gravity included, +g up at rest) and the
angular rate ``gyr`` (rad/s) in one body frame -- the vehicle axes (x forward, y left, z up) in spotfree, or an
IMU's own axes -- and returns roll and pitch (rad) in the convention of the paper's eq. (1): the body's vertical
(unit "up" vector in body coordinates) is ``[-sin(pitch), sin(roll) cos(pitch), cos(roll) cos(pitch)]``.

Each backend has a streaming form (``update(acc, gyr) -> (roll, pitch)``, ``reset()``) and a batch form
(``run(acc, gyr) -> (n, 2)``, from a fresh state) that agree to 1e-12. All are causal.

``paper``
    The paper's PI complementary filter (:mod:`spotfree.signal.complementary`) with Kp = 7.5924, Ki = 20.7015,
    discretised at the recording's rate, run on roll and pitch separately. The gyro enters as the body rates
    about the roll axis (x) and the pitch axis (y): the paper integrates the gyroscope readings, and eq. (3) is
    linear. The Euler-angle rates (``roll' = p + tan(pitch) (q sin(roll) + r cos(roll))``,
    ``pitch' = q cos(roll) - r sin(roll)``) would need the filter's own output (a nonlinear filter, not eq. 3)
    or the accelerometer angles (corrupted by the very accelerations the gyro path is there to ignore); the
    difference is second order in the angles, small for a handlebar, and large rotations are the default
    backend's business. The accelerometer roll is unwrapped before filtering and the output wrapped back to
    [-pi, pi).
``default``
    :class:`GravityPI`, a Mahony-type PI filter on the gravity direction with gain scheduling, an accelerometer
    low-pass in the gyro-propagated frame whose length follows how much the phone is shaken, a bounded correction
    rate and rest-phase gyro-bias estimation. Valid for any rotation; gains chosen on BROAD at 20 Hz and scored
    by leave-trials-out.
``vqf``
    The ``vqf`` package (Laidig and Seel 2023), 6D quaternion, default parameters.
"""

from __future__ import annotations

import math

import numpy as np

from spotfree.errors import InputError
from spotfree.signal.complementary import (
    PAPER_KI, PAPER_KP, pi_complementary, pi_complementary_design, stream_coefficients,
)
from spotfree.signal.frame import accel_roll_pitch
from spotfree.signal.recursions import (
    GRAVITY_PI_PARAMETERS, GRAVITY_PI_STATE, PAPER_PARAMETERS, PAPER_STATE, gravity_pi_run, gravity_pi_update,
    paper_attitude_update,
)
from spotfree.units import GRAVITY

ORIENTATIONS = ("default", "paper", "vqf")
"""Valid names of the orientation backends."""

TWO_PI = 2.0 * math.pi


def _wrap(angle):
    """Angle(s) wrapped to [-pi, pi)."""
    return (angle + math.pi) % TWO_PI - math.pi


class PaperAttitude:
    """The paper's filter: eq. (1) on the accelerometer, eq. (3) per angle with body rates ``gyr[0:2]``; batch by
    ``scipy.signal.lfilter``, streaming compiled (:func:`~spotfree.signal.recursions.paper_attitude_step`)."""

    def __init__(self, rate: float, kp: float = PAPER_KP, ki: float = PAPER_KI):
        self.rate = rate
        self.design = pi_complementary_design(kp, ki, rate)
        self._parameters = paper_parameters(self.design)
        self._state = np.zeros(1, PAPER_STATE)
        self.reset()

    @property
    def parameters_(self) -> np.void:
        """The :data:`~spotfree.signal.recursions.PAPER_PARAMETERS` record."""
        return self._parameters[0]

    def reset(self) -> None:
        """Forget the past: the next sample starts the filter at rest on its accelerometer angles."""
        self._start = True

    def update(self, acc, gyr) -> tuple[float, float]:
        """Roll and pitch (rad) after one sample; ``acc`` (m/s^2) and ``gyr`` (rad/s) body-frame 3-vectors."""
        out = paper_attitude_update(self._parameters, self._state, self._start, float(acc[0]), float(acc[1]),
                                     float(acc[2]), float(gyr[0]), float(gyr[1]))
        self._start = False
        return out

    def run(self, acc: np.ndarray, gyr: np.ndarray) -> np.ndarray:
        """``(n, 2)`` roll and pitch (rad) for ``(n, 3)`` body-frame ``acc`` (m/s^2) and ``gyr`` (rad/s)."""
        roll_acc, pitch_acc = accel_roll_pitch(acc)
        turns = -np.cumsum(np.round(np.diff(roll_acc, prepend=roll_acc[:1]) / TWO_PI) * TWO_PI)
        angles = pi_complementary(np.column_stack([roll_acc + turns, pitch_acc]), np.asarray(gyr)[:, :2], self.design)
        angles[:, 0] = _wrap(angles[:, 0])
        return angles


def paper_parameters(design) -> np.ndarray:
    """The :data:`~spotfree.signal.recursions.PAPER_PARAMETERS` of a :class:`~spotfree.signal.complementary.PIDesign`,
    one record in an array (numba takes a one-element array faster than a record)."""
    coefficients, zi = stream_coefficients(design)
    return np.array([(coefficients, zi)], dtype=PAPER_PARAMETERS)


class GravityPI:
    """Mahony-type PI complementary filter on the gravity direction, for ~20 Hz phone IMUs (the default).

    State: the unit vertical ``u`` (body frame), the gyro bias ``b`` (rad/s, body frame), the time the body has
    looked still, the specific force ``f`` low-passed in the gyro-propagated frame (m/s^2, body frame) and the
    low-passed departure ``m`` of ``|a|`` from g (m/s^2). Each sample ``(a, w_m)`` is taken to describe the
    interval ``(t - T, t]`` (``w_m`` its mean rate, ``a`` its mean specific force, as block-averaged or
    anti-aliased streams deliver them), so with ``w = w_m - b``:

    1. propagate to mid-interval: ``u <- exp(-[w T/2]x) u``;
    2. accelerometer trust: ``m <- m + (1 - exp(-T / motion_tau)) (||a| - g| - m)`` and ``s = (m / acc_scale)^2``
       (``s`` near 0: the phone is moved gently, ``|a|`` stays at g; large: it is shaken or translated);
    3. gravity from the accelerometer, low-passed where gravity is fixed (as vqf does, Laidig and Seel 2023): ``f``
       turns with the body, ``f <- exp(-[w T]x) f``, then ``f <- f + (1 - exp(-T / tau)) (a - f)`` with
       ``tau = acc_tau s / (1 + s)``: no smoothing while ``|a|`` stays at g (fast rotation then costs nothing, the
       raw direction is trusted), up to ``acc_tau`` while the phone is shaken (linear accelerations average out);
    4. error ``e = (f / |f|) x u`` (``|e|`` is the sine of the angle between measured and estimated vertical);
    5. correct: ``u <- exp(-[k e T]x) u``, which turns ``u`` towards ``f`` at the rate ``k |e|``; integral term
       ``b <- b - ki (k / kp) e T`` (gyro-bias estimation in motion by the PI's integral, at the same trust);
    6. propagate to the end of the interval: ``u <- exp(-[w T/2]x) u``, renormalise.

    The gain is scheduled as a steady-state Kalman gain ``k ~ sqrt(q / r)`` would be, with the gyro's error
    growing with the rotation rate and the accelerometer's with how much the phone is shaken::

        k = kp * sqrt(1 + |w|^2 / rate_scale^2) / sqrt(1 + s)

    and the correction rate is bounded, ``k |e| <= k sin(max_error)`` (a Huber-type limit: a large disagreement
    is more likely linear acceleration than attitude error; Madgwick's filter applies a fixed rate always).

    At rest (``|w| < rest_gyr`` and ``||a| - g| < rest_acc`` for ``rest_time`` s) there is no linear
    acceleration, so ``k = rest_gain`` and the bias follows the measured rate, ``b <- b + (T / rest_tau) w``,
    observing all three axes (the integral term cannot see the bias about the vertical).

    Start-up: the first vertical is one accelerometer sample, wrong by whatever the phone was doing then (a log
    often starts while the phone is put in its holder), and the bounded correction would take many seconds to
    undo it. For the first ``startup_time`` s (unless at rest) the gain ``kp`` is replaced by
    ``max(kp, startup_gain (1 - t / startup_time))``, unbounded and without the integral term (nothing is known
    about the bias yet), as Madgwick-type filters ramp their gain down during initialisation (x-io Technologies'
    Fusion AHRS: "initialisation" period). ``startup_time = 0`` gives the filter without it.

    Defaults: ``kp, ki, acc_scale, rate_scale, max_error, acc_tau, motion_tau`` are the point of
    ``benchmarks/tune_orientation.py``'s grid with the lowest mean inclination error on the BROAD trials (Laidig
    et al. 2021) among the points no worse on a synthetic ride-like motion (braking pulses, sway, gyro bias from
    the start); ``benchmarks/orientation_leave_trials_out.py`` checks the selection on held-out trials. The rest
    constants are physical
    (phone gyro noise and bias are well below 2 deg/s, 0.5 m/s^2 passes handlebar vibration) and were not tuned.
    ``acc_tau = 0``, ``motion_tau = 0`` give the filter without the accelerometer low-pass (the previous
    default had also ``acc_scale = 10``, ``rate_scale = 8``). The start-up constants were chosen on real phone
    exports against the phones' own gravity sensors (``benchmarks/export_tilt.py``), not on BROAD.

    :meth:`update` and :meth:`run` run the same compiled step (:func:`~spotfree.signal.recursions.gravity_pi_step`).
    """

    def __init__(
        self,
        rate: float,
        kp: float = 0.3,
        ki: float = 0.001,
        acc_scale: float = 3.0,
        rate_scale: float = 2.0,
        max_error: float = 0.1,
        rest_gyr: float = math.radians(2.0),
        rest_acc: float = 0.5,
        rest_time: float = 1.5,
        rest_gain: float = 1.0,
        rest_tau: float = 1.0,
        g: float = GRAVITY,
        acc_tau: float = 2.0,
        motion_tau: float = 4.0,
        startup_gain: float = 2.0,
        startup_time: float = 3.0,
    ):
        if not (np.isfinite(rate) and rate > 0):
            raise InputError(f"orientation filter: rate must be a positive number of Hz, got {rate}")
        self.rate = rate
        self.kp, self.ki = kp, ki
        self.acc_scale, self.rate_scale, self.max_error = acc_scale, rate_scale, max_error
        self.rest_gyr, self.rest_acc, self.rest_time = rest_gyr, rest_acc, rest_time
        self.rest_gain, self.rest_tau, self.g = rest_gain, rest_tau, g
        self.acc_tau, self.motion_tau = acc_tau, motion_tau
        self.startup_gain, self.startup_time = startup_gain, startup_time
        self.reset()

    def reset(self) -> None:
        """Forget the past: vertical from the next accelerometer sample, zero bias, not still. The parameters are
        read here (:attr:`parameters_`)."""
        self._parameters = np.array([tuple(float(getattr(self, name)) for name in GRAVITY_PI_PARAMETERS.names)],
                                    dtype=GRAVITY_PI_PARAMETERS)
        self._state = np.zeros(1, GRAVITY_PI_STATE)
        self._start = True

    @property
    def parameters_(self) -> np.void:
        """The :data:`~spotfree.signal.recursions.GRAVITY_PI_PARAMETERS` record, as read at the last :meth:`reset`."""
        return self._parameters[0]

    @property
    def bias_(self) -> list[float]:
        """The gyro bias estimate (rad/s, body frame)."""
        return self._state[0]["bias"].tolist()

    def update(self, acc, gyr) -> tuple[float, float]:
        """Roll and pitch (rad) after one sample; ``acc`` (m/s^2) and ``gyr`` (rad/s) body-frame 3-vectors."""
        out = gravity_pi_update(self._parameters, self._state, self._start, float(acc[0]), float(acc[1]),
                                float(acc[2]), float(gyr[0]), float(gyr[1]), float(gyr[2]))
        self._start = False
        return out

    def run(self, acc: np.ndarray, gyr: np.ndarray) -> np.ndarray:
        """``(n, 2)`` roll and pitch (rad) for ``(n, 3)`` body-frame ``acc`` (m/s^2) and ``gyr`` (rad/s)."""
        self.reset()
        acc = np.ascontiguousarray(acc, dtype=float).reshape(-1, 3)
        gyr = np.ascontiguousarray(gyr, dtype=float).reshape(-1, 3)
        out = np.empty((len(acc), 2))
        gravity_pi_run(self._parameters, self._state, acc, gyr, out)
        self._start = len(acc) == 0
        return out


class VQFAttitude:
    """The ``vqf`` package's 6D filter (default parameters) behind the same interface."""

    def __init__(self, rate: float):
        try:
            import vqf
        except ImportError as exc:
            raise InputError("orientation 'vqf' needs the vqf package: pip install vqf") from exc
        self.rate = rate
        self._vqf = vqf.VQF(1.0 / rate)

    def reset(self) -> None:
        """Forget the past (vqf's own initial state)."""
        self._vqf.resetState()

    def update(self, acc, gyr) -> tuple[float, float]:
        """Roll and pitch (rad) after one sample; ``acc`` (m/s^2) and ``gyr`` (rad/s) body-frame 3-vectors."""
        self._vqf.update(np.ascontiguousarray(gyr, dtype=float), np.ascontiguousarray(acc, dtype=float))
        roll, pitch = _quaternion_roll_pitch(*self._vqf.getQuat6D())
        return float(roll), float(pitch)

    def run(self, acc: np.ndarray, gyr: np.ndarray) -> np.ndarray:
        """``(n, 2)`` roll and pitch (rad) for ``(n, 3)`` body-frame ``acc`` (m/s^2) and ``gyr`` (rad/s)."""
        self.reset()
        out = self._vqf.updateBatch(np.ascontiguousarray(gyr, dtype=float), np.ascontiguousarray(acc, dtype=float))
        return np.column_stack(_quaternion_roll_pitch(*out["quat6D"].T))


def _quaternion_roll_pitch(w, x, y, z):
    """Roll and pitch (rad) of body-to-world (z up) quaternions [w, x, y, z] (floats or arrays).

    The body's vertical is the third row of the rotation matrix, ``[2(xz - wy), 2(yz + wx), 1 - 2(x^2 + y^2)]``,
    and eq. (1) gives the angles.
    """
    ux, uy, uz = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return np.arctan2(uy, uz), np.arctan2(-ux, np.hypot(uy, uz))


def attitude_filter(orientation: str, rate: float):
    """A fresh backend named ``orientation`` (one of :data:`ORIENTATIONS`) for samples at ``rate`` Hz."""
    if orientation == "default":
        return GravityPI(rate)
    if orientation == "paper":
        return PaperAttitude(rate)
    if orientation == "vqf":
        return VQFAttitude(rate)
    raise InputError(f"--orientation: unknown orientation '{orientation}'; choose one of: {', '.join(ORIENTATIONS)}")


def estimate_attitude(acc: np.ndarray, gyr: np.ndarray, rate: float, orientation: str = "default") -> np.ndarray:
    """``(n, 2)`` roll and pitch (rad) of one gap-free segment, ``acc`` (m/s^2), ``gyr`` (rad/s) ``(n, 3)`` body frame."""
    return attitude_filter(orientation, rate).run(acc, gyr)
