"""Per-sample cost of running the braking, lateral and road models together on one stream (MultiModelStream).

Models: trained spotting-free by :func:`spotfree.training.train` on development seed 100: braking (default
configuration, experiment 1 of a normal-braking and of a sudden-braking ride), lateral and road
(:data:`spotfree.evaluation.lateral_road.MODELS`, experiments 1-4 of their files and of the other scenario's).
Data: two simulated lateral rides (seed 7), raw device-frame IMU at 20 Hz with GPS speed on the fixes.

Rows (single calls timed with ``time.perf_counter_ns`` after a warm-up pass; the passes are interleaved so that all
rows see the same machine load):

* ``MultiModelStream.update``: one raw sample in, three labels out (one feature pass, three ring buffers and CRCs);
* ``RideClassifier.update`` per model: each model alone, end to end (its own feature pass);
* ``FeatureStream.update``: the ride features alone (13 channels), the floor under every row.

The three models' stream labels are checked against :func:`spotfree.classify.multi.classify_models`.

Run: ``python benchmarks/multi_model_speed.py [--passes 3]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import time

import numpy as np

from spotfree.classify.multi import MultiModelStream, classify_models
from spotfree.classify.stream import RideClassifier
from spotfree.evaluation.lateral_road import MODELS, split
from spotfree.signal.features import FeatureStream, ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario
from spotfree.training import TrainingConfig, TrainingExperiment, train

GOAL_US = 50.0
"""Median per raw sample, end to end, all three models (issue 7)."""
SEED = 100


def trained_models() -> dict:
    """The three models of the module docstring."""
    braking = [TrainingExperiment(ride_features(simulate_scenario(s, repeats=1, seed=SEED), derived=True),
                                  list(CLASSES[s])) for s in ("normal-braking", "sudden-braking")]
    models = {"braking": train(braking, TrainingConfig(seed=SEED)).model}
    for name, spec in MODELS.items():
        models[name] = train(split(spec.scenario, SEED).training, spec.config(SEED)).model
    return models


def timed(step, samples) -> np.ndarray:
    """Microseconds of each ``step(*sample)`` call."""
    out = np.empty(len(samples))
    for k, sample in enumerate(samples):
        start = time.perf_counter_ns()
        step(*sample)
        out[k] = (time.perf_counter_ns() - start) / 1e3
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--passes", type=int, default=3)
    args = parser.parse_args()
    start = time.perf_counter()
    models = trained_models()
    trained_s = time.perf_counter() - start
    rides = simulate_scenario("lateral", repeats=2, seed=7)
    samples = list(zip(rides.array(["ax", "ay", "az"]), rides.array(["gx", "gy", "gz"]), rides.time,
                       rides.channels["speed"]))
    print(f"# multi_model_speed {datetime.date.today()}: {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores (shared), load average {os.getloadavg()[0]:.1f}; Python {platform.python_version()},"
          f" numpy {np.__version__}; OPENBLAS_CORETYPE {os.environ.get('OPENBLAS_CORETYPE', 'not set')}")
    for name, m in models.items():
        print(f"model {name}: channels {','.join(m.channels)}, window {m.window}, {m.dictionary.shape[1]} columns, "
              f"classes {', '.join(map(str, m.classes))}")
    print(f"rides: {len(samples)} samples at 20 Hz; training the three models took {trained_s:.0f} s")

    table = classify_models(models, rides)
    multi = MultiModelStream(models)
    got = [multi.update(*s) for s in samples]
    differ = sum(int(np.sum(np.array(["" if g[k] is None else g[k] for g in got]) != table[name].to_numpy()))
                 for k, name in enumerate(multi.names))

    rows: dict[str, list[np.ndarray]] = {}
    singles = {name: RideClassifier(m) for name, m in models.items()}
    features = FeatureStream(20.0, derived=True)
    for _ in range(args.passes):
        multi.reset()
        rows.setdefault("MultiModelStream.update (3 models, end to end)", []).append(
            timed(lambda a, w, t, s: multi.update(a, w, t, s), samples))
        for name, clf in singles.items():
            clf.reset()
            rows.setdefault(f"RideClassifier.update {name} alone (end to end)", []).append(
                timed(lambda a, w, t, s: clf.update(a, w, t, s), samples))
        features.reset()
        rows.setdefault("FeatureStream.update (features alone)", []).append(
            timed(lambda a, w, t, s: features.update(a, w, s), samples))
    floor = float(np.median(np.concatenate(rows["FeatureStream.update (features alone)"])))
    print("\n| path | calls | median (us) | p90 (us) | p99 (us) | median / FeatureStream |")
    print("|---|---:|---:|---:|---:|---:|")
    for label, parts in rows.items():
        us = np.concatenate(parts)
        p50, p90, p99 = np.percentile(us, [50, 90, 99])
        print(f"| {label} | {len(us)} | {p50:.1f} | {p90:.1f} | {p99:.1f} | {p50 / floor:.2f} |")
    multi_median = float(np.median(np.concatenate(rows["MultiModelStream.update (3 models, end to end)"])))
    print(f"\n- three models end to end: median {multi_median:.1f} us per raw sample "
          f"({'within' if multi_median <= GOAL_US else 'beyond'} the {GOAL_US:.0f} us goal)")
    print(f"- stream labels differing from the batch table (3 models x {len(samples)} samples): {differ}")


if __name__ == "__main__":
    main()
