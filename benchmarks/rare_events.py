"""A short rare event learnt from clips that only say whether it happens in them: sudden stops on the simulator,
as a new user would train on car trips (issue 31's car protocol), beside supervised peers on the same clips.

Protocol: per seed, rides 1-2 of the simulator's normal-braking, sudden-braking and cruising files (six rides) are
cut into clips of ``--clip`` seconds on their ride features; a clip declares ``sudden-braking, other`` when a sudden
stop happens in it and ``other`` when none does (every other class is ``other``). Rides 3-7 of each file are the test.
Sudden stops are scored as events (:func:`spotfree.evaluation.metrics.event_detection`: a true run detected by a run
of its label within 0.5 s; a run that meets none is a false alarm): precision, recall, F1 and false alarms per hour
of riding without a stop, offline (centred windows) and live (causal windows); and the balanced per-sample accuracy
away from true changes (0.5 s).

Methods in the same run:

* ``spotfree``: :class:`spotfree.learner.SetSupervisedLearner` with its defaults on every ride channel, as
  ``spotfree train --sets`` trains with no option; the same with ``share_power`` 1 (``--share-power 1``: names
  weighed by the class shares, so that the rare event claims less), with ``column_share`` 0.25 (``--column-share
  0.25``: columns from the quarter of each class's windows named most surely, so that fewer of the windows the event
  claims beyond itself become its columns), with both; and on the braking model's channels (``acc_long,
  pitch_rate``);
* ``MiniRocket`` and ``1-NN``: sliding-window peers trained on the same clips and channels (every ride channel) with
  every sample's label, once per alignment.

    python benchmarks/rare_events.py [--seeds 0 1 2 3 4] [--clip 10]

Writes ``benchmarks/results/rare_events.md`` (command, machine, date, tables).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from machine import results_file
from real_har import clips
from spotfree.evaluation.metrics import EventScore, event_detection, near_transitions
from spotfree.evaluation.peers import MiniRocketPeer, NearestNeighbourPeer
from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario

SCENARIOS = ("normal-braking", "sudden-braking", "cruising")
EVENT, OTHER = "sudden-braking", "other"
BRAKING_CHANNELS = ("acc_long", "pitch_rate")
LEARNERS = {
    "spotfree, every ride channel": {},
    "spotfree, every ride channel, --share-power 1": {"share_power": 1.0},
    "spotfree, every ride channel, --column-share 0.25": {"column_share": 0.25},
    "spotfree, every ride channel, --share-power 1 --column-share 0.25": {"share_power": 1.0, "column_share": 0.25},
    "spotfree, acc_long and pitch_rate": {"channels": BRAKING_CHANNELS},
}
"""The learners compared, by name: :class:`~spotfree.learner.SetSupervisedLearner`'s parameters beyond its
defaults."""
METHODS = (*LEARNERS, "MiniRocket (every label)", "1-NN (every label)")
MINIROCKET_KERNELS = 2_016
"""MiniRocket features, as in ``real_har.py`` (aeon rounds to a multiple of 84)."""


def two_classes(rec: Recording) -> Recording:
    """``rec`` with its truth ``sudden-braking`` or ``other``."""
    out = rec.take(slice(None))
    out.truth["label"] = np.where(rec.truth["label"] == EVENT, EVENT, OTHER)
    return out


def score(predicted: list[np.ndarray], tests: list[Recording]) -> dict:
    """The events and the balanced accuracy away from true changes of ``predicted`` on ``tests``."""
    pred = np.concatenate(predicted).astype(str)
    truth = np.concatenate([r.truth["label"] for r in tests]).astype(str)
    ride = np.concatenate([np.full(len(r), k) for k, r in enumerate(tests)])
    away = ~np.concatenate([near_transitions(r.truth["label"], rate=r.rate) for r in tests]) & (pred != "")
    recall = [np.mean(pred[away & (truth == c)] == c) for c in (EVENT, OTHER)]
    return {"events": event_detection(pred, truth, EVENT, ride, tests[0].rate), "balanced": float(np.mean(recall))}


def run(seed: int, seconds: float) -> tuple[dict, str]:
    """``{method: {"offline": score, "live": score}}`` for one seed, and what it trained on."""
    feats = {s: ride_features(simulate_scenario(s, repeats=7, seed=seed), derived=True) for s in SCENARIOS}
    train = [c for s in SCENARIOS for k in (1, 2) for c in clips(two_classes(feats[s].select_experiment(k)), seconds)]
    tests = [two_classes(feats[s].select_experiment(k)) for s in SCENARIOS for k in range(3, 8)]
    sets = [sorted(set(c.truth["label"])) for c in train]
    out = {}
    learners = {name: SetSupervisedLearner(**params, seed=seed) for name, params in LEARNERS.items()}
    for name, learner in learners.items():
        learner.fit(train, sets)
        out[name] = {"offline": score([learner.predict(r) for r in tests], tests),
                     "live": score([learner.predict(r, centred=False) for r in tests], tests)}
    channels = tuple(learners[METHODS[0]].model_.channels)
    peers = dict(zip(METHODS[len(LEARNERS):], (lambda a: MiniRocketPeer(channels=channels, alignment=a,
                                                            n_kernels=MINIROCKET_KERNELS),
                                   lambda a: NearestNeighbourPeer(channels=channels, alignment=a))))
    for name, make in peers.items():
        centred, causal = make("centred").fit(train), make("causal").fit(train)
        out[name] = {"offline": score([centred.predict(r) for r in tests], tests),
                     "live": score([causal.predict(r) for r in tests], tests)}
    for name in METHODS:
        print(f"seed {seed} {name}: offline F1 {out[name]['offline']['events'].f1:.3f}, live F1 "
              f"{out[name]['live']['events'].f1:.3f}", file=sys.stderr)
    declared = sum(EVENT in s for s in sets)
    return out, f"{len(train)} clips, {declared} declaring {EVENT}; {len(tests)} test rides"


def cell(e: EventScore) -> str:
    return (f"{e.detected} / {e.events}, {e.false_alarms} false ({e.false_alarms_per_hour:.0f} per h), "
            f"{e.precision:.2f} / {e.rate:.2f} / {e.f1:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--clip", type=float, default=10.0, help="clip length, s")
    args = parser.parse_args()
    if args.clip <= 0:
        parser.error("--clip takes seconds > 0")
    with results_file("rare_events", "A short rare event learnt from clips that only say whether it happens in them"):
        runs = {seed: run(seed, args.clip) for seed in args.seeds}
        results = {seed: per for seed, (per, _) in runs.items()}
        print(f"Clips of {args.clip:g} s. Events: detected / true, false alarms (per hour without a stop), precision "
              "/ recall / F1. Balanced: mean recall of the two classes away from true changes (0.5 s).\n")
        print("| seed | method | offline: events | offline: balanced | live: events | live: balanced |")
        print("|---|---|---|---|---|---|")
        for seed, per in results.items():
            for name, r in per.items():
                print(f"| {seed} | {name} | {cell(r['offline']['events'])} | {100 * r['offline']['balanced']:.1f} % "
                      f"| {cell(r['live']['events'])} | {100 * r['live']['balanced']:.1f} % |")
        print("\nTraining per seed: " + "; ".join(f"seed {s}: {trained}" for s, (_, trained) in runs.items()))
        print("\nOver the seeds (events summed):\n")
        print("| method | offline: events | live: events |")
        print("|---|---|---|")
        for name in METHODS:
            total = {mode: sum((per[name][mode]["events"] for per in results.values()), EventScore(0, 0, 0, 0.0))
                     for mode in ("offline", "live")}
            print(f"| {name} | {cell(total['offline'])} | {cell(total['live'])} |")


if __name__ == "__main__":
    main()
