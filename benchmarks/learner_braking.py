"""The general learner on the simulator's braking protocol, with and without the ride prior, beside supervised
MiniRocket trained with every label on the same rides.

Protocol (issue 31): per seed, experiment 1 of the normal-braking, sudden-braking and cruising files (one ride per
scenario, each declared with its scenario's classes: :data:`spotfree.sim.scenarios.CLASSES`) trains; experiments
2-7 of each file are the test. Per-sample accuracy of centred labels per scenario, leaving out the samples within
0.5 s of a true change ("away"), the strict figure beside; and per seed the lowest per-class accuracy away from true
changes over all tests, as the goals table of ``spotfree evaluate`` reads one seed. One row trains as ``spotfree
evaluate`` and the shipped default model do: on the normal-braking and sudden-braking rides only (no cruising ride),
so that a single ride declares sudden braking and a single one does not. Every spotfree row is the ``braking`` preset's
learner (:func:`spotfree.presets.preset_learner`: its channels, window and column share), with the representation or
the prior its name says. The "true names" row is that learner with every training window named by the true label at
its centre (``real_har.TrueNames``): the same windows, columns and classifier, so what the dictionary and kernel
CRC_RLS reach on these rides when the naming is perfect.

    python benchmarks/learner_braking.py [--seeds 0 1 2 3 4]

Writes ``benchmarks/results/learner_braking.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import sys
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from machine import describe
from real_har import TrueNames, named_right
from spotfree.evaluation.metrics import near_transitions
from spotfree.evaluation.peers import MiniRocketPeer
from spotfree.presets import preset_learner
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario

RESULTS = Path(__file__).resolve().parent / "results" / "learner_braking.md"
SCENARIOS = ("normal-braking", "sudden-braking", "cruising")
CHANNELS = ("acc_long", "pitch_rate")


def methods():
    """Per row: the model and the scenarios whose experiment 1 it trains on."""
    def hankel():  # the braking preset's learner: hankel windows, the ride prior, its column share
        return preset_learner("braking")

    return {
        "spotfree, hankel, ride prior": (hankel, SCENARIOS),
        "spotfree, hankel, ride prior, two rides (as spotfree evaluate)": (hankel, SCENARIOS[:2]),
        "spotfree, summary, ride prior": (lambda: preset_learner("braking", representation="summary"), SCENARIOS),
        "spotfree, hankel, no prior": (lambda: preset_learner("braking", prior=None), SCENARIOS),
        "spotfree, hankel, ride prior, true names": (lambda: TrueNames(**hankel().get_params()), SCENARIOS),
        "MiniRocket (every label)": (lambda: MiniRocketPeer(channels=CHANNELS, alignment="centred"), SCENARIOS),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    args = parser.parse_args()
    hits = {m: {s: np.zeros(4) for s in SCENARIOS} for m in methods()}
    lowest = {m: [] for m in methods()}  # per seed: (class, accuracy) of the class labelled worst
    right = {m: [] for m in methods()}  # per seed: share of the learner's training windows named right
    for seed in args.seeds:
        feats = {s: ride_features(simulate_scenario(s, repeats=7, seed=seed), derived=True) for s in SCENARIOS}
        for name, (make, trained_on) in methods().items():
            model, train = make(), [feats[s].select_experiment(1) for s in trained_on]
            if isinstance(model, MiniRocketPeer):
                model.fit(train)
            else:
                model.set_params(seed=seed).fit(train, [CLASSES[s] for s in trained_on])
                if not isinstance(model, TrueNames):
                    right[name].append(100 * named_right(model, train))
            per_class: dict[str, np.ndarray] = {}
            for s in SCENARIOS:
                for k in range(2, 8):
                    rec = feats[s].select_experiment(k)
                    predicted, truth = np.asarray(model.predict(rec)).astype(str), rec.truth["label"]
                    labelled = predicted != ""
                    away = labelled & ~near_transitions(truth, rate=rec.rate)
                    hits[name][s] += [np.sum(predicted[away] == truth[away]), away.sum(),
                                      np.sum(predicted[labelled] == truth[labelled]), labelled.sum()]
                    for c in np.unique(truth[away]):
                        per_class.setdefault(str(c), np.zeros(2))
                        per_class[str(c)] += [np.sum(predicted[away & (truth == c)] == c), np.sum(away & (truth == c))]
            worst = min(per_class, key=lambda c: per_class[c][0] / per_class[c][1])
            lowest[name].append((worst, 100 * per_class[worst][0] / per_class[worst][1]))
            print(seed, name, {s: round(h[0] / h[1], 4) for s, h in hits[name].items()}, file=sys.stderr)
    lines = ["# The general learner on the simulator's braking protocol", "",
             f"- command: `python benchmarks/learner_braking.py {' '.join(sys.argv[1:])}`",
             f"- machine: {describe()}", f"- date: {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
             f"- seeds {', '.join(map(str, args.seeds))}; channels {', '.join(CHANNELS)}; centred labels; "
             "accuracy per scenario away from true changes (0.5 s), strict in brackets", "",
             "| method | " + " | ".join(SCENARIOS) + " |", "|---|" + "---|" * len(SCENARIOS)]
    for name, per in hits.items():
        lines.append(f"| {name} | " + " | ".join(f"{100 * h[0] / h[1]:.1f} % ({100 * h[2] / h[3]:.1f} %)"
                                                  for h in per.values()) + " |")
    lines += ["", "Lowest per-class accuracy away from true changes over all tests, per seed (centred labels):", "",
              "| method | " + " | ".join(f"seed {seed}" for seed in args.seeds) + " | mean |",
              "|---|" + "---|" * (len(args.seeds) + 1)]
    for name, per_seed in lowest.items():
        lines.append(f"| {name} | " + " | ".join(f"{a:.1f} % ({c})" for c, a in per_seed)
                     + f" | {np.mean([a for _, a in per_seed]):.1f} % |")
    lines += ["", "Training windows named right (the learner's final names against the true label at each window's centre, "
              "which the learner never sees), per seed:", "",
              "| method | " + " | ".join(f"seed {seed}" for seed in args.seeds) + " | mean |",
              "|---|" + "---|" * (len(args.seeds) + 1)]
    lines += [f"| {name} | " + " | ".join(f"{a:.1f} %" for a in shares) + f" | {np.mean(shares):.1f} % |"
              for name, shares in right.items() if shares]
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
