"""Dictionary purity of spotting-free training on simulated rides, per configuration and seed.

Training data as in ``tests/test_training.py``: experiment 1 of a ``normal-braking`` file (seed ``s``) declared
``cruising,normal-braking`` and experiment 1 of a ``sudden-braking`` file (seed ``s + 1``) declared
``cruising,normal-braking,sudden-braking``. Purity of a class: the share of its dictionary columns whose window
centre has that class in the hidden ``label`` (training never reads it). ``cols`` are the columns per class
(cruising / normal / sudden), ``s`` the wall time of one training. The last lines say, per configuration, on
which seeds every class is present with a purity of at least 0.98 (the goal of ``tests/test_training.py``), and the
share of right columns per class pooled over the seeds. ``--trend`` adds, per configuration, quantiles of the GPS
speed's trend (m/s^2, :func:`~spotfree.training.speed_slope`) around the centre of the columns, by the class they
are named and the class the hidden label gives. The training's clustering seed is 0 unless a configuration names
another.

    python benchmarks/training_purity.py --seeds 0 1 2 --configs default paper [--trend]
"""

from __future__ import annotations

import argparse
import time
from collections import defaultdict

import numpy as np

from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario
from spotfree.training import TrainingConfig, TrainingExperiment, dictionary_purity, speed_slope, train

CLASSES = ("cruising", "normal-braking", "sudden-braking")
GOAL = 0.98

CONFIGS = {
    "default": {},
    "paper": {"recipe": "paper"},
    "every-inner": {"inner_quantile": 0.0},
    "gaps-open": {"close_gaps": 0},
    "previous-default": {"inner_quantile": 0.0, "close_gaps": 0},
    "no-inner-depth": {"inner_depth": 0.0},
    "no-deepest-inner": {"deepest_inner": False},
    "no-outer-depth": {"outer_depth": 0.0},
    "neither-depth-rule": {"deepest_inner": False, "outer_depth": 0.0},
    "no-upright": {"upright": 0.0},
    "no-floor": {"inner_floor": 0.0},
    "floor-0.8": {"inner_floor": 0.8},
    "no-recluster": {"recluster": False},
    "neither-floor-nor-recluster": {"inner_floor": 0.0, "recluster": False},
    "no-background-lean": {"background_lean": 0.0},
    "no-slowing": {"slowing": 0.0},
    "slowing-0.3": {"slowing": 0.3},
    "slowing-0.5": {"slowing": 0.5},
    "background-lean-1": {"background_lean": 1.0},
    "inner-depth-0.7": {"inner_depth": 0.7},
    "inner-depth-0.9": {"inner_depth": 0.9},
    "every-outer": {"outer_quantile": 0.0},
    "outer-0.75": {"outer_quantile": 0.75},
    "seed-1": {"seed": 1},
    "seed-2": {"seed": 2},
    "seed-5": {"seed": 5},
    "seed-10": {"seed": 10},
    "votes-5": {"votes": 5},
    "votes-5-seed-5": {"votes": 5, "seed": 5},
    "votes-5-seed-10": {"votes": 5, "seed": 10},
    "neither": {"inner_depth": 0.0, "outer_quantile": 0.0},
    "osc": {"clustering": "osc"},
    "lean-acc_x-osc": {"channels": ("lean", "acc_x"), "clustering": "osc", "extra_clusters": 3},
    "acc_long-40": {"channels": ("acc_long",), "window": 40},
    "old-channels": {"channels": ("pitch", "pitch_rate", "acc_x"), "affine": 0.0},
    "no-affine": {"affine": 0.0},
    "affine-20": {"affine": 20.0},
    "lean-only": {"channels": ("lean",)},
    "lean-rate-acc": {"channels": ("lean", "pitch_rate", "acc_x")},
    "extra-10": {"extra_clusters": 10},
    "window-30": {"window": 30},
    "window-12": {"window": 12},
    "extra-1": {"extra_clusters": 1},
    "extra-8": {"extra_clusters": 8},
}


def experiments(seed: int) -> list[TrainingExperiment]:
    nb = simulate_scenario("normal-braking", repeats=1, seed=seed).select_experiment(1)
    sb = simulate_scenario("sudden-braking", repeats=1, seed=seed + 1).select_experiment(1)
    return [TrainingExperiment(ride_features(nb, derived=True), list(CLASSES[:2])),
            TrainingExperiment(ride_features(sb, derived=True), list(CLASSES))]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--configs", nargs="+", default=["default", "paper"], choices=sorted(CONFIGS))
    parser.add_argument("--trend", action="store_true", help="GPS speed trend of the columns by name and truth")
    args = parser.parse_args()
    print(f"{'config':<14} {'seed':>4} {'cruising':>9} {'normal':>7} {'sudden':>7} {'cols':>12} {'s':>6}")
    pure = {name: [] for name in args.configs}
    right, total = defaultdict(float), defaultdict(int)
    trends = defaultdict(list)
    for seed in args.seeds:
        exps = experiments(seed)
        for name in args.configs:
            start = time.perf_counter()
            result = train(exps, TrainingConfig(**{"seed": 0, **CONFIGS[name]}))
            elapsed = time.perf_counter() - start
            purity = dictionary_purity(result, exps)
            columns = result.model.summary["columns_per_class"]
            cells = " ".join(f"{purity[c]:>{w}.3f}" if c in purity else f"{'-':>{w}}"
                             for c, w in zip(CLASSES, (9, 7, 7)))
            cols = "/".join(str(columns.get(c, 0)) for c in CLASSES)
            print(f"{name:<14} {seed:>4} {cells} {cols:>12} {elapsed:>6.1f}", flush=True)
            if all(purity.get(c, 0.0) >= GOAL for c in CLASSES):
                pure[name].append(seed)
            for c in purity:
                right[name, c] += purity[c] * columns[c]
                total[name, c] += columns[c]
            if args.trend:
                for key, value in column_trends(result, exps):
                    trends[(name, *key)].append(value)
    for name, seeds in pure.items():
        print(f"{name}: every class >= {GOAL} on {len(seeds)} of {len(args.seeds)} seeds: {seeds}")
        print(f"{name}: right columns pooled over the seeds: " + ", ".join(
            f"{c} {100 * right[name, c] / total[name, c]:.2f} % of {total[name, c]}" for c in CLASSES
            if total[name, c]))
    for (name, named, truth), values in sorted(trends.items()):
        q = np.nanpercentile(values, [0, 1, 5, 50, 95, 99, 100])
        print(f"{name}: trend of columns named {named}, truth {truth}: n={len(values)}, min/1/5/50/95/99/max % "
              + " ".join(f"{v:+.2f}" for v in q))


def column_trends(result, exps):
    """``((named, truth), trend)`` per column: its class, the hidden label at its centre and the GPS speed's trend
    there (m/s^2)."""
    model = result.model
    by_recording = defaultdict(list)
    for (r, end), c in zip(result.column_source, model.column_class):
        by_recording[r].append((end - model.window // 2, model.classes[c]))
    for r, columns in by_recording.items():
        rec = exps[r].recording
        centres = np.array([centre for centre, _ in columns])
        trends = speed_slope(np.asarray(rec.channels["speed"], dtype=float), rec.rate, centres)
        for (centre, named), trend in zip(columns, trends):
            yield (named, rec.truth["label"][centre]), trend


if __name__ == "__main__":
    main()
