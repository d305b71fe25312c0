"""How much of the braking ground truth any classifier can recover from the ride features: a supervised ceiling.

The evaluation's goal is a per-sample accuracy on the simulator's hidden labels. Those labels are thresholds on the
rider's lean (``spotfree.sim.scenarios.braking_labels``: 0.5 and 2.0 m/s^2 of lean deceleration), a quantity the
phone sees only through the vehicle's response. This script measures what a strong supervised classifier, given
every training label, reaches on the same tests, so that spotfree's spotting-free figures can be read against it:

* learner: scikit-learn's ``HistGradientBoostingClassifier`` (200 iterations) on the ride feature channels sampled
  every 2nd sample over a context of ``--before`` samples before and ``--after`` after each labelled sample
  (``--after 0``: causal, as the phone; ``--after > 0``: centred, offline);
* training: either the evaluation's protocol (experiment 1 of the normal- and of the sudden-braking file of each
  test seed: two riders) or ``--riders many``: all 21 rides of seeds 100-103 (84 riders);
* tests: the evaluation's tests of each seed in ``--seeds`` (experiments 2-7 of the braking files, all 7 cruising
  rides), every sample that has a full context, scored against the hidden label; "away" leaves out the samples
  within 0.5 s of a label change.

    python benchmarks/supervised_ceiling.py [--seeds 0 1] [--channels acc_long,pitch_rate] [--riders protocol|many]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
from datetime import datetime, timezone

import numpy as np
from sklearn.ensemble import HistGradientBoostingClassifier

from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario

SCENARIOS = ("normal-braking", "sudden-braking", "cruising")
TRAINING_SEEDS = (100, 101, 102, 103)
STRIDE = 2
"""Samples between the context's taps."""
AWAY = 10
"""Samples (0.5 s) each side of a label change left out of the "away" score."""


def _features(cache: dict, seed: int, scenario: str):
    if (seed, scenario) not in cache:
        cache[seed, scenario] = ride_features(simulate_scenario(scenario, repeats=7, seed=seed), derived=True)
    return cache[seed, scenario]


def _rows(cache, rides, channels, before, after):
    """Context rows, labels, scenario and distance (samples) to the nearest label change of every sample of
    ``rides`` ((seed, scenario, experiments)) that has a full context."""
    x, y, scenario, distance = [], [], [], []
    taps = np.arange(-before, after + 1, STRIDE)
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
            x.append(v[at[:, None] + taps[None, :]].reshape(len(at), -1))
            y.append(lab[at])
            scenario += [name] * len(at)
            distance.append(near[at])
    return np.vstack(x), np.concatenate(y), np.array(scenario), np.concatenate(distance)


def _tests(seed: int):
    return [(seed, name, range(1, 8) if name == "cruising" else range(2, 8)) for name in SCENARIOS]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--channels", default="acc_long,pitch_rate")
    parser.add_argument("--riders", choices=("protocol", "many"), default="protocol")
    parser.add_argument("--contexts", default="20:0,40:0,20:20", help="before:after pairs, samples")
    args = parser.parse_args()
    channels = tuple(args.channels.split(","))
    print(f"# supervised_ceiling {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {platform.machine()}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; Python {platform.python_version()}")
    print(f"# channels {','.join(channels)}; training riders: {args.riders}; test seeds {args.seeds}")
    print("| context (before:after) | windows | normal-braking | sudden-braking | cruising | all tests | "
          "all, away from changes | errors within 0.25 s of a change |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    cache: dict = {}
    for context in args.contexts.split(","):
        before, after = (int(v) for v in context.split(":"))
        hits = {s: [0, 0] for s in SCENARIOS}
        away, late = [0, 0], [0, 0]
        seeds = [None] if args.riders == "many" else args.seeds
        for train_seed in seeds:
            training = ([(s, n, range(1, 8)) for s in TRAINING_SEEDS for n in SCENARIOS] if train_seed is None
                        else [(train_seed, n, [1]) for n in SCENARIOS[:2]])
            x, y, _, _ = _rows(cache, training, channels, before, after)
            model = HistGradientBoostingClassifier(max_iter=200, random_state=0).fit(x, y)
            for test_seed in (args.seeds if train_seed is None else [train_seed]):
                xt, yt, scen, dist = _rows(cache, _tests(test_seed), channels, before, after)
                right = model.predict(xt) == yt
                for s in SCENARIOS:
                    hits[s][0] += int(right[scen == s].sum())
                    hits[s][1] += int((scen == s).sum())
                away[0] += int(right[dist > AWAY].sum())
                away[1] += int((dist > AWAY).sum())
                late[0] += int((~right & (dist <= AWAY // 2)).sum())
                late[1] += int((~right).sum())
        total = [sum(h[0] for h in hits.values()), sum(h[1] for h in hits.values())]
        cells = " | ".join(f"{100 * h[0] / h[1]:.2f}" for h in hits.values())
        kind = "causal" if after == 0 else "centred"
        print(f"| {before}:{after} ({kind}) | {args.riders} | {cells} | {100 * total[0] / total[1]:.2f} | "
              f"{100 * away[0] / away[1]:.2f} | {100 * late[0] / max(late[1], 1):.0f} % |", flush=True)


if __name__ == "__main__":
    start = time.perf_counter()
    main()
    print(f"\n# wall time {time.perf_counter() - start:.0f} s")
