"""The evaluation report's lateral and road models: per-class accuracy on held-out riders, and the cost of the
braking, lateral and road models together on one raw stream.

Each model of :data:`~spotfree.evaluation.lateral_road.MODELS` is trained spotting-free under its protocol on the
report's seed and scored per true class on the held-out riders (:func:`~spotfree.evaluation.lateral_road.spec_split`,
:func:`~spotfree.evaluation.lateral_road.train_and_score`: live, centred and after the offline votes, beside the
peers). The report's braking model, the lateral and the road model then run together in one
:class:`~spotfree.classify.multi.MultiModelStream` over the raw held-out lateral rides, one sample at a time, each
call timed by ``time.perf_counter_ns`` after a short warm-up; the stream's labels are compared with the batch
table of :func:`~spotfree.classify.multi.classify_models`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from spotfree.classify.multi import MultiModelStream, classify_models
from spotfree.evaluation.lateral_road import MODELS, ModelScore, ModelSpec, spec_split, train_and_score
from spotfree.evaluation.peers.base import Peer
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.sim.scenarios import simulate_scenario

STREAM_GOAL_US = 50.0
"""Median microseconds per raw sample, end to end, the three models together (issue 7's streaming budget)."""
WARM_UP = 50
"""Samples streamed before the timed pass."""


@dataclass
class StreamCost:
    """Microseconds of each ``MultiModelStream.update`` call on ``samples`` raw samples, and the labels (over all
    models) that differ from the batch table."""

    micros: np.ndarray
    differing: int

    @property
    def samples(self) -> int:
        return len(self.micros)


@dataclass
class RideModels:
    """The lateral and road models' scores, and the three models' stream cost."""

    scores: dict[str, ModelScore]
    stream: StreamCost


def raw_samples(rides: Recording) -> list[tuple]:
    """``(acc, gyr, t, speed)`` per sample of a raw log, the arguments of ``MultiModelStream.update``."""
    return list(zip(rides.array(["ax", "ay", "az"]), rides.array(["gx", "gy", "gz"]), rides.time,
                    rides.channels["speed"]))


def stream_cost(models: dict[str, DictionaryModel], rides: Recording) -> StreamCost:
    """Time :class:`MultiModelStream` over the raw ``rides`` (after a warm-up on the first :data:`WARM_UP` samples,
    which loads the compiled kernels) and count its labels that differ from :func:`classify_models`' causal table."""
    samples = raw_samples(rides)
    stream = MultiModelStream(models)
    for sample in samples[:WARM_UP]:
        stream.update(*sample)
    stream.reset()
    micros = np.empty(len(samples))
    labels = []
    for k, sample in enumerate(samples):
        start = time.perf_counter_ns()
        labels.append(stream.update(*sample))
        micros[k] = (time.perf_counter_ns() - start) / 1e3
    table = classify_models(models, rides)
    differing = sum(int(np.sum(np.array(["" if row[k] is None else row[k] for row in labels], dtype=object)
                               != table[name].to_numpy()))
                    for k, name in enumerate(stream.names))
    return StreamCost(micros, differing)


def evaluate_ride_models(braking: DictionaryModel, seed: int,
                         peers: Callable[[ModelSpec], dict[str, Peer]] | None = None) -> RideModels:
    """Train and score every model of :data:`MODELS` on ``seed`` (``peers``: the peers of a spec, fitted on its
    training rides with their ground truth and scored beside it), then time them with ``braking`` on one stream."""
    splits = {name: spec_split(spec, seed) for name, spec in MODELS.items()}
    scores = {name: train_and_score(MODELS[name], data, seed, peers(MODELS[name]) if peers else None)
              for name, data in splits.items()}
    models = {"braking": braking, **{name: score.model for name, score in scores.items()}}
    tests = splits["lateral"].test_experiments
    rides = simulate_scenario("lateral", repeats=max(tests), seed=seed)
    return RideModels(scores, stream_cost(models, rides.take(np.isin(rides.experiment, tests))))
