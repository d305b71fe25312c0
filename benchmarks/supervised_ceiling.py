"""How much of the simulator's ground truth any classifier can recover from the ride features: a supervised ceiling.

The evaluations score per-sample accuracy on the simulator's hidden labels. Those labels are thresholds on quantities
the phone sees only through the vehicle's response (braking: the rider's lean deceleration, 0.5 and 2.0 m/s^2;
lateral: the yaw rate; road: the surface under the wheels and the vertical acceleration of a kerb strike). This
script measures what a strong supervised classifier, given every training label, reaches on the same kind of
tests, so that spotfree's spotting-free figures can be read against it:

* learner: scikit-learn's ``HistGradientBoostingClassifier`` (200 iterations) on the ride feature channels sampled
  every 2nd sample over a context of ``before`` samples before and ``after`` after each labelled sample
  (``after`` 0: causal, as the phone; above 0: centred, offline);
* ``--model braking``: the protocol of ``spotfree evaluate``; tests: experiments 2-7 of the normal- and
  sudden-braking files and all 7 cruising rides of each seed in ``--seeds``; "protocol" training: experiment 1 of
  the normal- and of the sudden-braking file of the same seed (two riders, as spotfree's training); scored per
  scenario;
* ``--model lateral`` or ``road``: the protocol of ``benchmarks/lateral_road.py``; tests: experiments 5-7 of the
  model's scenario; "protocol" training: its experiments 1-4 of the same seed; scored per true class;
* ``--riders many``: trained instead on all 7 rides of every scenario file of seeds 100-103 (braking: 84 riders) or
  of the model's scenario of seeds 100-105 (42 riders);
* ``--stride``: samples between the context's taps (default 2); ``--summary``: each channel's mean and standard
  deviation over the whole context added to the row (a variance estimate from every sample, for the road);
* "away": leaving out the samples within 0.5 s of a label change.

    python benchmarks/supervised_ceiling.py [--model braking] [--seeds 0 1] [--channels acc_long,pitch_rate]
                                            [--riders protocol|many] [--contexts 20:0,40:0,20:20]
                                            [--stride 2] [--summary]

Writes ``benchmarks/results/supervised_ceiling_<model>.md`` (``_many`` appended with ``--riders many``): command,
machine, date, table.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier

from machine import results_file
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario

BRAKING = ("normal-braking", "sudden-braking", "cruising")
CHANNELS = {"braking": "acc_long,pitch_rate", "lateral": "yaw_rate,roll_rate,roll,acc_y",
            "road": "vib_x,vib_y,vib_z,acc_z"}
"""Default channels per model: the braking model's own, and for the other two the union of those their grids tried."""
STRIDE = 2
"""Samples between the context's taps (``--stride``)."""
AWAY = 10
"""Samples (0.5 s) each side of a label change left out of the "away" score."""


def _features(cache: dict, seed: int, scenario: str):
    if (seed, scenario) not in cache:
        cache[seed, scenario] = ride_features(simulate_scenario(scenario, repeats=7, seed=seed), derived=True)
    return cache[seed, scenario]


def _rows(cache, rides, channels, before, after, stride=STRIDE, summary=False):
    """Context rows, labels, scenario and distance (samples) to the nearest label change of every sample of
    ``rides`` ((seed, scenario, experiments)) that has a full context. ``summary``: each row also holds every
    channel's mean and standard deviation over the whole context (every sample)."""
    x, y, scenario, distance = [], [], [], []
    taps = np.arange(-before, after + 1, stride)
    every = np.arange(-before, after + 1)
    for seed, name, experiments in rides:
        feats = _features(cache, seed, name)
        values = np.column_stack([feats.channels[c] for c in channels])
        labels = np.asarray(feats.truth["label"])
        for k in experiments:
            index = np.flatnonzero(feats.experiment == k)
            v, lab = values[index], labels[index]
            changes = np.flatnonzero(lab[1:] != lab[:-1]) + 0.5
            near = (np.abs(np.arange(len(lab))[:, None] - changes[None, :]).min(axis=1) if len(changes)
                    else np.full(len(lab), np.inf))
            at = np.arange(before, len(v) - after)
            row = [v[at[:, None] + taps[None, :]].reshape(len(at), -1)]
            if summary:
                context = v[at[:, None] + every[None, :]]
                row += [context.mean(axis=1), context.std(axis=1)]
            x.append(np.hstack(row))
            y.append(lab[at])
            scenario += [name] * len(at)
            distance.append(near[at])
    return np.vstack(x), np.concatenate(y), np.array(scenario), np.concatenate(distance)


def _protocol(model: str, seed: int) -> tuple[list, list]:
    """(training rides, test rides) of one seed, each a list of (seed, scenario, experiments)."""
    if model == "braking":
        tests = [(seed, n, range(1, 8) if n == "cruising" else range(2, 8)) for n in BRAKING]
        return [(seed, n, [1]) for n in BRAKING[:2]], tests
    return [(seed, model, range(1, 5))], [(seed, model, range(5, 8))]


def _many(model: str) -> list:
    if model == "braking":
        return [(s, n, range(1, 8)) for s in (100, 101, 102, 103) for n in BRAKING]
    return [(s, model, range(1, 8)) for s in range(100, 106)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=tuple(CHANNELS), default="braking")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--channels", default=None, help="comma-separated (default: per model, see CHANNELS)")
    parser.add_argument("--riders", choices=("protocol", "many"), default="protocol")
    parser.add_argument("--contexts", default="20:0,40:0,20:20", help="before:after pairs, samples")
    parser.add_argument("--stride", type=int, default=STRIDE, help="samples between the context's taps")
    parser.add_argument("--summary", action="store_true",
                        help="add each channel's mean and standard deviation over the context")
    args = parser.parse_args()
    name = f"supervised_ceiling_{args.model}" + ("_many" if args.riders == "many" else "")
    start = time.perf_counter()
    with results_file(name, f"Supervised ceiling of the {args.model} model's labels"):
        ceiling(args)
        print(f"\nWall time {time.perf_counter() - start:.0f} s.")


def ceiling(args: argparse.Namespace) -> None:
    """Print the table of one run: a row per context."""
    channels = tuple((args.channels or CHANNELS[args.model]).split(","))
    groups = BRAKING if args.model == "braking" else CLASSES[args.model]
    print(f"Model {args.model}; channels {','.join(channels)}; training riders: {args.riders}; test seeds "
          f"{args.seeds}; taps every {args.stride} samples{' + context mean, std' if args.summary else ''}; "
          f"columns: per {'scenario' if args.model == 'braking' else 'true class'}, then all. Accuracy in %.\n")
    print(f"| context (before:after) | training | {' | '.join(groups)} | all tests | all, away from changes | "
          "errors within 0.25 s of a change |")
    print("|---|---|" + "---:|" * (len(groups) + 3))
    cache: dict = {}
    for context in args.contexts.split(","):
        before, after = (int(v) for v in context.split(":"))
        hits = {g: [0, 0] for g in groups}
        away, late = [0, 0], [0, 0]
        fits = [(None, args.seeds)] if args.riders == "many" else [(s, [s]) for s in args.seeds]
        for train_seed, test_seeds in fits:
            training = _many(args.model) if train_seed is None else _protocol(args.model, train_seed)[0]
            x, y, _, _ = _rows(cache, training, channels, before, after, args.stride, args.summary)
            learner = HistGradientBoostingClassifier(max_iter=200, random_state=0).fit(x, y)
            for test_seed in test_seeds:
                xt, yt, scen, dist = _rows(cache, _protocol(args.model, test_seed)[1], channels, before, after,
                                           args.stride, args.summary)
                right = learner.predict(xt) == yt
                group = scen if args.model == "braking" else yt
                for g in groups:
                    hits[g][0] += int(right[group == g].sum())
                    hits[g][1] += int((group == g).sum())
                away[0] += int(right[dist > AWAY].sum())
                away[1] += int((dist > AWAY).sum())
                late[0] += int((~right & (dist <= AWAY // 2)).sum())
                late[1] += int((~right).sum())
        total = [sum(h[0] for h in hits.values()), sum(h[1] for h in hits.values())]
        cells = " | ".join(f"{100 * h[0] / h[1]:.2f}" if h[1] else "-" for h in hits.values())
        kind = "causal" if after == 0 else "centred"
        print(f"| {before}:{after} ({kind}) | {args.riders} | {cells} | {100 * total[0] / total[1]:.2f} | "
              f"{100 * away[0] / away[1]:.2f} | {100 * late[0] / max(late[1], 1):.0f} % |", flush=True)


if __name__ == "__main__":
    main()
