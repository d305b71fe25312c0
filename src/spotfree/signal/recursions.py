"""Compiled per-sample recursions of the ride features: one sample in, every filter's state updated in place.

Each filter keeps its math in its own module's docstring; its per-sample recursion is compiled here:

* :func:`lowpass_step` -- Butterworth second-order sections (:mod:`~spotfree.signal.butterworth`);
* :func:`pi_complementary_sample` and :func:`paper_attitude_step` -- the paper's PI complementary filter on roll and
  pitch (:mod:`~spotfree.signal.complementary`, :class:`~spotfree.signal.orientation.PaperAttitude`);
* :func:`gravity_pi_step` -- :class:`~spotfree.signal.orientation.GravityPI`, the default attitude filter;
* :func:`speed_aided_step` -- the speed-aided pitch filter (:mod:`~spotfree.signal.speed_aided`);
* :func:`ride_features_step` -- all of them chained into the 16 ride channels of
  :class:`~spotfree.signal.features.FeatureStream`.

Constants and states are numpy records (the ``*_PARAMETERS`` and ``*_STATE`` dtypes); Python passes them as
one-element arrays (numba takes those far faster than a record scalar), the kernels work on
``array[0]``. Every kernel is cached to disk by numba and calls only kernels of this module: numba's cache does not
notice a change in another file, so a chain across modules could run stale code.
"""

from __future__ import annotations

import math

import numba
import numpy as np

TWO_PI = 2.0 * math.pi
SECTIONS = 2
"""Second-order sections of the ride features' Butterworth low-passes (third order)."""
FEATURE_WIDTH = 16
"""Channels :func:`ride_features_step` writes (``FEATURE_CHANNELS`` then ``DERIVED_CHANNELS``)."""

PAPER_PARAMETERS = np.dtype([("coefficients", "f8", 8), ("zi", "f8", 2)])
"""Record of :func:`paper_attitude_step`'s constants (:func:`~spotfree.signal.complementary.stream_coefficients`)."""
PAPER_STATE = np.dtype([("z", "f8", (2, 2)), ("roll_prev", "f8"), ("turns", "f8")])
"""Record of :func:`paper_attitude_step`'s state: filter state of roll and pitch, last accelerometer roll, turns
added by the unwrapping (rad)."""
GRAVITY_PI_PARAMETERS = np.dtype([(name, "f8") for name in (
    "rate", "kp", "ki", "acc_scale", "rate_scale", "max_error", "rest_gyr", "rest_acc", "rest_time", "rest_gain",
    "rest_tau", "g", "acc_tau", "motion_tau", "startup_gain", "startup_time")])
"""Record of :class:`~spotfree.signal.orientation.GravityPI`'s parameters as :func:`gravity_pi_step` reads them (SI
units, rate in Hz)."""
GRAVITY_PI_STATE = np.dtype([("u", "f8", 3), ("bias", "f8", 3), ("still", "f8"), ("acc", "f8", 3), ("motion", "f8"),
                             ("age", "f8")])
"""Record of :func:`gravity_pi_step`'s state: unit vertical (body frame), gyro bias (rad/s), time still (s), the
specific force low-passed in the gyro-propagated frame (m/s^2, body frame), the low-passed departure of the
specific-force magnitude from g (m/s^2) and the time since the start (s)."""
SPEED_AIDED_PARAMETERS = np.dtype([(name, "f8") for name in (
    "rate", "pitch_noise", "bias_noise", "accel_noise", "reference_noise", "speed_noise", "initial_pitch",
    "initial_bias", "initial_speed")])
"""Record of :func:`speed_aided_step`'s constants: the rate (Hz) and
:class:`~spotfree.signal.speed_aided.SpeedAidedParameters`."""
SPEED_AIDED_STATE = np.dtype([("x", "f8", 3), ("P", "f8", 6), ("has_speed", "?")])
"""Record of :func:`speed_aided_step`'s state: ``(theta, b, v)``, the covariance's upper triangle
``p00, p01, p02, p11, p12, p22``, and whether a GPS fix has set the speed."""
FEATURE_PARAMETERS = np.dtype([
    ("attitude", "i8"), ("mount", "f8", (3, 3)), ("g", "f8"),
    ("gravity", GRAVITY_PI_PARAMETERS), ("paper", PAPER_PARAMETERS),
    ("sections", "f8", (SECTIONS, 5)), ("zi", "f8", (SECTIONS, 2)),
    ("long_sections", "f8", (SECTIONS, 5)), ("long_zi", "f8", (SECTIONS, 2)),
    ("speed_aided", SPEED_AIDED_PARAMETERS),
    ("lean_b", "f8"), ("lean_a", "f8"), ("bias_c", "f8"), ("vib_c", "f8"), ("rough_speed", "f8", 2),
])
"""Record of :func:`ride_features_step`'s constants: attitude kind (0 default, 1 paper, 2 given), the
device-to-vehicle ``MOUNT``, gravity (m/s^2), the attitude filters', low-passes' and speed-aided filter's
constants, the ``lean`` and ``vib`` coefficients, and the speed range (m/s) the ``rough`` channels clip to."""
FEATURE_STATE = np.dtype([
    ("gravity", GRAVITY_PI_STATE), ("paper", PAPER_STATE),
    ("lowpass", "f8", (3, SECTIONS, 2)), ("long_lowpass", "f8", (1, SECTIONS, 2)),
    ("speed_aided", SPEED_AIDED_STATE),
    ("lean", "f8"), ("lean_bias", "f8"), ("vib", "f8", 3),
    ("raw", "f8", 3), ("level", "f8", 3), ("a_t", "f8", 1), ("acc_long", "f8", 1),
])
"""Record of :func:`ride_features_step`'s state (``raw`` to ``acc_long``: the low-passes' inputs and outputs)."""


@numba.njit(cache=True, nogil=True)
def lowpass_step(sections, zi, state, start, x, y):  # pragma: no cover - compiled
    """One sample ``x`` ``(c,)`` through the cascade into ``y`` ``(c,)``; ``state`` ``(c, s, 2)``, per channel and
    section ``[z1, z2]``, set to ``zi * x`` when ``start`` (the filter at rest on this sample).

    Each section computes ``y = b0 v + z1``, ``z1 <- b1 v - a1 y + z2``, ``z2 <- b2 v - a2 y`` and passes ``y`` on
    as ``v``.
    """
    for c in range(x.shape[0]):
        v = x[c]
        z = state[c]
        if start:
            for i in range(sections.shape[0]):
                z[i, 0] = zi[i, 0] * v
                z[i, 1] = zi[i, 1] * v
        for i in range(sections.shape[0]):
            b0, b1, b2, a1, a2 = sections[i, 0], sections[i, 1], sections[i, 2], sections[i, 3], sections[i, 4]
            out = b0 * v + z[i, 0]
            z[i, 0] = b1 * v - a1 * out + z[i, 1]
            z[i, 1] = b2 * v - a2 * out
            v = out
        y[c] = v


@numba.njit(cache=True, nogil=True)
def pi_complementary_sample(coefficients, zi, z, start, x, w):  # pragma: no cover - compiled
    """Filtered angle (rad) of one channel for accelerometer angle ``x`` (rad) and rate ``w`` (rad/s); ``z`` ``(2,)``
    its state, set to ``zi * x`` when ``start``."""
    a1, a2, r0, r1, r2, b0, b1, b2 = (coefficients[0], coefficients[1], coefficients[2], coefficients[3],
                                      coefficients[4], coefficients[5], coefficients[6], coefficients[7])
    if start:
        z[0] = zi[0] * x
        z[1] = zi[1] * x
    y = r0 * w + b0 * x + z[0]
    z[0] = r1 * w + b1 * x - a1 * y + z[1]
    z[1] = r2 * w + b2 * x - a2 * y
    return y


@numba.njit(cache=True, nogil=True)
def pi_complementary_channels(coefficients, zi, state, start, angle_acc, rate, out):  # pragma: no cover - compiled
    """:func:`pi_complementary_sample` for every channel: ``state`` ``(c, 2)``, ``angle_acc``, ``rate``, ``out``
    ``(c,)``."""
    for c in range(out.shape[0]):
        out[c] = pi_complementary_sample(coefficients, zi, state[c], start, angle_acc[c], rate[c])


@numba.njit(cache=True, nogil=True)
def _wrap(angle):  # pragma: no cover - compiled
    """Angle wrapped to [-pi, pi)."""
    return (angle + math.pi) % TWO_PI - math.pi


@numba.njit(cache=True, nogil=True)
def paper_attitude_step(p, s, start, ax, ay, az, gx, gy):  # pragma: no cover - compiled
    """Roll and pitch (rad) of :class:`~spotfree.signal.orientation.PaperAttitude` after one sample: body-frame ``a``
    (m/s^2), rates ``gx, gy`` (rad/s) about x and y; ``p`` a :data:`PAPER_PARAMETERS` and ``s`` a :data:`PAPER_STATE`
    record, the state started afresh when ``start``."""
    roll_acc = math.atan2(ay, az)
    pitch_acc = math.atan2(-ax, math.hypot(ay, az))
    if start:
        s.turns = 0.0
    else:
        s.turns -= round((roll_acc - s.roll_prev) / TWO_PI) * TWO_PI
    s.roll_prev = roll_acc
    roll = pi_complementary_sample(p.coefficients, p.zi, s.z[0], start, roll_acc + s.turns, gx)
    pitch = pi_complementary_sample(p.coefficients, p.zi, s.z[1], start, pitch_acc, gy)
    return _wrap(roll), pitch


@numba.njit(cache=True, nogil=True)
def paper_attitude_update(p, s, start, ax, ay, az, gx, gy):  # pragma: no cover - compiled
    """:func:`paper_attitude_step` on one-element record arrays."""
    return paper_attitude_step(p[0], s[0], start, ax, ay, az, gx, gy)


@numba.njit(cache=True, nogil=True)
def _rotate(ux, uy, uz, wx, wy, wz, dt):  # pragma: no cover - compiled
    """Body coordinates of a world-fixed vector ``u`` after the body turns at ``w`` (rad/s) for ``dt`` (s).

    ``u <- exp(-[w dt]x) u`` by Rodrigues' formula (``u' = -w x u`` integrated exactly for constant ``w``).
    """
    norm = math.sqrt(wx * wx + wy * wy + wz * wz)
    angle = norm * dt
    if angle < 1e-12:
        return ux, uy, uz
    kx, ky, kz = -wx / norm, -wy / norm, -wz / norm
    c, s = math.cos(angle), math.sin(angle)
    d = (kx * ux + ky * uy + kz * uz) * (1.0 - c)
    return (
        ux * c + (ky * uz - kz * uy) * s + kx * d,
        uy * c + (kz * ux - kx * uz) * s + ky * d,
        uz * c + (kx * uy - ky * ux) * s + kz * d,
    )


@numba.njit(cache=True, nogil=True)
def _smoothing(dt, tau):  # pragma: no cover - compiled
    """Weight of a new sample in a first-order low-pass of time constant ``tau`` (s) after ``dt`` (s); 1 for
    ``tau <= 0`` (no smoothing)."""
    return 1.0 - math.exp(-dt / tau) if tau > 0 else 1.0


@numba.njit(cache=True, nogil=True)
def gravity_pi_step(p, s, start, ax, ay, az, gx, gy, gz):  # pragma: no cover - compiled
    """Roll and pitch (rad) of :class:`~spotfree.signal.orientation.GravityPI` after one sample (the steps of its
    docstring): body-frame ``a`` (m/s^2) and ``g`` (rad/s); ``p`` a :data:`GRAVITY_PI_PARAMETERS` and ``s`` a
    :data:`GRAVITY_PI_STATE` record, the state started afresh (vertical along ``a``, zero bias, not still) when
    ``start``."""
    u, b, f = s.u, s.bias, s.acc
    norm_a = math.sqrt(ax * ax + ay * ay + az * az)
    if start:
        if norm_a > 0:
            u[0], u[1], u[2] = ax / norm_a, ay / norm_a, az / norm_a
        else:
            u[0], u[1], u[2] = 0.0, 0.0, 1.0
        b[0] = b[1] = b[2] = 0.0
        f[0], f[1], f[2] = ax, ay, az
        s.still = s.motion = s.age = 0.0
    wx, wy, wz = gx - b[0], gy - b[1], gz - b[2]
    half = 0.5 / p.rate
    ux, uy, uz = _rotate(u[0], u[1], u[2], wx, wy, wz, half)
    w2 = wx * wx + wy * wy + wz * wz
    departure = norm_a - p.g
    s.motion += _smoothing(2.0 * half, p.motion_tau) * (abs(departure) - s.motion)
    shaken = (s.motion / p.acc_scale) ** 2
    fx, fy, fz = _rotate(f[0], f[1], f[2], wx, wy, wz, 2.0 * half)
    alpha = _smoothing(2.0 * half, p.acc_tau * shaken / (1.0 + shaken))
    fx, fy, fz = fx + alpha * (ax - fx), fy + alpha * (ay - fy), fz + alpha * (az - fz)
    f[0], f[1], f[2] = fx, fy, fz
    norm_f = math.sqrt(fx * fx + fy * fy + fz * fz)
    if w2 < p.rest_gyr * p.rest_gyr and abs(departure) < p.rest_acc:
        s.still += 2.0 * half
    else:
        s.still = 0.0
    if norm_f > 0:
        nx, ny, nz = fx / norm_f, fy / norm_f, fz / norm_f
        ex, ey, ez = ny * uz - nz * uy, nz * ux - nx * uz, nx * uy - ny * ux
        if s.still >= p.rest_time:
            k = p.rest_gain
            step = 2.0 * half / p.rest_tau
            b[0] += step * wx
            b[1] += step * wy
            b[2] += step * wz
        elif s.age < p.startup_time:
            k = max(p.kp, p.startup_gain * (1.0 - s.age / p.startup_time))
            k *= math.sqrt((1.0 + w2 / p.rate_scale**2) / (1.0 + shaken))
        else:
            trust = math.sqrt((1.0 + w2 / p.rate_scale**2) / (1.0 + shaken))
            k = p.kp * trust
            sine = math.sqrt(ex * ex + ey * ey + ez * ez)
            limit = math.sin(p.max_error)
            if sine > limit:
                k *= limit / sine
            integral = p.ki * (k / p.kp) * 2.0 * half
            b[0] -= integral * ex
            b[1] -= integral * ey
            b[2] -= integral * ez
        ux, uy, uz = _rotate(ux, uy, uz, k * ex, k * ey, k * ez, 2.0 * half)
    ux, uy, uz = _rotate(ux, uy, uz, wx, wy, wz, half)
    norm_u = math.sqrt(ux * ux + uy * uy + uz * uz)
    u[0], u[1], u[2] = ux / norm_u, uy / norm_u, uz / norm_u
    s.age += 2.0 * half
    return math.atan2(u[1], u[2]), math.atan2(-u[0], math.hypot(u[1], u[2]))


@numba.njit(cache=True, nogil=True)
def gravity_pi_update(p, s, start, ax, ay, az, gx, gy, gz):  # pragma: no cover - compiled
    """:func:`gravity_pi_step` on one-element record arrays."""
    return gravity_pi_step(p[0], s[0], start, ax, ay, az, gx, gy, gz)


@numba.njit(cache=True, nogil=True)
def gravity_pi_run(p, s, acc, gyr, out):  # pragma: no cover - compiled
    """:func:`gravity_pi_step` over ``(n, 3)`` arrays into ``out`` ``(n, 2)``, from a fresh state (one-element
    record arrays ``p``, ``s``)."""
    for k in range(acc.shape[0]):
        out[k, 0], out[k, 1] = gravity_pi_step(p[0], s[0], k == 0, acc[k, 0], acc[k, 1], acc[k, 2],
                                               gyr[k, 0], gyr[k, 1], gyr[k, 2])


@numba.njit(cache=True, nogil=True)
def speed_aided_step(p, s, start, ax, ay, az, q, r, roll, pitch_ref, speed):  # pragma: no cover - compiled
    """``(a_t, theta)`` after one sample (the recursion of :mod:`~spotfree.signal.speed_aided`): vehicle-axis specific
    force ``a`` (m/s^2), body rates ``q, r`` (rad/s) about y and z, the attitude filter's ``roll`` and ``pitch_ref``
    (rad), ``speed`` (m/s) on a GPS fix, NaN otherwise; ``p`` a :data:`SPEED_AIDED_PARAMETERS` and ``s`` a
    :data:`SPEED_AIDED_STATE` record, started afresh when ``start``."""
    dt = 1.0 / p.rate
    x, P = s.x, s.P
    sr, cr = math.sin(roll), math.cos(roll)
    across = sr * ay + cr * az
    if start:
        x[0], x[1], x[2] = pitch_ref, 0.0, 0.0
        P[0], P[1], P[2], P[3], P[4], P[5] = p.initial_pitch**2, 0.0, 0.0, p.initial_bias**2, 0.0, p.initial_speed**2
        s.has_speed = False
    theta, bias, v = x[0], x[1], x[2]
    st, ct = math.sin(theta), math.cos(theta)
    a_t = ct * ax + st * across
    g = (-st * ax + ct * across) * dt  # d v / d theta over one step
    p00, p01, p02, p11, p12, p22 = P[0], P[1], P[2], P[3], P[4], P[5]
    # F P F^T + Q, F = [[1, -dt, 0], [0, 1, 0], [g, 0, 1]]
    P[0] = p00 - 2 * dt * p01 + dt * dt * p11 + p.pitch_noise**2 * dt
    P[1] = p01 - dt * p11
    P[2] = g * (p00 - dt * p01) + p02 - dt * p12
    P[3] = p11 + p.bias_noise**2 * dt
    P[4] = g * p01 + p12
    P[5] = g * g * p00 + 2 * g * p02 + p22 + (p.accel_noise * dt) ** 2
    x[0], x[1], x[2] = theta + (q * cr - r * sr - bias) * dt, bias, v + a_t * dt
    _measure(x, P, 0, pitch_ref - x[0], p.reference_noise**2 / dt)
    if speed == speed:  # a GPS fix (not NaN)
        if not s.has_speed:
            x[2] = speed
            P[2] = P[4] = P[5] = 0.0
            s.has_speed = True
        _measure(x, P, 2, speed - x[2], p.speed_noise**2)
    theta = x[0]
    return math.cos(theta) * ax + math.sin(theta) * across, theta


@numba.njit(cache=True, nogil=True)
def _measure(x, P, k, innovation, variance):  # pragma: no cover - compiled
    """Kalman update for a direct measurement of state ``k`` (0 pitch, 2 speed): ``K = P e_k / (P_kk + var)``,
    ``x += K innovation``, ``P -= K (P e_k)^T``."""
    p00, p01, p02, p11, p12, p22 = P[0], P[1], P[2], P[3], P[4], P[5]
    if k == 0:
        c0, c1, c2, ckk = p00, p01, p02, p00
    else:
        c0, c1, c2, ckk = p02, p12, p22, p22
    inv = 1.0 / (ckk + variance)
    x[0] += c0 * inv * innovation
    x[1] += c1 * inv * innovation
    x[2] += c2 * inv * innovation
    P[0], P[1], P[2] = p00 - c0 * c0 * inv, p01 - c0 * c1 * inv, p02 - c0 * c2 * inv
    P[3], P[4], P[5] = p11 - c1 * c1 * inv, p12 - c1 * c2 * inv, p22 - c2 * c2 * inv


@numba.njit(cache=True, nogil=True)
def speed_aided_update(p, s, start, ax, ay, az, q, r, roll, pitch_ref, speed):  # pragma: no cover - compiled
    """:func:`speed_aided_step` on one-element record arrays."""
    return speed_aided_step(p[0], s[0], start, ax, ay, az, q, r, roll, pitch_ref, speed)


@numba.njit(cache=True, nogil=True)
def speed_aided_run(p, s, acc, gyr, roll, pitch_ref, speed, out):  # pragma: no cover - compiled
    """:func:`speed_aided_step` over a segment into ``out`` ``(n, 3)`` (``a_t``, ``theta`` and the speed state
    ``v``), from a fresh state (one-element record arrays ``p``, ``s``)."""
    for k in range(acc.shape[0]):
        out[k, 0], out[k, 1] = speed_aided_step(p[0], s[0], k == 0, acc[k, 0], acc[k, 1], acc[k, 2], gyr[k, 1],
                                                gyr[k, 2], roll[k], pitch_ref[k], speed[k])
        out[k, 2] = s[0].x[2]


@numba.njit(cache=True, nogil=True)
def ride_features_step(p, s, start, a0, a1, a2, w0, w1, w2, speed, roll, pitch, out):  # pragma: no cover - compiled
    """All 16 ride channels (``FEATURE_CHANNELS`` then ``DERIVED_CHANNELS`` of :mod:`~spotfree.signal.features`) of
    one device-frame sample ``a`` (m/s^2), ``w`` (rad/s), ``speed`` (m/s or NaN) into ``out``; ``p`` a
    :data:`FEATURE_PARAMETERS` and ``s`` a :data:`FEATURE_STATE` record, every filter started afresh when ``start``;
    ``roll``, ``pitch`` (rad) are used only with attitude kind 2 (otherwise the kernel's own attitude filter gives
    them).

    Vehicle axes ``a_v = MOUNT a``, ``g_v = MOUNT w``; gravity-free level acceleration
    ``R_y(pitch) R_x(roll) a_v - [0, 0, g]`` (:func:`spotfree.signal.frame.gravity_free_level`); then the recursions
    of :mod:`spotfree.signal.features` in its order."""
    m = p.mount
    ax = m[0, 0] * a0 + m[0, 1] * a1 + m[0, 2] * a2
    ay = m[1, 0] * a0 + m[1, 1] * a1 + m[1, 2] * a2
    az = m[2, 0] * a0 + m[2, 1] * a1 + m[2, 2] * a2
    gx = m[0, 0] * w0 + m[0, 1] * w1 + m[0, 2] * w2
    gy = m[1, 0] * w0 + m[1, 1] * w1 + m[1, 2] * w2
    gz = m[2, 0] * w0 + m[2, 1] * w1 + m[2, 2] * w2
    if p.attitude == 0:
        roll, pitch = gravity_pi_step(p.gravity, s.gravity, start, ax, ay, az, gx, gy, gz)
    elif p.attitude == 1:
        roll, pitch = paper_attitude_step(p.paper, s.paper, start, ax, ay, az, gx, gy)
    raw, level, vib = s.raw, s.level, s.vib
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    across = sr * ay + cr * az
    raw[0], raw[1], raw[2] = cp * ax + sp * across, cr * ay - sr * az, -sp * ax + cp * across - p.g
    lowpass_step(p.sections, p.zi, s.lowpass, start, raw, level)
    if start:
        s.lean = s.lean_bias = 0.0
        vib[0] = vib[1] = vib[2] = 0.0
    c = p.vib_c
    for i in range(3):
        vib[i] = c * vib[i] + (1.0 - c) * (raw[i] - level[i]) ** 2
    s.lean_bias = p.bias_c * s.lean_bias + (1.0 - p.bias_c) * gy
    s.lean = p.lean_a * s.lean + p.lean_b * (gy - s.lean_bias)
    s.a_t[0], _ = speed_aided_step(p.speed_aided, s.speed_aided, start, ax, ay, az, gy, gz, roll, pitch, speed)
    lowpass_step(p.long_sections, p.long_zi, s.long_lowpass, start, s.a_t, s.acc_long)
    out[0], out[1], out[2], out[3], out[4], out[5] = roll, pitch, gy, level[0], level[1], level[2]
    out[6], out[7], out[8], out[9] = s.lean, s.acc_long[0], gx, gz
    out[10], out[11], out[12] = math.sqrt(vib[0]), math.sqrt(vib[1]), math.sqrt(vib[2])
    if s.speed_aided.has_speed:  # a GPS fix has set the speed; before it, the vibration not normalised by speed
        speed_root = math.sqrt(min(max(s.speed_aided.x[2], p.rough_speed[0]), p.rough_speed[1]))
        out[13], out[14], out[15] = out[10] / speed_root, out[11] / speed_root, out[12] / speed_root
    else:
        out[13], out[14], out[15] = out[10], out[11], out[12]


@numba.njit(cache=True, nogil=True)
def ride_features_update(p, s, start, a0, a1, a2, w0, w1, w2, speed, roll, pitch, out):  # pragma: no cover
    """:func:`ride_features_step` on one-element record arrays; ``out`` must hold :data:`FEATURE_WIDTH` values."""
    if out.shape[0] < FEATURE_WIDTH:
        raise ValueError("ride features: the output vector must hold 16 values")
    ride_features_step(p[0], s[0], start, a0, a1, a2, w0, w1, w2, speed, roll, pitch, out)


@numba.njit(cache=True, nogil=True)
def ride_features_block(p, s, start, rows, columns, out):  # pragma: no cover - compiled
    """:func:`ride_features_step` over ``rows`` ``(n, k)`` whose ``columns`` (7 indices) hold ``a0 a1 a2 w0 w1 w2
    speed``, into ``out`` ``(n, 16)``, on one-element record arrays; ``start`` applies to the first row. Attitude
    kinds 0 and 1 only."""
    if out.shape[0] < rows.shape[0] or out.shape[1] < FEATURE_WIDTH:
        raise ValueError("ride features: the output must hold one row of 16 values per input row")
    c = columns
    for k in range(rows.shape[0]):
        r = rows[k]
        ride_features_step(p[0], s[0], start and k == 0, r[c[0]], r[c[1]], r[c[2]], r[c[3]], r[c[4]], r[c[5]],
                           r[c[6]], 0.0, 0.0, out[k])
