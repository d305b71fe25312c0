"""A simulated fleet: riders with demographics whose habits shape their rides, written as ride logs.

:func:`generate_fleet` draws ``riders`` riders (age band, gender, skill, home place) and ``rides`` rides among
them, all from ``numpy.random.SeedSequence([seed, ...])``: the same seed gives the same files. Each ride is one
experiment of the simulator (:func:`spotfree.sim.scenarios.simulate_ride`) whose scenario and rider habits follow
the rider's group. These effects are the generator's assumptions (what a fleet analysis should find again), not
findings:

* skill sets the scenario mix (:data:`SCENARIO_MIX`: a novice's ride is a sudden-braking ride with probability
  0.45, an expert's 0.08) and a factor on cruising speed (:data:`SKILL_SPEED`);
* age band sets a factor on cruising speed and on normal braking deceleration (:data:`AGE_HABITS`);
* gender changes nothing (a group difference found by gender is noise).

The simulator's local track is moved to the rider's home place (:data:`PLACES`) by translating latitude and
rescaling longitude differences by ``cos(lat0) / cos(lat)`` so east-west distances are kept.

Output folder: ``riders.csv`` (``rider_id, age_band, gender, skill, place``), ``rides.csv`` (the manifest
:mod:`spotfree.fleet.ingest` reads: ``file, ride, rider_id, vehicle, started`` (UNIX s), ``place, scenario``) and
``logs/<ride>.csv``, spotfree CSVs (``time ax ay az gx gy gz lat lon speed label event``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.errors import InputError
from spotfree.io.csvlog import write_csv
from spotfree.io.recording import Recording
from spotfree.sim.gps import GpsSpec
from spotfree.sim.scenarios import CHANNELS, simulate_ride

AGE_BANDS = ("18-29", "30-49", "50-64", "65-79")
GENDERS = ("female", "male")
SKILLS = ("novice", "intermediate", "expert")
SCENARIO_MIX = {
    "novice": {"sudden-braking": 0.45, "normal-braking": 0.35, "cruising": 0.20},
    "intermediate": {"sudden-braking": 0.20, "normal-braking": 0.50, "cruising": 0.30},
    "expert": {"sudden-braking": 0.08, "normal-braking": 0.52, "cruising": 0.40},
}
"""Probability of each simulated scenario for a ride of a rider of that skill."""
SKILL_SPEED = {"novice": 0.85, "intermediate": 0.95, "expert": 1.0}
"""Factor on the drawn cruising speed by skill."""
AGE_HABITS = {
    "18-29": {"cruise_speed": 1.0, "normal_decel": 1.0},
    "30-49": {"cruise_speed": 1.0, "normal_decel": 1.0},
    "50-64": {"cruise_speed": 0.95, "normal_decel": 0.95},
    "65-79": {"cruise_speed": 0.88, "normal_decel": 0.9},
}
"""Factors on the drawn rider habits by age band."""
PLACES = {
    "tsukuba": (36.0827, 140.1114),
    "tokyo": (35.6812, 139.7671),
    "osaka": (34.7025, 135.4959),
    "sapporo": (43.0687, 141.3508),
}
"""Home places (lat, lon degrees) riders are drawn from."""
EPOCH = 1711929600.0
"""2024-04-01T00:00:00Z: the first day of rides."""
DAY = 86400.0


@dataclass(frozen=True)
class Fleet:
    """What :func:`generate_fleet` wrote: the folder, and the riders and rides tables it holds."""

    folder: Path
    riders: pd.DataFrame
    rides: pd.DataFrame


def draw_riders(riders: int, seed: int) -> pd.DataFrame:
    """The rider table: ``rider_id, age_band, gender, skill, place``, uniformly drawn groups."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
    return pd.DataFrame({
        "rider_id": [f"rider-{k:04d}" for k in range(1, riders + 1)],
        "age_band": rng.choice(AGE_BANDS, riders),
        "gender": rng.choice(GENDERS, riders),
        "skill": rng.choice(SKILLS, riders),
        "place": rng.choice(list(PLACES), riders),
    })


def draw_rides(riders: pd.DataFrame, rides: int, vehicles: int, days: int, seed: int) -> pd.DataFrame:
    """The ride manifest (without ``file``): who rides which vehicle when, in which scenario."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 2]))
    who = riders.iloc[rng.integers(0, len(riders), rides)].reset_index(drop=True)
    scenario = [rng.choice(list(SCENARIO_MIX[s]), p=list(SCENARIO_MIX[s].values())) for s in who["skill"]]
    started = EPOCH + DAY * rng.integers(0, days, rides) + np.round(rng.uniform(7 * 3600, 20 * 3600, rides))
    return pd.DataFrame({
        "ride": [f"ride-{k:05d}" for k in range(1, rides + 1)],
        "rider_id": who["rider_id"],
        "vehicle": [f"vehicle-{k:02d}" for k in rng.integers(1, vehicles + 1, rides)],
        "started": started,
        "place": who["place"],
        "scenario": scenario,
    })


def rider_habits(age_band: str, skill: str) -> dict[str, float]:
    """Factors on the simulator's rider habits for a rider of that age band and skill."""
    age = AGE_HABITS[age_band]
    return {"cruise_speed": age["cruise_speed"] * SKILL_SPEED[skill], "normal_decel": age["normal_decel"]}


def simulate_fleet_ride(ride: pd.Series, rider: pd.Series, index: int, seed: int, rate: float = 20.0) -> Recording:
    """The ride's log: one simulated experiment with the rider's habits, placed at the rider's home."""
    sim = simulate_ride(ride["scenario"], 1, repeats=1, seed=_ride_seed(seed, index), rate=rate,
                        habits=rider_habits(rider["age_band"], rider["skill"]))
    channels = dict(sim.channels)
    channels["lat"], channels["lon"] = _moved(channels["lat"], channels["lon"], PLACES[rider["place"]])
    return Recording(sim.time, {c: channels[c] for c in CHANNELS}, float(rate), source=ride["ride"],
                     truth={"label": sim.label, "event": sim.event})


def generate_fleet(folder: str | Path, riders: int = 50, rides: int = 1000, vehicles: int = 10, days: int = 7,
                   seed: int = 0, rate: float = 20.0) -> Fleet:
    """Write a simulated fleet into ``folder`` (see the module docstring); returns its tables."""
    for name, value, least in (("riders", riders, 1), ("rides", rides, 1), ("vehicles", vehicles, 1),
                               ("days", days, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise InputError(f"fleet generate: {name} must be a whole number >= {least}, got {value!r}")
    folder = Path(folder)
    (folder / "logs").mkdir(parents=True, exist_ok=True)
    rider_table = draw_riders(riders, seed)
    ride_table = draw_rides(rider_table, rides, vehicles, days, seed)
    by_id = rider_table.set_index("rider_id")
    files = []
    for k, ride in ride_table.iterrows():
        path = folder / "logs" / f"{ride['ride']}.csv"
        write_csv(simulate_fleet_ride(ride, by_id.loc[ride["rider_id"]], k, seed, rate), path)
        files.append(str(path.relative_to(folder)))
    ride_table.insert(0, "file", files)
    rider_table.to_csv(folder / "riders.csv", index=False)
    ride_table.to_csv(folder / "rides.csv", index=False)
    return Fleet(folder, rider_table, ride_table)


def _ride_seed(seed: int, index: int) -> int:
    """A simulator seed for ride ``index`` of the fleet of ``seed``."""
    return int(np.random.SeedSequence([seed, 3, index]).generate_state(1)[0])


def _moved(lat: np.ndarray, lon: np.ndarray, place: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """A track near the simulator's origin moved to ``place`` (degrees), east-west distances kept."""
    lat0, lon0 = GpsSpec().origin
    scale = np.cos(np.deg2rad(lat0)) / np.cos(np.deg2rad(place[0]))
    return lat - lat0 + place[0], place[1] + (lon - lon0) * scale
