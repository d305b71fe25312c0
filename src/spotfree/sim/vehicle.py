"""Self-balancing transporter and rider: from the rider's programme to the motion of the handlebar.

Frames. Handlebar (body) axes: x forward, y left, z up along the handlebar column. Heading frame: x along the
heading, y left, z up. World: local East-North-Up, heading ``psi`` measured from East, counter-clockwise. The
handlebar attitude is ``R = R_z(psi) R_y(theta) R_x(phi)`` (pitch ``theta`` positive nose down, i.e. the top of
the column forward; roll ``phi`` positive right side down), the convention of :mod:`spotfree.signal.frame`.

Longitudinal motion (a wheeled inverted pendulum). The rider asks for an acceleration ``a_cmd`` by leaning; the
balance loop (rider plus controller) makes the lean follow it as a well-damped second-order response::

    a_lean = H(s) a_cmd,   H(s) = w_b^2 / (s^2 + 2 z_b w_b s + w_b^2),   alpha = atan(a_lean / g)

``alpha`` is the lean of the combined centre of mass (positive forward), so ``tan(alpha) = a / g`` in steady
acceleration. A mass at height ``L`` above an axle accelerating at ``a`` obeys ``L alpha'' = g sin(alpha) -
a cos(alpha)``, hence the wheels deliver::

    a_base = a_lean - L alpha'' / cos(alpha)

which shows the inverted pendulum's counter-movement: a short surge before a stop, a short dip before a start.
The platform, and the handlebar with it, pitches with the lean and with the pitch error the controller needs to
produce the transient torque::

    theta = theta_rest + kappa alpha + kappa_c (a_base - a_lean) / g + alpha_road + theta_column

Road. The left and right hub paths (from :class:`Road`) excite the platform through the tyres, its only spring
(no suspension on the transporter); the rider's legs damp it: ``T(s) = w^2 / (s^2 + 2 z w s + w^2)``, heave
(``w_t``) from the mean of both tracks, roll (``w_r``, slower: a tall rider on a narrow track) from their
difference over the track width. The contact force leans with the local road slope ``s = dz/dx``: a horizontal
force per unit mass ``a_road = -(g + z_p'') s``. The controller holds the wheels' speed and position (a critically
damped loop, so a steady force, such as standing on a sloping stone, leaves no speed error); the axle's speed and
acceleration are perturbed by ``dv = dx'`` and ``da = dx''``::

    dx'' + 2 w_v dx' + w_v^2 dx = a_road

which in turn

* pitches the vehicle until the balance loop restores it (the pendulum feels the axle's acceleration):
  ``alpha_road'' + 2 z_p w_p alpha_road' + w_p^2 alpha_road = -da / L``;
* bends the handlebar column, a lightly damped mode ``theta_column'' + 2 z_c w_c theta_column' +
  w_c^2 theta_column = -(da + c z_p'') / l + m |v| w(t)`` with motor torque ripple ``w`` (white).

Steering (lean-steer handlebar): tilting the handlebar towards a side turns to it, ``r = -G(v) phi_steer`` with
``G(v) = G_0 / (1 + |v| / v_f)``, so the handlebar rolls by ``phi_steer = -r / G(v)`` (left turn, ``r > 0``: left
side down, ``phi < 0``); the turn's centripetal acceleration is ``v r`` to the left.

Handlebar kinematics. Body rates from the Euler rates (ZYX)::

    p = phi' - psi' sin(theta)
    q = theta' cos(phi) + psi' sin(phi) cos(theta)
    r = psi' cos(phi) cos(theta) - theta' sin(phi)

and the specific force at the tablet, a height ``l`` up the column from the axle (the pivot of pitch and roll)::

    f = R_x(phi)^T R_y(theta)^T ([a_t, v psi', z_p''] + [0, 0, g]) + w' x rho + w x (w x rho),   rho = [0, 0, l]

with ``a_t = a_base + da`` the tangential acceleration of the axle and ``v = v_lean + dv`` its speed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.signal import bilinear_zpk, sosfilt, tf2zpk, zpk2sos

from spotfree.units import GRAVITY


@dataclass(frozen=True)
class Vehicle:
    """The transporter: geometry, tyres, controller loops and steering (SI units, angles in rad)."""

    tablet_height: float = 0.95
    """Tablet above the axle along the handlebar column, m."""
    track: float = 0.50
    """Distance between the wheels' contact tracks, m."""
    tyre_freq: float = 6.5
    """Bounce of the platform on its tyres, Hz."""
    tyre_damping: float = 0.3
    roll_freq: float = 3.0
    """Roll of platform and rider on the tyres, Hz."""
    roll_damping: float = 0.3
    column_freq: float = 18.0
    """Fore-aft bending mode of the handlebar column with the tablet, Hz."""
    column_damping: float = 0.04
    column_coupling: float = 0.3
    """Share of the platform's vertical acceleration that bends the column (the tablet sits ahead of it)."""
    motor_ripple: float = 0.3
    """Column excitation by motor torque ripple, rad/s^2 per m/s of speed, per internal sample (white)."""
    pitch_loop_freq: float = 2.0
    """Balance loop restoring the vehicle's pitch after a road disturbance, Hz."""
    pitch_loop_damping: float = 0.7
    speed_loop_freq: float = 0.3
    """``w_v / 2 pi``: how fast the wheels' speed and position recover from a road disturbance, Hz."""
    steer_gain: float = 6.0
    """Yaw rate per rad of handlebar roll at standstill, 1/s."""
    steer_fade_speed: float = 3.0
    """Speed at which the steering gain has halved, m/s."""
    max_steer: float = float(np.deg2rad(14.0))
    """Largest handlebar roll, rad."""

    def steer_gain_at(self, speed: np.ndarray | float) -> np.ndarray | float:
        """``G(v) = G_0 / (1 + |v| / v_f)``: yaw rate (rad/s) per rad of handlebar roll at speed ``v`` (m/s)."""
        return self.steer_gain / (1.0 + np.abs(speed) / self.steer_fade_speed)

    def max_yaw_rate(self, speed: np.ndarray | float) -> np.ndarray | float:
        """Largest yaw rate (rad/s) the handlebar can command at speed ``v`` (m/s)."""
        return self.steer_gain_at(speed) * self.max_steer


def draw_vehicle(rng: np.random.Generator) -> Vehicle:
    """One vehicle set-up: tyre pressure and the tablet mount vary from ride to ride."""
    return Vehicle(
        tyre_freq=rng.uniform(5.5, 7.5),
        tyre_damping=rng.uniform(0.25, 0.4),
        roll_freq=rng.uniform(2.5, 3.5),
        column_freq=rng.uniform(14.0, 22.0),
        column_damping=rng.uniform(0.03, 0.06),
    )


@dataclass(frozen=True)
class RiderBody:
    """How the rider and the balance loop carry the lean (SI units, angles in rad)."""

    com_height: float
    """``L``: combined centre of mass above the axle, m."""
    balance_freq: float
    """``w_b / 2 pi``: closed-loop lean response, Hz."""
    balance_damping: float
    """``z_b``: damping ratio of the lean response (well damped, about 0.85 to 1)."""
    lean_to_pitch: float
    """``kappa``: handlebar pitch per rad of lean."""
    counter_pitch: float
    """``kappa_c``: handlebar pitch per g of transient base acceleration (controller pitch error)."""
    rest_pitch: float
    """``theta_rest``: handlebar pitch standing still, rad."""


@dataclass(frozen=True)
class Road:
    """Hub paths along the route, sampled every ``dx`` metres from distance 0.

    ``height`` (n, 2): left and right wheel hub elevation (m, tyre envelope applied); ``strike`` (n,): the kerbs
    and bumps alone (m), included in ``height``, so their response can be told apart; ``surface`` (n,): index into
    ``names`` of the surface under the wheels.
    """

    dx: float
    height: np.ndarray
    strike: np.ndarray
    surface: np.ndarray
    names: tuple[str, ...]

    def sample(self, distance: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """At each ``distance`` (m): hub heights (n, 2) m, their slopes (n, 2), the strike slope (n,), surface index."""
        grid = np.arange(self.height.shape[0]) * self.dx
        slope = np.gradient(self.height, self.dx, axis=0)
        strike_slope = np.gradient(self.strike, self.dx)
        heights = np.column_stack([np.interp(distance, grid, self.height[:, k]) for k in range(2)])
        slopes = np.column_stack([np.interp(distance, grid, slope[:, k]) for k in range(2)])
        index = np.clip(np.rint(distance / self.dx).astype(int), 0, len(grid) - 1)
        return heights, slopes, np.interp(distance, grid, strike_slope), self.surface[index]


@dataclass
class Motion:
    """Ground truth of one ride at the internal rate (arrays of shape (n,), vectors (n, 3) in handlebar axes)."""

    time: np.ndarray
    """s"""
    speed: np.ndarray
    """Axle speed along the heading, m/s."""
    distance: np.ndarray
    """Distance rolled along the route, m."""
    heading: np.ndarray
    """rad from East, counter-clockwise."""
    east: np.ndarray
    """m"""
    north: np.ndarray
    """m"""
    lean_accel: np.ndarray
    """``g tan(alpha)``, m/s^2: the acceleration the lean asks for."""
    accel: np.ndarray
    """Tangential acceleration of the axle, m/s^2."""
    pitch: np.ndarray
    """Handlebar pitch ``theta``, rad (positive nose down)."""
    pitch_rate: np.ndarray
    """``theta'``, rad/s."""
    roll: np.ndarray
    """Handlebar roll ``phi``, rad (positive right side down)."""
    yaw_rate: np.ndarray
    """``psi'``, rad/s (positive left)."""
    specific_force: np.ndarray
    """At the tablet, handlebar axes (x forward, y left, z up), gravity included, m/s^2."""
    angular_rate: np.ndarray
    """Of the handlebar, handlebar axes, rad/s."""
    surface: np.ndarray
    """Surface index under the wheels (see ``Road.names``)."""
    surface_names: tuple[str, ...]
    strike_accel: np.ndarray
    """Vertical platform acceleration caused by kerbs and bumps alone, m/s^2."""


def _filter(num: list[float], den: list[float], u: np.ndarray, fs: float) -> np.ndarray:
    """Apply the continuous transfer function ``num(s) / den(s)`` to ``u`` sampled at ``fs`` (bilinear, zero state)."""
    return sosfilt(zpk2sos(*bilinear_zpk(*tf2zpk(num, den), fs)), u)


def second_order(u: np.ndarray, freq: float, damping: float, fs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``y, y', y''`` of ``y'' + 2 z w y' + w^2 y = u`` from rest (``w = 2 pi freq``), ``u`` sampled at ``fs``."""
    w = 2.0 * np.pi * freq
    den = [1.0, 2.0 * damping * w, w * w]
    y = _filter([1.0], den, u, fs)
    dy = _filter([1.0, 0.0], den, u, fs)
    return y, dy, u - 2.0 * damping * w * dy - w * w * y


def balance_response(accel_cmd: np.ndarray, body: RiderBody, fs: float) -> np.ndarray:
    """``a_lean = H(s) a_cmd`` (m/s^2): the commanded acceleration after the well-damped lean response."""
    w = 2.0 * np.pi * body.balance_freq
    return _filter([w * w], [1.0, 2.0 * body.balance_damping * w, w * w], accel_cmd, fs)


def _body_rates(phi, theta, dphi, dtheta, dpsi):
    """Body angular rates ``(p, q, r)`` (rad/s) from ZYX Euler angles and their rates."""
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    return np.column_stack([dphi - dpsi * st, dtheta * cp + dpsi * sp * ct, dpsi * cp * ct - dtheta * sp])


def _body_rate_derivatives(phi, theta, dphi, dtheta, dpsi, ddphi, ddtheta, ddpsi):
    """Time derivatives of :func:`_body_rates` (rad/s^2), from the Euler angles' first and second derivatives."""
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    dp = ddphi - ddpsi * st - dpsi * dtheta * ct
    dq = (ddtheta * cp - dtheta * dphi * sp + ddpsi * sp * ct + dpsi * dphi * cp * ct - dpsi * dtheta * sp * st)
    dr = (ddpsi * cp * ct - dpsi * dphi * sp * ct - dpsi * dtheta * cp * st - ddtheta * sp - dtheta * dphi * cp)
    return np.column_stack([dp, dq, dr])


def _to_body(vec: np.ndarray, phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """``R_x(phi)^T R_y(theta)^T vec``: heading-frame vectors (n, 3) on handlebar axes."""
    sp, cp, st, ct = np.sin(phi), np.cos(phi), np.sin(theta), np.cos(theta)
    ux = ct * vec[:, 0] - st * vec[:, 2]
    uz = st * vec[:, 0] + ct * vec[:, 2]
    return np.column_stack([ux, cp * vec[:, 1] + sp * uz, -sp * vec[:, 1] + cp * uz])


def simulate_motion(
    time: np.ndarray,
    accel_cmd: np.ndarray,
    yaw_rate: np.ndarray,
    body: RiderBody,
    vehicle: Vehicle,
    make_road: Callable[[np.ndarray], Road],
    rng: np.random.Generator,
    heading0: float = 0.0,
) -> Motion:
    """Ride the programme: rider command ``accel_cmd`` (m/s^2) and steered ``yaw_rate`` (rad/s) on a uniform grid.

    ``make_road(distance)`` builds the road once the distance rolled at each instant is known. ``rng`` drives the
    motor torque ripple. See the module docstring for the equations.
    """
    fs = 1.0 / (time[1] - time[0])
    g = GRAVITY
    d1 = lambda x: np.gradient(x, 1.0 / fs)  # noqa: E731  (smooth, low-frequency signals only)

    # Lean and the base acceleration it needs.
    a_lean = balance_response(accel_cmd, body, fs)
    alpha = np.arctan(a_lean / g)
    dd_alpha = d1(d1(alpha))
    a_base = a_lean - body.com_height * dd_alpha / np.cos(alpha)
    v_lean = cumulative_trapezoid(a_base, time, initial=0.0)
    distance = cumulative_trapezoid(v_lean, time, initial=0.0)

    # Road through the tyres: heave acceleration, roll, horizontal disturbance.
    road = make_road(distance)
    heights, slopes, strike_slope, surface = road.sample(distance)
    wt, wr = 2.0 * np.pi * vehicle.tyre_freq, 2.0 * np.pi * vehicle.roll_freq
    heave_den = [1.0, 2.0 * vehicle.tyre_damping * wt, wt * wt]
    roll_den = [1.0, 2.0 * vehicle.roll_damping * wr, wr * wr]
    heave_acc = _filter([wt * wt, 0.0], heave_den, v_lean * slopes.mean(axis=1), fs)  # s T(s) z_c'
    strike_acc = _filter([wt * wt, 0.0], heave_den, v_lean * strike_slope, fs)
    roll_in = (heights[:, 0] - heights[:, 1]) / vehicle.track
    roll_rate_in = v_lean * (slopes[:, 0] - slopes[:, 1]) / vehicle.track
    phi_road = _filter([wr * wr], roll_den, roll_in, fs)
    dphi_road = _filter([wr * wr], roll_den, roll_rate_in, fs)
    ddphi_road = _filter([wr * wr, 0.0], roll_den, roll_rate_in, fs)
    a_road = -(g + heave_acc) * slopes.mean(axis=1)

    _, dv, da = second_order(a_road, vehicle.speed_loop_freq, 1.0, fs)
    alpha_road, dalpha_road, ddalpha_road = second_order(
        -da / body.com_height, vehicle.pitch_loop_freq, vehicle.pitch_loop_damping, fs
    )
    speed = v_lean + dv
    a_t = a_base + da
    ripple = vehicle.motor_ripple * np.abs(speed) * rng.standard_normal(len(time))
    excitation = -(da + vehicle.column_coupling * heave_acc) / vehicle.tablet_height + ripple
    col, dcol, ddcol = second_order(excitation, vehicle.column_freq, vehicle.column_damping, fs)

    # Handlebar attitude and its derivatives.
    theta_smooth = body.rest_pitch + body.lean_to_pitch * alpha + body.counter_pitch * (a_base - a_lean) / g
    theta = theta_smooth + alpha_road + col
    dtheta = d1(theta_smooth) + dalpha_road + dcol
    ddtheta = d1(d1(theta_smooth)) + ddalpha_road + ddcol
    phi_steer = np.clip(-yaw_rate / vehicle.steer_gain_at(speed), -vehicle.max_steer, vehicle.max_steer)
    phi = phi_steer + phi_road
    dphi = d1(phi_steer) + dphi_road
    ddphi = d1(d1(phi_steer)) + ddphi_road
    dd_psi = d1(yaw_rate)
    heading = heading0 + cumulative_trapezoid(yaw_rate, time, initial=0.0)

    rates = _body_rates(phi, theta, dphi, dtheta, yaw_rate)
    rates_dot = _body_rate_derivatives(phi, theta, dphi, dtheta, yaw_rate, ddphi, ddtheta, dd_psi)
    base = np.column_stack([a_t, speed * yaw_rate, heave_acc + g])
    height = vehicle.tablet_height
    p, q, r = rates.T
    lever = height * np.column_stack([rates_dot[:, 1] + p * r, -rates_dot[:, 0] + q * r, -(p * p + q * q)])
    force = _to_body(base, phi, theta) + lever

    return Motion(
        time=time,
        speed=speed,
        distance=distance,
        heading=heading,
        east=cumulative_trapezoid(speed * np.cos(heading), time, initial=0.0),
        north=cumulative_trapezoid(speed * np.sin(heading), time, initial=0.0),
        lean_accel=a_lean,
        accel=a_t,
        pitch=theta,
        pitch_rate=dtheta,
        roll=phi,
        yaw_rate=yaw_rate,
        specific_force=force,
        angular_rate=rates,
        surface=surface,
        surface_names=road.names,
        strike_accel=strike_acc,
    )
