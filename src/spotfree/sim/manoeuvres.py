"""Rider programmes: what the rider does and when, and the road the ride goes over.

A :class:`Plan` is written leg by leg on a time axis (stand, accelerate, cruise, brake, turn) and becomes a
:class:`Programme` on the simulator's internal grid:

* ``accel``: the longitudinal acceleration the rider asks for by leaning (m/s^2, vehicle x forward), a sum of
  raised-cosine steps ``a(t) = sum_i da_i S((t - t_i) / w_i + 1/2)``, ``S(u) = (1 - cos(pi u)) / 2`` on [0, 1].
  Each step is antisymmetric about its centre ``t_i``, so once it has settled the planned speed is exactly that of
  the piecewise-constant plan: a stop ends at 0 m/s and never below.
* ``sway``: the rider's postural sway, a zero-mean acceleration (the derivative of a slow speed wobble).
* ``yaw_rate``: the heading rate the rider steers (rad/s about vertical, positive left): ``sin^2`` lobes for
  turns and slaloms, plus a small wander while moving.
* ``events``: spans of the confounders (``turn``, ``speed-change``, ``crossing-stop``, ``braking``,
  ``near-sudden``); ``surfaces``: spans on rough asphalt or cobblestone; ``strikes``: kerbs and bumps.

Riders differ (:func:`draw_rider`, one draw per experiment) and every repetition varies around the rider's habits.
The five scenario plans (:data:`PLANS`) follow the paper's protocol; see docs/simulator.md.

Road (:meth:`Programme.road`): per surface an ISO 8608 random profile, displacement PSD
``Gd(n) = Gd(n0) (n / n0)^-2`` with ``n0 = 0.1`` cycles/m (classes A, C, D for smooth, rough asphalt, cobblestone),
left and right tracks partly coherent; cobblestones add domed setts; a kerb is a step climbed along the wheel's arc
``sqrt(2 R h)``, a bump a ``sin^2`` hump (a pothole when negative). The tyre's contact patch envelopes the texture
(moving average over its length).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, NamedTuple

import numpy as np
from scipy.fft import next_fast_len
from scipy.integrate import cumulative_trapezoid
from scipy.ndimage import uniform_filter1d
from scipy.signal import butter, sosfiltfilt

from spotfree.sim.vehicle import Road, RiderBody, Vehicle

MAX_SPEED = 20.1 / 3.6
"""Segway PT top speed, m/s (12.5 mi/h)."""
LATERAL_KINDS = ("gentle", "sharp", "slalom")
"""The kinds of lateral manoeuvre a lateral ride draws (:func:`lateral`)."""
LATERAL_LIMIT = 2.0
"""Lateral acceleration ``v r`` riders keep below in turns, m/s^2."""
SURFACES = ("smooth", "rough-asphalt", "cobblestone")
ROAD_KINDS = ("rough-asphalt", "cobblestone", "kerb")
"""The kinds of road event a road ride holds (:func:`road`): patches of the two rough surfaces, kerbs and bumps."""
ISO_8608_GD0 = {"smooth": 16e-6, "rough-asphalt": 256e-6, "cobblestone": 1024e-6}
"""Displacement PSD at ``n0 = 0.1`` cycles/m (m^3): ISO 8608 classes A, C and D (geometric class means)."""
WHEEL_RADIUS = 0.24
"""m (a 19-inch tyre)."""
CONTACT_LENGTH = 0.08
"""Tyre contact patch length, m: the road texture is averaged over it."""
TRACK_COHERENCE = 0.6
"""Share of the profile variance the left and right tracks have in common."""


class Span(NamedTuple):
    start: float
    """s"""
    end: float
    """s"""
    name: str


class Strike(NamedTuple):
    time: float
    """s, when the wheel reaches the feature."""
    kind: str
    """``kerb`` (a step) or ``bump`` (a hump; a pothole when ``height < 0``)."""
    height: float
    """m"""


@dataclass(frozen=True)
class Rider:
    """One rider's habits (m/s, m/s^2, s) and body; repetitions vary around them."""

    cruise_speed: float
    accel: float
    normal_decel: float
    sudden_decel: float
    normal_ramp: float
    """Lean-in time of a planned stop, s."""
    sudden_ramp: float
    """Lean-in time of an emergency stop, s."""
    body: RiderBody


def draw_rider(rng: np.random.Generator) -> Rider:
    """A rider: cruising 13-19 km/h, accelerating 0.45-0.95 m/s^2, braking 0.8-1.35 (normal) or 2.6-3.3 m/s^2."""
    return Rider(
        cruise_speed=rng.uniform(3.6, 5.3),
        accel=rng.uniform(0.45, 0.95),
        normal_decel=rng.uniform(0.8, 1.35),
        sudden_decel=rng.uniform(2.6, 3.3),
        normal_ramp=rng.uniform(0.6, 1.1),
        sudden_ramp=rng.uniform(0.25, 0.4),
        body=RiderBody(
            com_height=rng.uniform(0.75, 0.95),
            balance_freq=rng.uniform(0.9, 1.2),
            balance_damping=rng.uniform(0.85, 1.0),
            lean_to_pitch=rng.uniform(0.55, 0.85),
            counter_pitch=rng.uniform(0.1, 0.25),
            rest_pitch=float(np.deg2rad(rng.normal(0.0, 0.7))),
        ),
    )


def raised_cosine_step(u: np.ndarray) -> np.ndarray:
    """``S(u)``: 0 for ``u <= 0``, ``(1 - cos(pi u)) / 2`` on [0, 1], 1 for ``u >= 1``."""
    return 0.5 - 0.5 * np.cos(np.pi * np.clip(u, 0.0, 1.0))


def _slow_noise(rng: np.random.Generator, n: int, cutoff: float, fs: float, rms: float) -> np.ndarray:
    """Zero-phase low-passed white noise with the given rms (``cutoff`` in Hz)."""
    x = sosfiltfilt(butter(2, cutoff, fs=fs, output="sos"), rng.standard_normal(n))
    return rms * x / x.std()


@dataclass
class Programme:
    """A rider programme on the internal grid (see the module docstring)."""

    time: np.ndarray
    accel: np.ndarray
    sway: np.ndarray
    yaw_rate: np.ndarray
    speed: np.ndarray
    """Planned speed, m/s (the integral of ``accel``)."""
    events: list[Span] = field(default_factory=list)
    surfaces: list[Span] = field(default_factory=list)
    strikes: list[Strike] = field(default_factory=list)

    @property
    def duration(self) -> float:
        return float(self.time[-1])

    def add_strikes(self, rng: np.random.Generator, count: int, kinds: tuple[str, ...]) -> None:
        """``count`` kerbs or bumps at moments when the planned speed exceeds 1.5 m/s, at least 2 s apart."""
        fs = 1.0 / (self.time[1] - self.time[0])
        free = self.speed > 1.5
        for _ in range(count):
            candidates = np.flatnonzero(free)
            if not len(candidates):
                return
            k = int(rng.choice(candidates))
            kind = str(rng.choice(kinds))
            if kind == "kerb":
                height = rng.choice([-1.0, 1.0]) * rng.uniform(0.03, 0.07)
            else:
                height = rng.uniform(0.02, 0.05) if rng.random() < 0.7 else -rng.uniform(0.02, 0.04)
            self.strikes.append(Strike(float(self.time[k]), kind, float(height)))
            free[max(0, k - int(2 * fs)) : k + int(2 * fs)] = False

    def add_patches(self, rng: np.random.Generator, seconds: float, names: tuple[str, ...]) -> None:
        """Rough patches (surface spans of 4-12 s) while moving, until they total about ``seconds``."""
        moving = self.time[self.speed > 1.0]
        if not len(moving):
            return
        lo, hi = float(moving[0]), float(moving[-1])
        total, tries = 0.0, 0
        while total < seconds and tries < 200:
            tries += 1
            length = min(rng.uniform(4.0, 12.0), seconds - total + 2.0)
            start = rng.uniform(lo, max(lo, hi - length))
            span = Span(start, start + length, str(rng.choice(names)))
            if any(span.start < s.end + 2.0 and s.start < span.end + 2.0 for s in self.surfaces):
                continue
            self.surfaces.append(span)
            total += length

    def road(self, distance: np.ndarray, rng: np.random.Generator, dx: float = 0.01) -> Road:
        """The road under this programme, given the ``distance`` (m) rolled at each instant of ``time``."""
        n = int(np.ceil((distance[-1] + 5.0) / dx))
        x = np.arange(n) * dx
        at = lambda t: float(np.interp(t, self.time, distance))  # noqa: E731
        surface = np.zeros(n, dtype=int)
        for span in self.surfaces:
            surface[(x >= at(span.start)) & (x < at(span.end))] = SURFACES.index(span.name)
        blend = max(1, int(round(0.5 / dx)))
        texture = np.zeros((n, 2))
        for index in sorted(set(surface.tolist())):
            weight = uniform_filter1d((surface == index).astype(float), blend)
            texture += weight[:, None] * _two_tracks(n, dx, ISO_8608_GD0[SURFACES[index]], rng)
            if SURFACES[index] == "cobblestone":
                texture += weight[:, None] * np.column_stack([_setts(n, dx, rng) for _ in range(2)])
        texture = uniform_filter1d(texture, max(1, int(round(CONTACT_LENGTH / dx))), axis=0)
        strike = np.zeros(n)
        for s in self.strikes:
            strike += _strike_profile(x, at(s.time), s.kind, s.height)
        return Road(dx=dx, height=texture + strike[:, None], strike=strike, surface=surface, names=SURFACES)


def iso8608_profile(n: int, dx: float, gd0: float, rng: np.random.Generator, n_min: float = 0.05) -> np.ndarray:
    """Random elevation (m) on ``n`` points ``dx`` apart with one-sided PSD ``gd0 (n / 0.1)^-2`` above ``n_min``.

    Unit white noise sampled every ``dx`` has one-sided PSD ``2 dx``; shaping its spectrum by
    ``sqrt(Gd(n) / (2 dx))`` gives the ISO 8608 PSD ``Gd(n)`` (m^3, ``n`` in cycles/m).
    """
    m = next_fast_len(n, real=True)
    freq = np.fft.rfftfreq(m, dx)
    psd = np.zeros_like(freq)
    band = freq >= n_min
    psd[band] = gd0 * (freq[band] / 0.1) ** -2
    return np.fft.irfft(np.fft.rfft(rng.standard_normal(m)) * np.sqrt(psd / (2.0 * dx)), m)[:n]


def _two_tracks(n: int, dx: float, gd0: float, rng: np.random.Generator) -> np.ndarray:
    """Left and right profiles (n, 2) sharing :data:`TRACK_COHERENCE` of their variance."""
    common = iso8608_profile(n, dx, gd0, rng)
    own = [iso8608_profile(n, dx, gd0, rng) for _ in range(2)]
    c = np.sqrt(TRACK_COHERENCE)
    return np.column_stack([c * common + np.sqrt(1.0 - c * c) * o for o in own])


def _setts(n: int, dx: float, rng: np.random.Generator) -> np.ndarray:
    """Domed setts along one track: stones 9-15 cm long, crowns 2-8 mm high (m)."""
    lengths = rng.uniform(0.09, 0.15, size=int(n * dx / 0.09) + 2)
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    crowns = rng.uniform(0.002, 0.008, size=len(lengths))
    x = np.arange(n) * dx
    stone = np.searchsorted(starts, x, side="right") - 1
    return crowns[stone] * np.sin(np.pi * (x - starts[stone]) / lengths[stone])


def _strike_profile(x: np.ndarray, at: float, kind: str, height: float) -> np.ndarray:
    """Hub path over a kerb (a step climbed over ``sqrt(2 R |h|)``) or a bump (``sin^2`` hump, 0.3 m + 4 |h|)."""
    if kind == "kerb":
        length = np.sqrt(2.0 * WHEEL_RADIUS * abs(height))
        return height * raised_cosine_step((x - at) / length + 0.5)
    length = 0.3 + 4.0 * abs(height)
    u = (x - at) / length
    return np.where((u > 0) & (u < 1), height * np.sin(np.pi * u) ** 2, 0.0)


class Plan:
    """A programme under construction: a cursor ``t`` (s) with the planned speed ``v`` (m/s) there."""

    def __init__(self) -> None:
        self.t = 0.0
        self.v = 0.0
        self._a = 0.0
        self._steps: list[tuple[float, float, float]] = []
        self._lobes: list[tuple[float, float, float]] = []
        self.cruises: list[tuple[float, float, float]] = []
        """Constant-speed stretches ``(start, end, speed)``, free for turns."""
        self.events: list[Span] = []

    def _accel_to(self, a: float, ramp: float) -> None:
        self._steps.append((self.t, a - self._a, ramp))
        self._a = a

    def wait(self, duration: float) -> None:
        """Hold the current speed (standing or cruising) for ``duration`` s."""
        if duration > 0 and self.v > 0:
            self.cruises.append((self.t, self.t + duration, self.v))
        self.t += max(duration, 0.0)

    def brake(self, levels: list[tuple[float, float]], ramps: list[float]) -> tuple[float, float]:
        """Decelerate through plateaus ``(decel m/s^2, speed drop m/s)``; ``ramps`` (s) has one more entry.

        Each switch is a raised-cosine ramp no longer than the plateaus it joins. Returns the (start, end) of the
        manoeuvre including its ramps.
        """
        durations = [dv / d for d, dv in levels] + [np.inf]
        widths = [min(w, durations[i], durations[i - 1] if i else np.inf) for i, w in enumerate(ramps)]
        start = self.t - widths[0] / 2
        for (decel, _), width, duration in zip(levels, widths, durations):
            self._accel_to(-decel, width)
            self.t += duration
        self._accel_to(0.0, widths[-1])
        self.v = max(0.0, self.v - sum(dv for _, dv in levels))
        return start, self.t + widths[-1] / 2

    def change_speed(self, target: float, accel: float, ramp: float) -> tuple[float, float]:
        """Reach ``target`` m/s at ``|accel|`` m/s^2 with ramps of ``ramp`` s; returns (start, end)."""
        dv = target - self.v
        if dv < 0:
            return self.brake([(abs(accel), -dv)], [ramp, ramp])
        duration = dv / abs(accel)
        width = min(ramp, duration)
        start = self.t - width / 2
        self._accel_to(abs(accel), width)
        self.t += duration
        self._accel_to(0.0, width)
        self.v = target
        return start, self.t + width / 2

    def turn(self, start: float, duration: float, peak: float) -> None:
        """A ``sin^2`` yaw-rate lobe of ``peak`` rad/s (positive left) from ``start`` over ``duration`` s."""
        self._lobes.append((start, duration, peak))

    def event(self, start: float, end: float, name: str) -> None:
        self.events.append(Span(start, end, name))

    def programme(self, rate: float, rng: np.random.Generator) -> Programme:
        """Sample the plan at ``rate`` Hz, adding the rider's postural sway and steering wander."""
        n = int(np.ceil(self.t * rate)) + 1
        time = np.arange(n) / rate
        accel = np.zeros(n)
        for centre, jump, width in self._steps:
            i0 = int(np.clip(np.ceil((centre - width / 2) * rate), 0, n))
            i1 = int(np.clip(np.ceil((centre + width / 2) * rate), 0, n))
            accel[i0:i1] += jump * raised_cosine_step((time[i0:i1] - centre) / width + 0.5)
            accel[i1:] += jump
        speed = cumulative_trapezoid(accel, time, initial=0.0)
        yaw = np.zeros(n)
        for start, duration, peak in self._lobes:
            i0, i1 = int(np.ceil(start * rate)), int(np.floor((start + duration) * rate)) + 1
            yaw[i0:i1] += peak * np.sin(np.pi * (time[i0:i1] - start) / duration) ** 2
        moving = np.clip(speed / 1.5, 0.0, 1.0)
        yaw += moving * _slow_noise(rng, n, 0.3, rate, 0.015)
        wobble = raised_cosine_step(time / 2.0) * _slow_noise(rng, n, 0.5, rate, 0.015)  # fades in from rest
        return Programme(time, accel, np.gradient(wobble, time), yaw, speed, events=list(self.events))


# ---------------------------------------------------------------------------------------------------------------
# Legs: one repetition of a manoeuvre, varied around the rider's habits.


def _cruise_speed(rider: Rider, rng: np.random.Generator) -> float:
    return float(min(rider.cruise_speed * rng.uniform(0.92, 1.05), 0.97 * MAX_SPEED))


def accelerate(plan: Plan, rider: Rider, rng: np.random.Generator, target: float,
               brisk: float = 1.0) -> tuple[float, float]:
    """Lean forward to reach ``target`` m/s (``brisk`` scales the rider's habitual acceleration)."""
    return plan.change_speed(target, brisk * rider.accel * rng.uniform(0.8, 1.2), rng.uniform(0.6, 1.2))


def normal_stop(plan: Plan, rider: Rider, rng: np.random.Generator, near_sudden: bool = False,
                to_speed: float = 0.0, gentle: float = 1.0) -> tuple[float, float]:
    """Planned braking to ``to_speed`` m/s: one plateau, or a firmer then a softer one.

    ``gentle`` scales the rider's habitual deceleration (kept within 0.6-1.7 m/s^2). ``near_sudden``:
    1.72-1.84 m/s^2 with a quick lean-in, close to (but below) sudden braking.
    """
    drop = plan.v - to_speed
    if near_sudden:
        span = plan.brake([(rng.uniform(1.72, 1.84), drop)], [rng.uniform(0.3, 0.4), rng.uniform(0.35, 0.5)])
        plan.event(*span, "near-sudden")
        return span
    decel = float(np.clip(gentle * rider.normal_decel * np.exp(rng.normal(0.0, 0.18)), 0.6, 1.7))
    ramp_in, ramp_out = rider.normal_ramp * rng.uniform(0.75, 1.3), rng.uniform(0.5, 1.0)
    if rng.random() < 0.35:
        levels = [(min(1.2 * decel, 1.75), 0.5 * drop), (max(0.8 * decel, 0.6), 0.5 * drop)]
        return plan.brake(levels, [ramp_in, rng.uniform(0.4, 0.8), ramp_out])
    return plan.brake([(decel, drop)], [ramp_in, ramp_out])


def sudden_stop(plan: Plan, rider: Rider, rng: np.random.Generator) -> tuple[float, float]:
    """An emergency stop: a short normal lean-in, the hard plateau, and a normal easing-off before standstill."""
    v = plan.v
    pre = (rng.uniform(0.7, 1.3), v * rng.uniform(0.04, 0.12))
    post = (rng.uniform(0.8, 1.4), v * rng.uniform(0.10, 0.20))
    hard = (float(np.clip(rider.sudden_decel * np.exp(rng.normal(0.0, 0.08)), 2.4, 3.5)), v - pre[1] - post[1])
    ramps = [rng.uniform(0.15, 0.3), rider.sudden_ramp * rng.uniform(0.8, 1.2), rng.uniform(0.25, 0.45),
             rng.uniform(0.35, 0.6)]
    return plan.brake([pre, hard, post], ramps)


def speed_change(plan: Plan, rider: Rider, rng: np.random.Generator) -> None:
    """A gentle speed change and back: 2-4 s each way at 0.15-0.35 m/s^2 (below braking), at most about 13 s in all.

    The ``speed-change`` confounder.
    """
    v0 = plan.v
    rate = rng.uniform(0.15, 0.35)
    step = rate * rng.uniform(2.0, 4.0)
    up = v0 + step < 0.95 * MAX_SPEED and rng.random() < 0.4
    start, _ = plan.change_speed(v0 + step if up else max(v0 - step, 0.5 * v0), rate, 1.0)
    plan.wait(rng.uniform(1.0, 3.0))
    _, end = plan.change_speed(v0, rate * rng.uniform(0.8, 1.25), 1.0)
    plan.event(start, end, "speed-change")


def crossing_stop(plan: Plan, rider: Rider, rng: np.random.Generator, near_sudden: bool = False) -> None:
    """Stop at a crossing, wait 2-6 s, ride on: the ``crossing-stop`` confounder (normal braking by physics)."""
    v0 = plan.v
    start, _ = normal_stop(plan, rider, rng, near_sudden)
    plan.wait(rng.uniform(2.0, 6.0))
    _, end = accelerate(plan, rider, rng, v0)
    plan.event(start, end, "crossing-stop")


def crossing_time(rider: Rider, speed: float) -> float:
    """Room (s) a crossing stop from ``speed`` needs in a cruise: braking, waiting, re-accelerating, margins."""
    return speed / rider.normal_decel + 4.0 + speed / rider.accel + 5.0


def cruise(plan: Plan, rider: Rider, rng: np.random.Generator, duration: float, change: float = 0.0,
           stop: float = 0.0, near_sudden: bool = False) -> None:
    """Cruise for about ``duration`` s; with probability ``stop`` a crossing stop (always when ``near_sudden``, which
    makes it close to sudden) and with probability ``change`` a speed change, each only where it fits."""
    end = plan.t + duration
    if (near_sudden or rng.random() < stop) and duration >= crossing_time(rider, plan.v):
        plan.wait(rng.uniform(1.5, 3.0))
        crossing_stop(plan, rider, rng, near_sudden)
    if rng.random() < change and end - plan.t >= 15.0:
        plan.wait(rng.uniform(1.0, 3.0))
        speed_change(plan, rider, rng)
    plan.wait(max(end - plan.t, 1.0))


def add_turns(plan: Plan, vehicle: Vehicle, rng: np.random.Generator, probability: float, at_least: int = 0) -> None:
    """Gentle turns (peak 0.15-0.35 rad/s, 2.5-5 s) in the plan's free cruising stretches: the ``turn`` confounder."""
    windows = [w for w in plan.cruises if w[1] - w[0] >= 4.0]
    for rank, i in enumerate(rng.permutation(len(windows))):
        if rank >= at_least and rng.random() >= probability:
            continue
        start, end, v = windows[i]
        duration = rng.uniform(2.5, min(5.0, end - start - 1.0))
        peak = min(rng.uniform(0.15, 0.35), LATERAL_LIMIT / v, 0.9 * vehicle.max_yaw_rate(v))
        t0 = rng.uniform(start + 0.5, end - duration - 0.5)
        plan.turn(t0, duration, rng.choice([-1.0, 1.0]) * peak)
        plan.event(t0, t0 + duration, "turn")


# ---------------------------------------------------------------------------------------------------------------
# Scenario plans. Each takes the rider, the vehicle, a generator, the experiment's target share of its declared
# manoeuvre, whether one normal stop comes close to sudden, and the internal rate; it returns the Programme.


def _split(total: float, parts: int, rng: np.random.Generator, least: float) -> np.ndarray:
    """``parts`` random durations of at least ``least`` s summing to about ``max(total, parts * least)``."""
    spare = max(total - parts * least, 0.0)
    return least + spare * rng.dirichlet(np.ones(parts))


def _finish(plan: Plan, rng: np.random.Generator, rate: float, strikes: tuple[int, int],
            patches: float | None = None, surfaces: tuple[str, ...] = SURFACES[1:]) -> Programme:
    """Sample the plan, then place kerbs and bumps (``strikes``: low, high count) and rough patches (``patches`` s
    in total; by default none or one of 4-10 s) of the ``surfaces`` (none: no patch)."""
    programme = plan.programme(rate, rng)
    programme.add_strikes(rng, int(rng.integers(*strikes)), ("kerb", "bump"))
    if patches is None:
        patches = float(rng.choice([0.0, rng.uniform(4.0, 10.0)]))
    if surfaces:
        programme.add_patches(rng, patches, surfaces)
    return programme


def normal_braking(rider, vehicle, rng, share, near_sudden, rate) -> Programme:
    """Cruising and normal braking alternate.

    Up to a share of 0.3 the rider stops fully each time; beyond, braking dominates the ride: long gentle slow-downs
    to 35-60 % of the cruising speed, each followed at once by a brisk re-acceleration. As many repetitions as the
    share asks for and the ride's length allows.
    """
    plan = Plan()
    duration = rng.uniform(58.0, 72.0)
    v = _cruise_speed(rider, rng)
    partial = share > 0.3
    gentle, brisk, drop, dwell = (0.6, 1.4, 0.5 * v, 0.4) if partial else (1.0, 1.0, v, 2.0)
    decel = max(gentle * rider.normal_decel, 0.65)
    braking, climb = drop / decel, drop / (brisk * rider.accel)
    cycle = braking + climb + dwell + 0.5 + 1.5  # + the ramps' half-widths
    room = int((duration - v / rider.accel - v / rider.normal_decel) / cycle)
    stops = int(np.clip(np.round(share * duration / braking), 1, max(1, min(room, 12 if partial else 7))))
    other = v / rider.accel + (stops - 1) * climb + stops * dwell + 2.0
    cruises = _split(duration * (1.0 - share) - other, stops, rng, 0.5)
    hard = int(rng.integers(stops)) if near_sudden else -1
    plan.wait(rng.uniform(1.0, 3.0))
    for i, length in enumerate(cruises):
        accelerate(plan, rider, rng, _cruise_speed(rider, rng), brisk=1.0 if plan.v == 0 else brisk)
        cruise(plan, rider, rng, length, change=0.5)
        if partial and i != stops - 1 and i != hard:
            normal_stop(plan, rider, rng, to_speed=plan.v * rng.uniform(0.35, 0.6), gentle=gentle)
            plan.wait(rng.uniform(0.2, 0.6))
        else:
            normal_stop(plan, rider, rng, near_sudden=i == hard, gentle=gentle)
            plan.wait(rng.uniform(1.0, 3.0))
    add_turns(plan, vehicle, rng, 0.35, at_least=1)
    return _finish(plan, rng, rate, strikes=(1, 4))


def sudden_braking(rider, vehicle, rng, share, near_sudden, rate) -> Programme:
    """Accelerate, cruise, stop hard, several times (the paper: seven), with a crossing stop and turns between.

    As many emergency stops as the share asks for and the ride's length allows (3 to 7).
    """
    plan = Plan()
    duration = rng.uniform(60.0, 75.0)
    v = _cruise_speed(rider, rng)
    hard_time = 0.75 * v / rider.sudden_decel
    crossing = near_sudden or rng.random() < 0.5
    extra = crossing_time(rider, 0.97 * MAX_SPEED) if crossing else 0.0
    cycle = v / rider.accel + v / rider.sudden_decel + 1.75 + 1.5
    room = (duration - 2.0 - extra) / cycle
    stops = int(np.clip(np.round(share * duration / hard_time), 3, max(3, min(7, int(room)))))
    cruises = _split(duration - 2.0 - stops * (cycle - 1.5) - extra, stops, rng, 1.5)
    cruises[int(rng.integers(stops))] += extra
    plan.wait(rng.uniform(1.0, 2.5))
    for length in cruises:
        accelerate(plan, rider, rng, _cruise_speed(rider, rng))
        long = length >= crossing_time(rider, plan.v)
        cruise(plan, rider, rng, length, change=0.4, stop=1.0 if crossing and long else 0.0,
               near_sudden=near_sudden and long)
        crossing, near_sudden = crossing and not long, near_sudden and not long
        sudden_stop(plan, rider, rng)
        plan.wait(rng.uniform(1.0, 2.5))
    add_turns(plan, vehicle, rng, 0.3, at_least=1)
    return _finish(plan, rng, rate, strikes=(1, 4))


def cruising(rider, vehicle, rng, share, near_sudden, rate, length: float = 40.0) -> Programme:
    """The paper's 40 s ride: accelerate, cruise (turns, a bump, maybe a crossing), stop with normal braking."""
    plan = Plan()
    plan.wait(rng.uniform(1.0, 2.5))
    v = _cruise_speed(rider, rng)
    accelerate(plan, rider, rng, v)
    stop_time = v / rider.normal_decel + 1.5
    stand = rng.uniform(1.0, 2.5)
    cruise(plan, rider, rng, length - plan.t - stop_time - stand, change=0.5, stop=0.5)
    normal_stop(plan, rider, rng, near_sudden)
    plan.wait(max(length - plan.t, 1.0))
    add_turns(plan, vehicle, rng, 0.6, at_least=1)
    return _finish(plan, rng, rate, strikes=(1, 3), patches=0.0)


def _turn_speed(vehicle: Vehicle, peak: float, cruise_speed: float) -> float:
    """Fastest speed (m/s) for a yaw rate ``peak`` (rad/s) within the lateral limit and 90 % of the steering range.

    ``0.9 G_0 phi_max / (1 + v / v_f) >= peak``  gives  ``v <= v_f (0.9 G_0 phi_max / peak - 1)``.
    """
    steer = vehicle.steer_fade_speed * (0.9 * vehicle.steer_gain * vehicle.max_steer / abs(peak) - 1.0)
    return float(np.clip(min(LATERAL_LIMIT / abs(peak), steer), 0.8, cruise_speed))


class _Lateral(NamedTuple):
    lobes: int
    length: float
    """s per lobe"""
    peak: float
    """rad/s"""
    speed: float
    """m/s through the manoeuvre"""


def _draw_lateral(kind: str, vehicle: Vehicle, rng: np.random.Generator, v: float) -> _Lateral:
    """A gentle turn (0.15-0.38 rad/s, 3-7 s), a sharp turn (0.55-1 rad/s, 2.5-4.5 s, slowing down first) or a
    slalom (4-8 alternating lobes of 0.3-0.6 rad/s, 1.1-2 s each), at cruising speed ``v`` (m/s)."""
    if kind == "gentle":
        peak = min(rng.uniform(0.15, 0.38), LATERAL_LIMIT / v, 0.9 * vehicle.max_yaw_rate(v))
        return _Lateral(1, rng.uniform(3.0, 7.0), peak, v)
    if kind == "sharp":
        peak = rng.uniform(0.55, 1.0)
        return _Lateral(1, rng.uniform(2.5, 4.5), peak, _turn_speed(vehicle, peak, v))
    peak = rng.uniform(0.3, 0.6)
    return _Lateral(int(rng.integers(4, 9)), rng.uniform(1.1, 2.0), peak, _turn_speed(vehicle, peak, v))


def lateral(rider, vehicle, rng, share, near_sudden, rate, kinds: tuple[str, ...] = LATERAL_KINDS) -> Programme:
    """Straight riding with gentle turns, sharp turns (slowing down first) and slaloms.

    Manoeuvres are drawn until their turning time reaches the share, as long as their time with the slowing down
    and speeding up around them fits in the ride; high shares favour slaloms over sharp turns. ``kinds``: the
    kinds of :data:`LATERAL_KINDS` drawn (their odds renormalised; all of them draw as before); none: a straight
    ride.
    """
    plan = Plan()
    duration = rng.uniform(58.0, 72.0)
    v = max(_cruise_speed(rider, rng) * (1.0 - 0.8 * share), 2.5)  # a course dense with turns is ridden slower
    fixed = v / rider.accel + v / rider.normal_decel + 8.0
    odds = np.array([0.45, 0.3, 0.25] if share < 0.3 else [0.45, 0.15, 0.4])  # sharp turns cost slowing down
    drawn = [k in kinds for k in LATERAL_KINDS]
    need, manoeuvres, busy, cost = share * duration, [], 0.0, 0.0
    for _ in range(30 if any(drawn) else 0):
        if busy >= need and manoeuvres:
            break
        kind = rng.choice(np.array(LATERAL_KINDS)[drawn], p=odds[drawn] / odds[drawn].sum())
        m = _draw_lateral(str(kind), vehicle, rng, v)
        turning = m.lobes * m.length * (1.0 if m.lobes > 1 else 0.65)  # a lone lobe is straight at its ends
        extra = m.lobes * m.length + (2.0 * (v - m.speed) / 0.6 + 1.5 if m.speed < v - 0.1 else 0.0)
        if busy + turning > max(1.3 * need, 4.0) or cost + extra + 2.0 * (len(manoeuvres) + 2) > duration - fixed:
            continue
        manoeuvres.append(m)
        busy += turning
        cost += extra
    if not manoeuvres and any(drawn):
        manoeuvres.append(_draw_lateral(LATERAL_KINDS[drawn.index(True)], vehicle, rng, v))
        cost = manoeuvres[0].lobes * manoeuvres[0].length
    gaps = _split(duration - fixed - cost, len(manoeuvres) + 1, rng, 2.0)
    stop_gap = int(np.argmax(gaps)) if rng.random() < 0.5 else -1
    plan.wait(rng.uniform(1.0, 2.5))
    accelerate(plan, rider, rng, v)
    for i, m in enumerate(manoeuvres):
        cruise(plan, rider, rng, gaps[i], change=0.3, stop=1.0 if i == stop_gap else 0.0)
        if m.speed < plan.v - 0.1:
            start, end = plan.change_speed(m.speed, rng.uniform(0.4, 0.8), 0.6)
            plan.event(start, end, "speed-change")
            plan.wait(0.5)
        side = rng.choice([-1.0, 1.0])
        for k in range(m.lobes):
            plan.turn(plan.t + k * m.length, m.length, side * (-1.0) ** k * m.peak)
        plan.wait(m.lobes * m.length + 0.5)
        if plan.v < v - 0.1:
            start, end = accelerate(plan, rider, rng, v)
            plan.event(start, end, "speed-change")
    cruise(plan, rider, rng, gaps[-1], change=0.3)
    start, end = normal_stop(plan, rider, rng, near_sudden)
    plan.event(start, end, "braking")
    plan.wait(rng.uniform(1.0, 2.5))
    return _finish(plan, rng, rate, strikes=(1, 4))


def road(rider, vehicle, rng, share, near_sudden, rate, kinds: tuple[str, ...] = ROAD_KINDS) -> Programme:
    """A ride over smooth asphalt with patches of rough asphalt and cobblestone, and kerbs and bumps. ``kinds``: the
    kinds of :data:`ROAD_KINDS` the ride holds (all of them: as before; without ``kerb``, no kerb or bump)."""
    plan = Plan()
    duration = rng.uniform(58.0, 72.0)
    v = _cruise_speed(rider, rng)
    plan.wait(rng.uniform(1.0, 2.5))
    accelerate(plan, rider, rng, v)
    legs = _split(duration - plan.t - v / rider.normal_decel - 3.0, 2, rng, 8.0)
    cruise(plan, rider, rng, legs[0], change=0.6, stop=0.5)
    cruise(plan, rider, rng, legs[1], change=0.6)
    start, end = normal_stop(plan, rider, rng, near_sudden)
    plan.event(start, end, "braking")
    plan.wait(rng.uniform(1.0, 2.5))
    add_turns(plan, vehicle, rng, 0.5, at_least=1)
    return _finish(plan, rng, rate, strikes=(3, 7) if "kerb" in kinds else (0, 1), patches=0.95 * share * duration,
                   surfaces=tuple(s for s in SURFACES[1:] if s in kinds))


PLANS: dict[str, Callable[..., Programme]] = {
    "normal-braking": normal_braking,
    "sudden-braking": sudden_braking,
    "cruising": cruising,
    "lateral": lateral,
    "road": road,
}
"""Scenario name -> plan builder ``(rider, vehicle, rng, share, near_sudden, rate) -> Programme``."""
