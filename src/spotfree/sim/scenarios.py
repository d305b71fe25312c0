"""The five simulated scenarios, their ground-truth labels, and the Recording they make.

``simulate_scenario(scenario, repeats, seed, rate)`` returns ``repeats`` separate experiments (rides) in one
:class:`~spotfree.io.recording.Recording`: ``experiment`` numbers them 1..repeats and ``time`` restarts at 0 s in
each (the nominal grid ``k / rate``; the sensor itself sampled at ``k / rate`` plus a few ms of jitter). Channels:
``ax ay az`` (m/s^2) and ``gx gy gz`` (rad/s) in the Android device frame, ``lat lon`` (degrees) and ``speed``
(m/s) from GPS, only on the samples where a 1 Hz fix arrives. Truth: ``label`` (the scenario's classes) and
``event`` (confounders, ``+``-joined when several overlap, empty otherwise).

Labels come from the simulated physics, not from the plan:

* braking scenarios: ``g tan(alpha)``, the deceleration the rider's lean asks for (after the balance response,
  postural sway excluded), is ``sudden-braking`` from :data:`SUDDEN_BRAKING`, ``normal-braking`` from
  :data:`NORMAL_BRAKING`, else ``cruising`` (standing, accelerating, cruising, turning). A sudden stop therefore
  passes through normal braking as the lean builds up and as it eases off.
* lateral: a turn is a run of yaw rate beyond :data:`STRAIGHT` of one sign; it is ``sharp-turn`` when its peak
  reaches :data:`SHARP`, else ``gentle-turn``; ``slalom`` is a chain of at least :data:`SLALOM_LOBES` turns of
  alternating sign, each shorter than :data:`SLALOM_LOBE` s and less than :data:`SLALOM_GAP` s apart.
* road: the surface under the wheels; ``kerb`` while the vertical acceleration caused by a kerb or bump alone
  exceeds :data:`STRIKE`.

Each experiment draws its own rider, vehicle set-up, programme, road, sensor errors and GPS errors from
``numpy.random.SeedSequence([seed, scenario, experiment, stream])``; the same seed gives the same file.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import numpy as np
from scipy.ndimage import maximum_filter1d

from spotfree.errors import InputError
from spotfree.io.checks import true_runs
from spotfree.io.recording import Recording
from spotfree.sim.gps import GpsSpec, gps_fixes
from spotfree.sim.imu import ImuSpec, read_imu
from spotfree.sim.manoeuvres import LATERAL_KINDS, PLANS, ROAD_KINDS, SURFACES, Programme, draw_rider
from spotfree.sim.vehicle import Motion, balance_response, draw_vehicle, simulate_motion

SCENARIOS = ("normal-braking", "sudden-braking", "cruising", "lateral", "road")
CLASSES = {
    "normal-braking": ("cruising", "normal-braking"),
    "sudden-braking": ("cruising", "normal-braking", "sudden-braking"),
    "cruising": ("cruising", "normal-braking"),
    "lateral": ("straight", "gentle-turn", "sharp-turn", "slalom"),
    "road": ("smooth", "rough-asphalt", "cobblestone", "kerb"),
}
"""The label classes of each scenario."""
MANOEUVRE_CLASSES = {
    "normal-braking": ("normal-braking",),
    "sudden-braking": ("sudden-braking",),
    "cruising": ("normal-braking",),
    "lateral": ("gentle-turn", "sharp-turn", "slalom"),
    "road": ("rough-asphalt", "cobblestone", "kerb"),
}
"""The classes of the scenario's declared manoeuvre (what :func:`manoeuvre_share` counts)."""
SHARE_RANGE = {
    "normal-braking": (0.04, 0.5),
    "sudden-braking": (0.03, 0.15),
    "cruising": (0.0, 0.0),
    "lateral": (0.05, 0.5),
    "road": (0.05, 0.5),
}
"""Targets for the manoeuvre's share of an experiment, spread over the experiments of a file."""

NORMAL_BRAKING = 0.5
"""m/s^2 of lean deceleration (lean back 2.9 deg) from which the ride is braking."""
SUDDEN_BRAKING = 2.0
"""m/s^2 of lean deceleration (lean back 11.5 deg) from which braking is sudden."""
STRAIGHT = 0.10
"""rad/s: below this yaw rate the ride is straight."""
SHARP = 0.45
"""rad/s: peak yaw rate of a sharp turn."""
SLALOM_LOBES, SLALOM_LOBE, SLALOM_GAP = 3, 2.5, 0.8
STRIKE = 1.0
"""m/s^2 of vertical platform acceleration from a kerb or bump alone."""
NEAR_SUDDEN_EXPERIMENT = 5
"""The experiment (or the last, if fewer) with one normal stop close to sudden, like the paper's fifth."""
STREAMS = ("share", "rider", "programme", "road", "vehicle", "imu", "gps")
CHANNELS = ("ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed")


@dataclass
class SimulatedRide:
    """One experiment on the output grid, with the kinematic truth the Recording does not carry."""

    time: np.ndarray
    channels: dict[str, np.ndarray]
    label: np.ndarray
    event: np.ndarray
    truth: dict[str, np.ndarray]
    """``pitch``, ``roll`` (rad), ``pitch_rate``, ``yaw_rate`` (rad/s), ``speed`` (m/s), ``accel`` (tangential)
    and ``lean_accel`` (the lean's ``g tan(alpha)``), m/s^2, at the nominal sample times."""
    params: dict


def braking_labels(lean_accel: np.ndarray) -> np.ndarray:
    """``cruising`` / ``normal-braking`` / ``sudden-braking`` from the lean's ``g tan(alpha)`` (m/s^2)."""
    decel = -np.asarray(lean_accel)
    return np.where(decel >= SUDDEN_BRAKING, "sudden-braking",
                    np.where(decel >= NORMAL_BRAKING, "normal-braking", "cruising"))


def lateral_labels(yaw_rate: np.ndarray, fs: float) -> np.ndarray:
    """``straight`` / ``gentle-turn`` / ``sharp-turn`` / ``slalom`` from the yaw rate (rad/s) sampled at ``fs``."""
    labels = np.full(len(yaw_rate), "straight", dtype=object)
    lobes = []
    for sign in (1.0, -1.0):
        for i0, i1 in true_runs(sign * yaw_rate >= STRAIGHT):
            peak = float(np.max(np.abs(yaw_rate[i0:i1])))
            labels[i0:i1] = "sharp-turn" if peak >= SHARP else "gentle-turn"
            lobes.append((i0, i1, sign))
    lobes.sort()
    chain: list[tuple[int, int, float]] = []
    for lobe in lobes + [(len(yaw_rate) + 10 * int(SLALOM_GAP * fs), 0, 0.0)]:
        short = lobe[1] - lobe[0] <= SLALOM_LOBE * fs
        if chain and short and lobe[2] == -chain[-1][2] and lobe[0] - chain[-1][1] <= SLALOM_GAP * fs:
            chain.append(lobe)
            continue
        if len(chain) >= SLALOM_LOBES:
            labels[chain[0][0] : chain[-1][1]] = "slalom"
        chain = [lobe] if short else []
    return labels.astype(str)


def manoeuvre_share(labels: np.ndarray, scenario: str) -> float:
    """Fraction of samples labelled with the scenario's declared manoeuvre (:data:`MANOEUVRE_CLASSES`)."""
    return float(np.isin(labels, MANOEUVRE_CLASSES[scenario]).mean()) if len(labels) else 0.0


def _rng(seed: int, scenario: str, experiment: int, stream: str) -> np.random.Generator:
    return np.random.default_rng(
        np.random.SeedSequence([seed, SCENARIOS.index(scenario), experiment, STREAMS.index(stream)])
    )


def _share_target(scenario: str, experiment: int, repeats: int, seed: int) -> float:
    """Stratified over the file: experiment k gets one of ``repeats`` equal slices of :data:`SHARE_RANGE`."""
    lo, hi = SHARE_RANGE[scenario]
    rng = _rng(seed, scenario, 0, "share")
    slot, jitter = rng.permutation(repeats)[experiment - 1], rng.uniform(size=repeats)[experiment - 1]
    return float(lo + (hi - lo) * (slot + jitter) / repeats)


KINDS = {"lateral": LATERAL_KINDS, "road": ROAD_KINDS}
"""The scenarios whose rides can be asked to hold only some kinds of manoeuvre or road event (``manoeuvres``)."""


def _validate(scenario: str, repeats: int, seed: int, rate: float, manoeuvres: tuple[str, ...] | None = None) -> None:
    if scenario not in SCENARIOS:
        raise InputError(f"simulate: unknown scenario '{scenario}'; choose one of {', '.join(SCENARIOS)}")
    if manoeuvres is not None:
        if scenario not in KINDS:
            raise InputError(f"simulate: --manoeuvres chooses what a {' or '.join(KINDS)} ride holds; scenario "
                             f"'{scenario}' has no such choice")
        unknown = sorted(set(manoeuvres) - set(KINDS[scenario]))
        if unknown:
            raise InputError(f"simulate: unknown {scenario} manoeuvre(s) {', '.join(unknown)}; choose from "
                             f"{', '.join(KINDS[scenario])}, or none")
    if isinstance(repeats, bool) or not isinstance(repeats, (int, np.integer)) or repeats < 1:
        raise InputError(f"simulate: --repeats must be a whole number of at least 1, got {repeats!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"simulate: --seed must be a non-negative whole number, got {seed!r}")
    if not 1.0 <= float(rate) <= 1000.0:
        raise InputError(f"simulate: --rate must be between 1 and 1000 Hz, got {rate!r}")


def _span_mask(time: np.ndarray, start: float, end: float) -> np.ndarray:
    return (time >= start) & (time < end)


def _any_in_cell(mask: np.ndarray, index: np.ndarray, half: int) -> np.ndarray:
    """Whether ``mask`` holds anywhere within ``half`` internal samples of each output ``index``."""
    counts = np.concatenate([[0], np.cumsum(mask)])
    lo = np.clip(index - half, 0, len(mask))
    hi = np.clip(index + half + 1, 0, len(mask))
    return counts[hi] - counts[lo] > 0


def _join(names: list[tuple[str, np.ndarray]], n: int) -> np.ndarray:
    """Per sample, the ``+``-joined sorted names whose mask holds ('' when none)."""
    out = np.full(n, "", dtype=object)
    for name, mask in sorted(names, key=lambda item: item[0]):
        out[mask] = np.where(out[mask] == "", name, out[mask] + "+" + name)
    return out.astype(str)


def _truth_labels(scenario: str, motion: Motion, lean_plan: np.ndarray, fs: float) -> np.ndarray:
    """The scenario's label at every internal sample (kerb strikes are laid over by :func:`_ground_truth`)."""
    if scenario == "lateral":
        return lateral_labels(motion.yaw_rate, fs)
    if scenario == "road":
        return np.asarray(SURFACES, dtype=str)[motion.surface]
    return braking_labels(lean_plan)


def _ground_truth(scenario: str, programme: Programme, motion: Motion, lean_plan: np.ndarray, fs: float,
                  index: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """``label`` and ``event`` on the output grid: internal samples ``index``, cells of ``half`` samples each side.

    Kerbs and bumps count where their own response exceeds :data:`STRIKE` anywhere in an output sample's cell, so
    a short strike is never missed between two output samples.
    """
    labels = _truth_labels(scenario, motion, lean_plan, fs)[index]
    events = [(span.name, _span_mask(programme.time, span.start, span.end)[index]) for span in programme.events]
    strike_window = maximum_filter1d(np.abs(motion.strike_accel), int(0.05 * fs) + 1) >= STRIKE
    strikes = []
    for strike in programme.strikes:
        near = _span_mask(programme.time, strike.time - 0.2, strike.time + 1.5)
        strikes.append((strike.kind, _any_in_cell(strike_window & near, index, half)))
    if scenario == "road":
        if strikes:
            labels = np.where(np.any([mask for _, mask in strikes], axis=0), "kerb", labels)
    else:
        surface = np.asarray(SURFACES)[motion.surface][index]
        events += strikes + [(name, surface == name) for name in SURFACES[1:]]
    return np.asarray(labels, dtype=str), _join(events, len(index))


def simulate_ride(scenario: str, experiment: int = 1, *, repeats: int = 7, seed: int = 0,
                  rate: float = 20.0, habits: dict[str, float] | None = None,
                  manoeuvres: tuple[str, ...] | None = None) -> SimulatedRide:
    """Experiment ``experiment`` (1..repeats) of ``scenario`` at ``rate`` Hz, with its kinematic truth.

    ``habits`` multiplies the drawn rider's habits by factors, e.g. ``{"cruise_speed": 0.9}`` (fields of
    :class:`~spotfree.sim.manoeuvres.Rider` other than ``body``); the other draws are unchanged.
    ``manoeuvres`` (lateral and road only, :data:`KINDS`): the kinds of manoeuvre or road event the ride holds,
    none for a straight ride on smooth asphalt; None: all of them.
    """
    _validate(scenario, repeats, seed, rate, manoeuvres)
    if isinstance(experiment, bool) or not isinstance(experiment, (int, np.integer)) or not 1 <= experiment <= repeats:
        raise InputError(f"simulate: experiment must be a whole number from 1 to {repeats}, got {experiment!r}")
    fs = max(200.0, 10.0 * rate)
    rider_rng = _rng(seed, scenario, experiment, "rider")
    rider, vehicle = draw_rider(rider_rng), draw_vehicle(rider_rng)
    if habits:
        unknown = sorted(set(habits) - {f.name for f in fields(rider)} | ({"body"} & set(habits)))
        if unknown:
            raise InputError(f"simulate: habits {', '.join(unknown)} are not rider habits; use "
                             f"{', '.join(f.name for f in fields(rider) if f.name != 'body')}")
        rider = replace(rider, **{k: getattr(rider, k) * float(f) for k, f in habits.items()})
    heading0 = rider_rng.uniform(0.0, 2.0 * np.pi)
    share = _share_target(scenario, experiment, repeats, seed)
    near_sudden = experiment == min(NEAR_SUDDEN_EXPERIMENT, repeats)
    kinds = {} if manoeuvres is None else {"kinds": tuple(manoeuvres)}
    programme = PLANS[scenario](rider, vehicle, _rng(seed, scenario, experiment, "programme"), share, near_sudden, fs,
                                **kinds)
    road_rng = _rng(seed, scenario, experiment, "road")
    motion = simulate_motion(programme.time, programme.accel + programme.sway, programme.yaw_rate, rider.body,
                             vehicle, lambda distance: programme.road(distance, road_rng),
                             _rng(seed, scenario, experiment, "vehicle"), heading0)
    lean_plan = balance_response(programme.accel, rider.body, fs)
    n_out = int(np.floor(programme.duration * rate + 1e-9)) + 1
    index = np.minimum(np.rint(np.arange(n_out) * fs / rate).astype(int), len(programme.time) - 1)
    labels, events = _ground_truth(scenario, programme, motion, lean_plan, fs, index, int(fs / (2.0 * rate)))

    imu = read_imu(programme.time, motion.specific_force, motion.angular_rate, rate, n_out,
                   _rng(seed, scenario, experiment, "imu"))
    lat, lon, gps_speed = gps_fixes(programme.time, motion.east, motion.north, motion.speed, rate, n_out,
                                    _rng(seed, scenario, experiment, "gps"))
    channels = dict(zip(CHANNELS[:6], np.column_stack([imu.acc, imu.gyro]).T))
    channels.update(lat=lat, lon=lon, speed=gps_speed)
    truth = {
        "pitch": motion.pitch, "roll": motion.roll, "pitch_rate": motion.pitch_rate,
        "yaw_rate": motion.yaw_rate, "speed": motion.speed, "accel": motion.accel, "lean_accel": lean_plan,
    }
    params = {
        "experiment": experiment,
        "duration_s": round(n_out / rate, 3),
        "share_target": round(share, 4) if scenario != "cruising" else None,
        "share": round(manoeuvre_share(labels, scenario), 4),
        "near_sudden_stop": near_sudden,
        "rider": asdict(rider),
        "vehicle": asdict(vehicle),
        "heading0_deg": float(np.rad2deg(heading0)),
        "misalignment_deg": np.rad2deg(imu.misalignment).tolist(),
        "acc_bias": imu.acc_bias.tolist(),
        "gyro_bias": imu.gyro_bias.tolist(),
    }
    return SimulatedRide(
        time=np.arange(n_out) / rate,
        channels=channels,
        label=labels,
        event=events,
        truth={k: v[index] for k, v in truth.items()},
        params=params,
    )


def simulate_scenario(scenario: str, repeats: int = 7, seed: int = 0, rate: float = 20.0,
                      manoeuvres: tuple[str, ...] | None = None) -> Recording:
    """``repeats`` experiments of ``scenario`` in one Recording (see the module docstring); ``manoeuvres`` as in
    :func:`simulate_ride`."""
    _validate(scenario, repeats, seed, rate, manoeuvres)
    rides = [simulate_ride(scenario, k, repeats=repeats, seed=seed, rate=rate, manoeuvres=manoeuvres)
             for k in range(1, repeats + 1)]
    return Recording(
        time=np.concatenate([r.time for r in rides]),
        channels={c: np.concatenate([r.channels[c] for r in rides]) for c in CHANNELS},
        rate=float(rate),
        source=f"simulate {scenario}",
        truth={"label": np.concatenate([r.label for r in rides]), "event": np.concatenate([r.event for r in rides])},
        experiment=np.concatenate([np.full(len(r.time), k) for k, r in enumerate(rides, start=1)]),
        meta={
            "scenario": scenario,
            **({} if manoeuvres is None else {"manoeuvres": list(manoeuvres)}),
            "seed": int(seed),
            "repeats": int(repeats),
            "rate": float(rate),
            "internal_rate": max(200.0, 10.0 * rate),
            "time": "restarts at 0 s in each experiment; nominal grid k/rate, sensor sampled at k/rate + jitter",
            "classes": list(CLASSES[scenario]),
            "thresholds": {"normal_braking": NORMAL_BRAKING, "sudden_braking": SUDDEN_BRAKING,
                           "straight": STRAIGHT, "sharp": SHARP, "strike": STRIKE},
            "imu": asdict(ImuSpec()),
            "gps": asdict(GpsSpec()),
            "experiments": [r.params for r in rides],
        },
    )
