"""Ride features: attitude, pitch rate and gravity-free level accelerations from a raw IMU log.

Per sample, with the raw device-frame IMU re-expressed on the vehicle axes (x forward, y left, z up) by the
mount that :mod:`spotfree.signal.mount` estimates from the log (the nominal ``MOUNT``, flat on the handlebar with
the top edge forward, unless the phone is mounted otherwise or ``mount`` says):

* ``roll``, ``pitch`` (rad): the attitude filter chosen by ``orientation``
  (:mod:`spotfree.signal.orientation`), eq. (1) convention, positive pitch nose down;
* ``pitch_rate`` (rad/s): the gyro rate about the vehicle y axis (positive nose down);
* ``acc_x, acc_y, acc_z`` (m/s^2): specific force rotated to the level vehicle frame with the filtered roll and
  pitch, gravity removed (``R_y(pitch) R_x(roll) a - [0, 0, g]``), then low-passed by the third-order
  Butterworth of :mod:`spotfree.signal.butterworth` (causal, or zero-phase offline).

Derived channels (``derived=True``), :data:`DERIVED_CHANNELS`:

* ``lean`` (rad, about the vehicle y axis, positive nose down): the gyro-only lean, a leaky integral of
  ``pitch_rate`` ``q`` after removing a slowly tracked gyro bias ``beta``,

      beta[n] = c beta[n-1] + (1 - c) q[n],           c = exp(-1 / (tau_b f_s)),  tau_b = LEAN_BIAS_TIME_CONSTANT
      lean[n] = a lean[n-1] + (q[n] - beta[n]) / f_s,  a = exp(-1 / (tau f_s)),    tau = LEAN_TIME_CONSTANT

  i.e. ``q`` through ``tau s / (tau s + 1) * tau_b s / (tau_b s + 1) / s``, both states zero at the start of every
  segment. A self-balancing vehicle leans so that the specific force stays along its body z axis, so during a
  sustained braking the accelerometer sees almost no longitudinal force and the attitude filter drifts back to
  "no lean"; the gyro does not. A constant mount misalignment is absent, and a constant gyro bias ``b`` (rad/s)
  shifts ``lean`` by ``b tau exp(-t / tau_b)`` only (without the bias stage: ``b tau`` for ever).
* ``acc_long`` (m/s^2, vehicle x, positive forward): the longitudinal acceleration ``a_t`` of the speed-aided
  pitch filter (:mod:`spotfree.signal.speed_aided`, GPS ``speed`` channel when the log has one), low-passed by the
  same third-order Butterworth at :data:`LONG_CUTOFF`. Unlike ``acc_x`` it does not decay during a steady braking.
* ``roll_rate``, ``yaw_rate`` (rad/s): the gyro rates about the vehicle x (positive right side down) and z (positive
  to the left) axes, unfiltered, for lateral manoeuvres.
* ``vib_x, vib_y, vib_z`` (m/s^2, vehicle frame): the vibration the acceleration low-pass removes, as an RMS: with
  ``e[n]`` the gravity-free level acceleration minus its low-passed ``acc_*``,

      v[n] = c v[n-1] + (1 - c) e[n]^2,   vib[n] = sqrt(v[n]),   c = exp(-1 / (tau_v f_s)),  tau_v = VIB_TIME_CONSTANT

  ``v`` zero at the start of every segment. Road roughness shows in these levels (``acc_*`` keep only < 3 Hz).
* ``rough_x, rough_y, rough_z`` (m/s^2 per sqrt(m/s)): the vibration levels over the square root of the forward
  speed ``u`` of the speed-aided filter (its state ``v``, held to :data:`ROUGH_SPEED`),

      rough[n] = vib[n] / sqrt(clip(u[n], u_min, u_max))   from the segment's first GPS speed fix on,
      rough[n] = vib[n]                                     before it.

  On a road of ISO 8608 displacement density ``Gd(n) = Gd(n0) (n / n0)^-2`` ridden at ``u``, the vertical
  acceleration density is ``(2 pi f)^4 Gd(n0) n0^2 u / f^2``, so in a fixed frequency band the RMS grows as
  ``sqrt(Gd(n0) u)``: ``rough`` estimates the road's class, whatever the speed. Before any fix the filter's speed
  is the integrated acceleration, which drifts without bound: a speed nothing measured, so ``rough`` is then the
  vibration not normalised by speed, and a log without GPS speed gets a note saying so
  (:data:`NO_SPEED_NOTE`).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.signal import lfilter

from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS, Recording
from spotfree.signal.butterworth import butter_lowpass, lowpass, sections_and_zi
from spotfree.signal.frame import MOUNT, gravity_free_level
from spotfree.signal.mount import estimate_mount
from spotfree.signal.orientation import GravityPI, PaperAttitude, attitude_filter
from spotfree.signal.recursions import (FEATURE_PARAMETERS, FEATURE_STATE, ride_features_block,
                                       ride_features_update)
from spotfree.signal.speed_aided import speed_aided_acceleration, speed_aided_parameters
from spotfree.units import GRAVITY

FEATURE_CHANNELS = ("roll", "pitch", "pitch_rate", "acc_x", "acc_y", "acc_z")
"""Channel names of the ride features, in output order."""

DERIVED_CHANNELS = ("lean", "acc_long", "roll_rate", "yaw_rate", "vib_x", "vib_y", "vib_z", "rough_x", "rough_y",
                    "rough_z")
"""Channels added after :data:`FEATURE_CHANNELS` when ``derived=True``."""
LEVEL_CHANNELS = ("vib_x", "vib_y", "vib_z", "rough_x", "rough_y", "rough_z")
"""The non-negative RMS levels among :data:`DERIVED_CHANNELS` (m/s^2 and m/s^2 over root m/s): a change of surface
multiplies them."""

FEATURE_VERSION = 2
"""Version of the channel definitions, stored in every model file (:mod:`spotfree.model`)."""
FEATURE_CHANGES = {2: "the vibration RMS over 0.25 s, now 0.05 s"}
"""Per :data:`FEATURE_VERSION`, what it changed in the channels of :data:`CHANNEL_CHANGED` (version 2 also added
the ``rough_*`` channels)."""
CHANNEL_CHANGED = {"vib_x": 2, "vib_y": 2, "vib_z": 2}
"""The :data:`FEATURE_VERSION` from which a channel is computed as now: a model trained on it under an earlier
version would be fed other values, so loading it is refused."""

LEAN_TIME_CONSTANT = 10.0
"""Time constant ``tau`` (s) of the ``lean`` leaky integrator (the module docstring's recursion): long enough to
hold the lean of a braking, short enough that the gyro bias left in ``q - beta`` does not move cruising as far as a
gentle braking."""

LEAN_BIAS_TIME_CONSTANT = 20.0
"""Time constant ``tau_b`` (s) of the gyro bias ``beta`` tracked out of ``lean`` (a first-order low-pass of the
pitch rate ``q``): it keeps the lean of cruising near zero across rides."""


LONG_CUTOFF = 1.0
"""Cut-off (Hz) of the ``acc_long`` low-pass: it passes the deceleration of a braking and removes the handlebar
vibration that makes one rider's cruising unlike another's."""


VIB_TIME_CONSTANT = 0.05
"""Time constant ``tau_v`` (s) of the vibration RMS (the module docstring's recursion, :func:`vibration_coefficient`):
one sample at 20 Hz, so that a model's window does the averaging and a change of surface shows within it."""

ROUGH_SPEED = (1.0, 8.0)
"""m/s: ``(u_min, u_max)``, the range the speed ``u`` under ``rough = vib / sqrt(u)`` is held to (walking pace;
above a self-balancing vehicle's top speed)."""


def vibration_coefficient(rate: float, tau: float = VIB_TIME_CONSTANT) -> float:
    """``c = exp(-1 / (tau_v f_s))`` of the vibration RMS recursion."""
    return float(np.exp(-1.0 / (tau * rate)))


def vibration(residual: np.ndarray, rate: float) -> np.ndarray:
    """``vib`` (m/s^2) from the low-pass ``residual`` ``(n, 3)`` (m/s^2) of one gap-free segment, zero initial state."""
    c = vibration_coefficient(rate)
    return np.sqrt(lfilter([1.0 - c], [1.0, -c], np.asarray(residual, dtype=float) ** 2, axis=0))


NO_SPEED_NOTE = ("no GPS speed: the road channels rough_x, rough_y, rough_z are the vibration not normalised by "
                 "speed (vib_x, vib_y, vib_z), so a model trained on rides with GPS speed reads them at another "
                 "scale; record with location on")
"""The note of a log without GPS speed whose ride features include the derived channels (module docstring)."""


def roughness(vib: np.ndarray, speed: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """``rough`` (m/s^2 per sqrt(m/s)) of one segment: ``vib`` ``(n, 3)`` (m/s^2) over the square root of the
    filter's ``speed`` ``(n,)`` (m/s) held to :data:`ROUGH_SPEED` where ``measured`` (from the segment's first GPS
    speed fix on), ``vib`` itself before it."""
    measured = np.maximum.accumulate(np.asarray(measured, dtype=bool))
    return np.where(measured[:, None], vib / np.sqrt(np.clip(speed, *ROUGH_SPEED))[:, None], vib)


def lean_coefficients(rate: float, tau: float = LEAN_TIME_CONSTANT,
                      tau_bias: float = LEAN_BIAS_TIME_CONSTANT) -> tuple[float, float, float]:
    """``(b, a, c)`` of the ``lean`` recursion: ``b = 1 / f_s`` (s), ``a = exp(-1 / (tau f_s))``,
    ``c = exp(-1 / (tau_b f_s))``."""
    return 1.0 / rate, float(np.exp(-1.0 / (tau * rate))), float(np.exp(-1.0 / (tau_bias * rate)))


def leaky_lean(pitch_rate: np.ndarray, rate: float, tau: float = LEAN_TIME_CONSTANT,
               tau_bias: float = LEAN_BIAS_TIME_CONSTANT) -> np.ndarray:
    """``lean`` (rad) from ``pitch_rate`` (rad/s, vehicle y axis) of one gap-free segment, zero initial states."""
    b, a, c = lean_coefficients(rate, tau, tau_bias)
    q = np.asarray(pitch_rate, dtype=float)
    bias = lfilter([1.0 - c], [1.0, -c], q)
    return lfilter([b], [1.0, -a], q - bias)


def ride_features(rec: Recording, orientation: str = "default", zero_phase: bool = False,
                  derived: bool = False, mount: str | np.ndarray | None = None) -> Recording:
    """The six :data:`FEATURE_CHANNELS` of ``rec`` on its own grid (same experiment column, truth and gaps),
    followed by the :data:`DERIVED_CHANNELS` when ``derived``, and the log's GPS ``speed`` (m/s, NaN between fixes)
    as it is when it has one (the ride prior reads it: :class:`spotfree.ride_prior.RidePrior`); ``meta`` says
    ``features="ride"`` and the ``orientation``, so that a model trained on them knows how to make them from a raw log.
    With ``derived`` and no GPS speed in ``rec``, :data:`NO_SPEED_NOTE` is added to ``rec.meta['repairs']`` (the
    log's notes), once.

    ``mount``: the device-to-vehicle rotation, a ``(3, 3)`` matrix (``v_vehicle = mount @ v_device``) or a choice
    of :func:`~spotfree.signal.mount.estimate_mount` (``auto``, ``estimate``, ``flat``, ``upright``); None takes
    ``rec.meta['mount_choice']``, else ``auto``. ``meta['mount']`` says what was used, ``meta['mount_warnings']``
    lists the doubts (an unusual or uncertain mount)."""
    rec.require_imu()
    mount = rec.meta.get("mount_choice", "auto") if mount is None else mount
    mount_note, mount_warnings = "given matrix", []
    if isinstance(mount, str):
        estimate = estimate_mount(rec, mount)
        mount, mount_note, mount_warnings = estimate.used, estimate.describe(), estimate.warnings
    mount = np.asarray(mount, dtype=float)
    attitude = attitude_filter(orientation, rec.rate)
    sos = butter_lowpass(rec.rate)
    acc_all = rec.array(ACC_CHANNELS) @ mount.T
    gyr_all = rec.array(GYRO_CHANNELS) @ mount.T
    speed_all = rec.channels.get("speed")
    long_sos = butter_lowpass(rec.rate, LONG_CUTOFF)
    names = FEATURE_CHANNELS + (DERIVED_CHANNELS if derived else ())
    out = np.full((len(rec), len(names)), np.nan)
    for start, stop in rec.segments():
        acc, gyr = acc_all[start:stop], gyr_all[start:stop]
        roll, pitch = attitude.run(acc, gyr).T
        raw_level = gravity_free_level(acc, roll, pitch)
        level = lowpass(raw_level, sos, zero_phase=zero_phase)
        columns = [roll, pitch, gyr[:, 1], level]
        if derived:
            speed = None if speed_all is None else speed_all[start:stop]
            a_t, _, forward = speed_aided_acceleration(acc, gyr, roll, pitch, speed, rec.rate).T
            vib = vibration(raw_level - level, rec.rate)
            fixed = np.zeros(stop - start, bool) if speed is None else np.isfinite(speed)
            columns += [leaky_lean(gyr[:, 1], rec.rate), lowpass(a_t[:, None], long_sos)[:, 0], gyr[:, 0],
                        gyr[:, 2], vib, roughness(vib, forward, fixed)]
        out[start:stop] = np.column_stack(columns)
    if derived and (speed_all is None or not np.isfinite(speed_all).any()):
        notes = rec.meta.get("repairs", [])  # the log's notes: told with what was read, once
        if f"{rec.source}: {NO_SPEED_NOTE}" not in notes:
            rec.meta["repairs"] = [*notes, f"{rec.source}: {NO_SPEED_NOTE}"]
    carried = {"speed": speed_all} if speed_all is not None else {}
    feats = rec.with_channels({**dict(zip(names, out.T)), **carried})
    feats.meta.update(features="ride", orientation=orientation, mount=mount_note, mount_warnings=mount_warnings,
                      mount_matrix=mount.tolist())
    return feats


_ATTITUDE_KINDS = {"default": 0, "paper": 1}
"""Attitude filters the compiled step runs itself; any other (``vqf``) hands it roll and pitch (kind 2)."""


def feature_parameters(rate: float, orientation: str = "default") -> np.ndarray:
    """:func:`_feature_parameters` (a fresh copy; the filter designs are computed once per rate and attitude)."""
    return _feature_parameters(float(rate), orientation).copy()


@functools.lru_cache(maxsize=16)
def _feature_parameters(rate: float, orientation: str) -> np.ndarray:
    """The :data:`~spotfree.signal.recursions.FEATURE_PARAMETERS` of the causal ride features at ``rate`` Hz with
    ``orientation``, one record in an array (numba takes a one-element array faster than a record)."""
    array = np.zeros(1, FEATURE_PARAMETERS)
    p = array[0]
    p["attitude"] = _ATTITUDE_KINDS.get(orientation, 2)
    p["mount"] = MOUNT
    p["g"] = GRAVITY
    p["gravity"] = GravityPI(rate).parameters_
    p["paper"] = PaperAttitude(rate).parameters_
    p["sections"], p["zi"] = sections_and_zi(butter_lowpass(rate))
    p["long_sections"], p["long_zi"] = sections_and_zi(butter_lowpass(rate, LONG_CUTOFF))
    p["speed_aided"] = speed_aided_parameters(rate)[0]
    p["lean_b"], p["lean_a"], p["bias_c"] = lean_coefficients(rate)
    p["vib_c"] = vibration_coefficient(rate)
    p["rough_speed"] = ROUGH_SPEED
    return array


class FeatureStream:
    """The causal :func:`ride_features` one sample at a time (one gap-free segment; :meth:`reset` between).

    With ``derived=True``, :meth:`update` returns the :data:`DERIVED_CHANNELS` after the six standard channels;
    pass the GPS ``speed`` (m/s) on the samples where a fix arrives. One compiled call per sample
    (:func:`~spotfree.signal.recursions.ride_features_step`) updates every filter; :attr:`parameters_` and
    :attr:`state_` hold its records (one-element arrays)."""

    def __init__(self, rate: float, orientation: str = "default", derived: bool = False,
                 mount: np.ndarray = MOUNT):
        self.rate = rate
        self.orientation = orientation
        self.derived = derived
        self.mount = np.asarray(mount, dtype=float)
        self._attitude = attitude_filter(orientation, rate) if orientation not in _ATTITUDE_KINDS else None
        self.parameters_ = feature_parameters(rate, orientation)
        self.parameters_[0]["mount"] = self.mount
        self.state_ = np.zeros(1, FEATURE_STATE)
        self._out = np.zeros(len(FEATURE_CHANNELS + DERIVED_CHANNELS))
        self._width = len(self._out) if derived else len(FEATURE_CHANNELS)
        self.reset()

    def reset(self) -> None:
        """Start a new segment: fresh attitude and low-pass state."""
        if self._attitude is not None:
            self._attitude.reset()
        self._start = True

    def update(self, acc, gyr, speed: float = float("nan")) -> np.ndarray:
        """Features ``(6,)`` (``(16,)`` with ``derived``) for one sample: ``acc`` (m/s^2) and ``gyr`` (rad/s)
        3-vectors in the device frame, ``speed`` (m/s) the GPS speed on a fix, NaN otherwise."""
        self.step(*imu_floats(acc, gyr), float(speed), self._out)
        return self._out[:self._width].copy()

    def update_block(self, rows: np.ndarray, columns: np.ndarray = np.arange(7)) -> np.ndarray:
        """:meth:`update` over ``rows`` ``(n, k)`` of one segment whose ``columns`` (7 indices) hold ``ax ay az``
        (m/s^2), ``gx gy gz`` (rad/s) and the GPS ``speed`` (m/s or NaN); IMU values finite. Features ``(n, 6)``
        (``(n, 16)`` with ``derived``); one compiled call for the attitude filters the kernel runs itself."""
        rows = np.asarray(rows, dtype=float)
        out = np.empty((len(rows), len(self._out)))
        if self._attitude is None:
            ride_features_block(self.parameters_, self.state_, self._start, rows, columns, out)
            self._start = False
        else:
            for k, row in enumerate(rows[:, columns].tolist()):
                self.step(*row, out[k])
        return out[:, :self._width]

    def step(self, a0: float, a1: float, a2: float, w0: float, w1: float, w2: float, speed: float,
             out: np.ndarray) -> None:
        """:meth:`update` on plain floats, writing all 16 channels into ``out`` (no copy; a shorter ``out`` is
        refused)."""
        roll = pitch = 0.0
        if self._attitude is not None:
            m = self.parameters_[0]["mount"]
            roll, pitch = self._attitude.update(m @ (a0, a1, a2), m @ (w0, w1, w2))
        ride_features_update(self.parameters_, self.state_, self._start, a0, a1, a2, w0, w1, w2, speed, roll,
                             pitch, out)
        self._start = False


def imu_floats(acc, gyr) -> tuple[float, float, float, float, float, float]:
    """``acc`` and ``gyr`` (3-vectors: arrays, lists or tuples) as six Python floats."""
    if isinstance(acc, np.ndarray) and isinstance(gyr, np.ndarray):
        a0, a1, a2 = acc.tolist()
        w0, w1, w2 = gyr.tolist()
        return float(a0), float(a1), float(a2), float(w0), float(w1), float(w2)
    return float(acc[0]), float(acc[1]), float(acc[2]), float(gyr[0]), float(gyr[1]), float(gyr[2])
