"""The paper's protocol (section V) on the simulator: which rides are simulated, trained on and tested.

Per manoeuvre scenario of :data:`SCENARIOS`, ``repeats`` experiments (rides) are simulated with one seed (the paper
recorded seven). The dictionary is trained without labels on experiment :data:`TRAIN_EXPERIMENT` of the
normal-braking and of the sudden-braking file, each declared with its classes from
:data:`spotfree.sim.scenarios.CLASSES` (the paper trains on one experiment of each braking state); the other
experiments of those files are the tests. No cruising ride is trained on, so every cruising ride is a test.
Everything is classified from the ride features (:func:`~spotfree.signal.features.ride_features` with the derived
channels), computed once per file.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.presets import preset_learner
from spotfree.signal.features import ride_features
from spotfree.sim.hand import TRAINING_PEOPLE
from spotfree.sim.scenarios import CLASSES, simulate_scenario

SCENARIOS = ("normal-braking", "sudden-braking", "cruising")
"""The tested scenarios, in report order."""
TRAINED_ON = ("normal-braking", "sudden-braking")
"""Scenarios one experiment of which the dictionary is trained on."""
TRAIN_EXPERIMENT = 1


@dataclass(frozen=True)
class Protocol:
    """What one evaluation run simulates and measures.

    ``repeats`` experiments per scenario; ``method_windows``: about how many test windows per scenario the
    CRC / SRC / B_SRC comparison classifies (every k-th window, the same for all three methods);
    ``minirocket_kernels``: MiniRocket's number of features (10,000 is its published default);
    ``ride_train_step``: the lateral and road models' MiniRocket peers fit every so many training windows (their
    training rides are ten times the braking model's); ``hand_people``: the simulated people the hand is trained and
    tested on (:func:`~spotfree.evaluation.hand.evaluate_hand`); ``hand_train_step``: the hand's supervised peers fit
    every so many training windows.
    """

    seed: int = 0
    repeats: int = 7
    rate: float = 20.0
    method_windows: int = 1000
    minirocket_kernels: int = 10_000
    ride_train_step: int = 4
    hand_people: tuple[int, int] = (TRAINING_PEOPLE, 6)
    hand_train_step: int = 4
    quick: bool = False

    @classmethod
    def quick_run(cls, seed: int = 0) -> "Protocol":
        """Two experiments per scenario, 50 comparison windows, 1,000 MiniRocket kernels fitted on every 8th ride
        or hand window, and the hand of 4 people tested on 2: every section of the report in a short run (for tests; not
        the paper's protocol)."""
        return cls(seed=seed, repeats=2, method_windows=50, minirocket_kernels=1_000, ride_train_step=8,
                   hand_people=(4, 2), hand_train_step=8, quick=True)

    def test_experiments(self, scenario: str) -> list[int]:
        """The experiment numbers of ``scenario`` that are tested."""
        return [k for k in range(1, self.repeats + 1) if scenario not in TRAINED_ON or k != TRAIN_EXPERIMENT]


@dataclass
class ScenarioData:
    """One scenario's rides: the ride features of its test experiments (``truth`` kept for scoring), and of its
    training experiment (None when it is not trained on)."""

    name: str
    test: Recording
    experiments: list[int]
    training: Recording | None


@dataclass
class Trained:
    """The training run: the fitted learner, the recordings it read with their declared classes (for the naming's
    scores and the figure) and its wall time (s)."""

    learner: SetSupervisedLearner
    recordings: list[Recording]
    class_sets: list[list[str]]
    seconds: float


def simulate(protocol: Protocol) -> dict[str, ScenarioData]:
    """Simulate every scenario of :data:`SCENARIOS` and split it into training and test experiments."""
    data = {}
    for scenario in SCENARIOS:
        feats = ride_features(simulate_scenario(scenario, repeats=protocol.repeats, seed=protocol.seed,
                                                rate=protocol.rate), derived=True)
        tests = protocol.test_experiments(scenario)
        data[scenario] = ScenarioData(
            name=scenario,
            test=_rename(feats.take(np.isin(feats.experiment, tests)), f"{scenario} tests"),
            experiments=tests,
            training=(_rename(feats.select_experiment(TRAIN_EXPERIMENT), f"{scenario} experiment {TRAIN_EXPERIMENT}")
                      if scenario in TRAINED_ON else None),
        )
    return data


def train_dictionary(data: dict[str, ScenarioData], protocol: Protocol) -> Trained:
    """Spotting-free training (the ``braking`` preset, :func:`~spotfree.presets.preset_learner`, seeded with the protocol's seed) on the
    training experiments, each declared with its scenario's classes."""
    recordings = [data[s].training for s in TRAINED_ON]
    sets = [list(CLASSES[s]) for s in TRAINED_ON]
    start = time.perf_counter()
    learner = preset_learner("braking", seed=protocol.seed).fit(recordings, sets)
    return Trained(learner, recordings, sets, time.perf_counter() - start)


def _rename(rec: Recording, source: str) -> Recording:
    rec.source = source
    return rec
