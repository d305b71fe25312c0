"""Lateral and road-surface models: channel/window grid on development seeds, per-class accuracy on test seeds.

Protocol (:mod:`spotfree.evaluation.lateral_road`): per model, the training rides of its spec are trained on
spotting-free (each declares the classes that occur in it), experiments 5-7 of its own scenario (three held-out
riders) are labelled and scored per true class. The grid runs on ``--dev-seeds`` only (causal labels, then the centred
labels after the offline votes of the spec, :mod:`spotfree.votes`; every sample, strict). The
chosen :data:`~spotfree.evaluation.lateral_road.MODELS` are then scored on each of ``--test-seeds``, which the grid
never sees (``spotfree evaluate`` reports one of them): per label stream (live, centred, offline vote) and class the
accuracy away from true label changes (+-0.5 s) with the strict figure beside, the spec's short classes as detected
events (F1, false alarms); then per stream and class the mean and the lowest over the test seeds, and on how many
seeds every class meets issue 35's goal (>= 98 % offline, >= 95 % live, away from changes).

Run: ``python benchmarks/lateral_road.py [--dev-seeds 100] [--test-seeds 0 1 2 3 4]``; writes
``benchmarks/results/lateral_road.md`` (command, machine, date, output).
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from machine import results_file
from spotfree.evaluation.lateral_road import MODELS, STREAMS, ModelScore, spec_split, train_and_score
from spotfree.evaluation.report import GOALS
from spotfree.sim.scenarios import CLASSES

GRID = {
    "lateral": ([("yaw_rate", "roll_rate"), ("yaw_rate", "roll"), ("yaw_rate",), ("yaw_rate", "roll", "acc_y")],
                (10, 20, 40)),
    "road": ([("rough_y", "rough_z"), ("vib_y", "vib_z"), ("rough_x", "rough_y", "rough_z"), ("rough_z",)], (6, 10, 20)),
}
"""Channel sets and windows (samples at 20 Hz) tried per model."""
STREAM_GOALS = {"live": GOALS["live"], "centred": GOALS["offline"], "offline vote": GOALS["offline"]}
"""Issue 35's per-class goal away from true changes (``spotfree evaluate``'s), per label stream."""


def row(name: str, seed: int, channels, window: int, result, seconds: float) -> str:
    classes = " ".join(f"{s.rate:.3f}" for s in result.per_class("live").values())
    voted = " ".join(f"{s.rate:.3f}" for s in result.per_class("offline vote").values())
    return (f"{name:8s} {seed:4d}  {','.join(channels):22s} {window:3d}  {classes}  overall "
            f"{result.overall('live').rate:.3f}  | offline vote {voted}  overall "
            f"{result.overall('offline vote').rate:.3f}  ({seconds:.0f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dev-seeds", type=int, nargs="+", default=[100])
    parser.add_argument("--test-seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with results_file("lateral_road", "Lateral and road-surface models: grid on development seeds, test seeds",
                      preformatted=True):
        for name in args.models:
            score_model(name, args.dev_seeds, args.test_seeds)


def score_model(name: str, dev_seeds: list[int], test_seeds: list[int]) -> None:
    """Print the grid rows of model ``name`` on ``dev_seeds``, then its chosen spec on each of ``test_seeds`` and a
    summary over them."""
    spec = MODELS[name]
    print(f"\n{name}: per-class accuracy in the order {', '.join(CLASSES[spec.scenario])}")
    channel_sets, windows = GRID[name]
    for seed in dev_seeds:
        data = spec_split(spec, seed)
        print(f"declared per training experiment: {[classes for _, classes in data.training]}")
        for channels in channel_sets:
            for window in windows:
                start = time.perf_counter()
                result = train_and_score(spec, data, seed, channels=channels, window=window)
                print(row(name, seed, channels, window, result, time.perf_counter() - start), flush=True)
    print(f"test seeds, chosen spec ({','.join(spec.channels)}, window {spec.window}): per class, % away from true "
          "changes (strict)")
    results = []
    for seed in test_seeds:
        start = time.perf_counter()
        result = train_and_score(spec, spec_split(spec, seed), seed)
        results.append(result)
        print(f"seed {seed} ({time.perf_counter() - start:.0f} s); model classes: "
              f"{', '.join(map(str, result.model.classes))}; warnings: {result.warnings}")
        for stream in STREAMS:
            print(f"  {stream:13s} {seed_row(result, stream)}", flush=True)
    print(f"over test seeds {', '.join(map(str, test_seeds))}: per class, mean / lowest % away from true changes")
    for stream in STREAMS:
        print(f"  {stream:13s} {summary_row(results, stream)}")


def seed_row(result: ModelScore, stream: str) -> str:
    """Per class of ``stream``: away (strict) % (away ``-`` for a class all of whose samples lie near a change), then
    each detected class's events."""
    away, strict = result.per_class(stream, collar=True), result.per_class(stream)
    cells = [f"{c} {f'{100 * away[c].rate:.2f}' if away[c].total else '-'} ({100 * strict[c].rate:.2f})"
             for c in strict if strict[c].total]
    for event in result.spec.detections:
        e = result.events(event, stream)
        cells.append(f"{event} events F1 {e.f1:.3f}, {e.detected}/{e.events}, {e.false_alarms} false")
    return "; ".join(cells)


def summary_row(results: list[ModelScore], stream: str) -> str:
    """Per class of ``stream``: mean and lowest away % over ``results``; the seeds whose every class meets
    :data:`STREAM_GOALS`; each detected class's mean F1 and false alarms."""
    away = [r.per_class(stream, collar=True) for r in results]
    classes = [c for c in away[0] if all(a[c].total for a in away)]
    rates = {c: np.array([a[c].rate for a in away]) for c in classes}
    met = sum(all(rates[c][k] >= STREAM_GOALS[stream] for c in classes) for k in range(len(results)))
    cells = [f"{c} {100 * v.mean():.2f} / {100 * v.min():.2f}" for c, v in rates.items()]
    cells.append(f"every class >= {100 * STREAM_GOALS[stream]:.0f} % on {met} of {len(results)} seeds")
    for event in results[0].spec.detections:
        events = [r.events(event, stream) for r in results]
        cells.append(f"{event} events F1 mean {np.nanmean([e.f1 for e in events]):.3f}, "
                     f"{sum(e.false_alarms for e in events)} false in all")
    return "; ".join(cells)


if __name__ == "__main__":
    main()
