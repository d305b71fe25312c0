"""Segment-vote penalty per model on development seeds: per-class accuracy of the lateral and road models' labels
after the offline segment vote (:mod:`spotfree.classify.segments`) at each penalty, 0 being the causal labels; with
``--edges``, after the spec's votes with its event edges at each level instead (0: none).

Protocol of :mod:`spotfree.evaluation.lateral_road` (the spec's training; experiments 5-7 of each seed held out),
kernel CRC_RLS, causal windows; the road model keeps its kerb labels (the spec's ``keep``).

Run: ``python benchmarks/segment_penalty.py [--model lateral|road] [--seeds 100 101 102 103]
[--penalties 0.5 1 2 4 8 | --edges 0.07 0.08 0.09 0.1 0.11]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import warnings
from dataclasses import replace

import numpy as np

from spotfree.classify.batch import classify_recording, offline_votes
from spotfree.evaluation.lateral_road import MODELS, score_labels, segment_options, spec_split
from spotfree.sim.scenarios import CLASSES
from spotfree.training import train


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=sorted(MODELS), default="lateral")
    parser.add_argument("--seeds", type=int, nargs="+", default=[100, 101, 102, 103])
    parser.add_argument("--penalties", type=float, nargs="+", default=[0.5, 1, 2, 4, 8])
    parser.add_argument("--edges", type=float, nargs="+", help="event-edge levels of the spec's edge channel")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    spec = MODELS[args.model]
    if args.edges and not spec.edges:
        parser.error(f"the {args.model} model's spec has no event-edge channel")
    classes = CLASSES[spec.scenario]
    now = datetime.datetime.now(datetime.timezone.utc)
    print(f"# segment_penalty --model {args.model} {now:%Y-%m-%d %H:%M} UTC: {os.cpu_count()} cores (shared), "
          f"load average {os.getloadavg()[0]:.1f}; kept: {', '.join(spec.keep) or 'none'}")
    setting = f"{spec.edges[0][0]} edge (penalty {spec.segments:g})" if args.edges else "penalty"
    if args.edges:
        channel = spec.edges[0][0]
        specs = [(level, replace(spec, edges=((channel, level),) if level else ())) for level in [0.0, *args.edges]]
    else:
        specs = [(p, replace(spec, segments=p)) for p in [0.0, *args.penalties]]
    print(f"| seed | {setting} | {' | '.join(classes)} | all |")
    print("|---:|---:|" + "---:|" * (len(classes) + 1))
    rates: dict[float, list] = {}
    for seed in args.seeds:
        data = spec_split(spec, seed)
        model = train(data.training, spec.config(seed)).model
        causal = classify_recording(model, data.test)
        for value, variant in specs:
            options = segment_options(variant, model) if variant.segments else {}
            per_class, overall = score_labels(offline_votes(model, data.test, causal, **options).label, data.test,
                                              spec.scenario)
            row = [s.rate for s in per_class.values()] + [overall.rate]
            rates.setdefault(value, []).append(row)
            print(f"| {seed} | {value:g} | " + " | ".join(f"{r:.3f}" for r in row) + " |", flush=True)
    print(f"\n| {setting} | mean over the seeds: {' | '.join(classes)} | all | lowest class: mean over the seeds | "
          "on any seed |")
    print("|---:|" + "---:|" * (len(classes) + 3))
    for value, rows in rates.items():
        lowest = np.nanmin(np.array(rows)[:, :-1], axis=1)
        print(f"| {value:g} | " + " | ".join(f"{m:.3f}" for m in np.nanmean(rows, axis=0))
              + f" | {lowest.mean():.3f} | {lowest.min():.3f} |")


if __name__ == "__main__":
    main()
