"""Lateral and road-surface models: channel/window grid on development seeds, per-class accuracy on the test seed.

Protocol (:mod:`spotfree.evaluation.lateral_road`): per model, experiments 1-4 of its scenario's file and of the
other scenario's are trained on spotting-free (each declares the classes that occur in it), experiments 5-7 of its
own scenario (three held-out riders) are labelled causally and scored per true class. The grid runs on
``--dev-seeds`` only; the chosen :data:`~spotfree.evaluation.lateral_road.MODELS` are then scored on
``--test-seed``, which the grid never sees. Each row: the causal labels, then the same after the offline segment
vote at the spec's penalty (:mod:`spotfree.votes.segments`).

Run: ``python benchmarks/lateral_road.py [--dev-seeds 100] [--test-seed 0]``; writes
``benchmarks/results/lateral_road.md`` (command, machine, date, output).
"""

from __future__ import annotations

import argparse
import time
import warnings

from machine import results_file
from spotfree.evaluation.lateral_road import MODELS, spec_split, train_and_score
from spotfree.sim.scenarios import CLASSES

GRID = {
    "lateral": ([("yaw_rate", "roll_rate"), ("yaw_rate", "roll"), ("yaw_rate",), ("yaw_rate", "roll", "acc_y")],
                (10, 20, 40)),
    "road": ([("rough_y", "rough_z"), ("vib_y", "vib_z"), ("rough_x", "rough_y", "rough_z"), ("rough_z",)], (6, 10, 20)),
}
"""Channel sets and windows (samples at 20 Hz) tried per model."""


def row(name: str, seed: int, channels, window: int, result, seconds: float) -> str:
    classes = " ".join(f"{s.rate:.3f}" for s in result.per_class("live").values())
    voted = " ".join(f"{s.rate:.3f}" for s in result.per_class("offline vote").values())
    return (f"{name:8s} {seed:4d}  {','.join(channels):22s} {window:3d}  {classes}  overall "
            f"{result.overall('live').rate:.3f}  | segment vote {voted}  overall "
            f"{result.overall('offline vote').rate:.3f}  ({seconds:.0f} s)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dev-seeds", type=int, nargs="+", default=[100])
    parser.add_argument("--test-seed", type=int, default=0)
    parser.add_argument("--models", nargs="+", default=list(MODELS))
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    with results_file("lateral_road", "Lateral and road-surface models: grid on development seeds, test seed",
                      preformatted=True):
        for name in args.models:
            score_model(name, args.dev_seeds, args.test_seed)


def score_model(name: str, dev_seeds: list[int], test_seed: int) -> None:
    """Print the grid rows of model ``name`` on ``dev_seeds``, then its chosen spec on ``test_seed``."""
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
    data = spec_split(spec, test_seed)
    start = time.perf_counter()
    result = train_and_score(spec, data, test_seed)
    print("test seed, chosen spec:")
    print(row(name, test_seed, spec.channels, spec.window, result, time.perf_counter() - start))
    print(f"  samples per class: {', '.join(f'{c} {s.correct}/{s.total}' for c, s in result.per_class().items())}")
    print(f"  model classes: {', '.join(map(str, result.model.classes))}; warnings: {result.warnings}")


if __name__ == "__main__":
    main()
