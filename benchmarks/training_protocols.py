"""Lateral and road models: the training protocol of mixed rides against rides of one kind each, per test seed.

For each seed, the model (:data:`spotfree.evaluation.lateral_road.MODELS`) is trained spotting-free under several
protocols, each from the same four training riders (experiments 1-4) and scored on the same three held-out riders
(experiments 5-7 of the seed's file of the model's scenario, causal labels, per true class):

* ``mixed``: the riders' rides of the scenario (every kind of manoeuvre or road event in every ride) and of the other
  scenario (the models before 2026-11-24: lateral with 7 extra groups on ``yaw_rate`` and ``roll_rate``);
* ``one kind``: each rider's rides of one kind each and one without any
  (:data:`~spotfree.evaluation.lateral_road.KIND_RIDES`), naming rule 6 of :mod:`spotfree.naming` (the models
  now: lateral with 15 extra groups on the yaw rate alone); also without rule 6, for the lateral model with the
  roll rate too, and for the road model on the vibration levels without the speed (its channels before
  2026-11-24, at today's vibration time constant).

Each model labels the tests with kernel CRC_RLS (the product's classifier), with the nearest columns, and with
kernel CRC_RLS followed by the offline segment vote at the spec's penalty (:mod:`spotfree.classify.segments`), and
for the lateral model that followed by the event vote (the spec's ``events``) and then by its event edges (the spec's
``edges``). The spec's short classes (``detections``: kerbs) are also scored as events detected within 0.5 s
(:func:`~spotfree.evaluation.metrics.event_detection`), summed over the seeds.

Run: ``python benchmarks/training_protocols.py [--model lateral|road] [--seeds 0 1 2 3 4 5 6 7 100]
[--protocols "one kind" ...]``.
"""

from __future__ import annotations

import argparse
import datetime
import os
import time
import warnings
from dataclasses import replace

import numpy as np

from spotfree.classify.batch import classify_recording, offline_votes
from spotfree.evaluation.lateral_road import MODELS, detections, segment_options, spec_split
from spotfree.evaluation.metrics import Score, class_accuracy
from spotfree.sim.scenarios import CLASSES
from spotfree.training import train


def labellings(spec, model) -> dict[str, dict]:
    """Label column -> options of :func:`classify_recording` for ``model`` of ``spec``."""
    events = {"kcrc, segment and event vote": segment_options(replace(spec, edges=()), model)} if spec.events else {}
    edges = {"kcrc, both votes and event edges": segment_options(spec, model)} if spec.edges else {}
    return {"kcrc": {}, "nearest": {"method": "nearest"},
            "kcrc, segment vote": segment_options(replace(spec, events=False, edges=()), model), **events, **edges}


def protocols(name: str) -> dict[str, tuple]:
    """Name -> (spec, training changes) of each protocol compared for model ``name``."""
    spec = MODELS[name]
    if name == "road":
        return {"mixed": (replace(spec, one_kind=False), {}), "one kind": (spec, {}),
                "one kind, no rule 6": (spec, {"single_manoeuvre": False}),
                "one kind, vib_y vib_z over 10": (replace(spec, channels=("vib_y", "vib_z"), window=10), {})}
    both = ("yaw_rate", "roll_rate")
    return {"mixed": (replace(spec, channels=both, one_kind=False, extra_clusters=7), {}),
            "one kind": (spec, {}),
            "one kind, roll rate too": (replace(spec, channels=both), {}),
            "one kind, no rule 6": (spec, {"single_manoeuvre": False})}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=sorted(MODELS), default="lateral")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4, 5, 6, 7, 100])
    parser.add_argument("--protocols", nargs="+", metavar="NAME",
                        help="only these protocols (default: all; 'one kind' is the product's)")
    args = parser.parse_args()
    chosen = protocols(args.model)
    if args.protocols:
        unknown = set(args.protocols) - set(chosen)
        if unknown:
            parser.error(f"unknown protocol {', '.join(sorted(unknown))}; choose from {', '.join(chosen)}")
        chosen = {name: chosen[name] for name in args.protocols}
    warnings.simplefilter("ignore")
    now = datetime.datetime.now(datetime.timezone.utc)
    print(f"# training_protocols --model {args.model} {now:%Y-%m-%d %H:%M} UTC: {os.cpu_count()} cores (shared), "
          f"load average {os.getloadavg()[0]:.1f}")
    classes = CLASSES[MODELS[args.model].scenario]
    print(f"| seed | protocol | labels | {' | '.join(classes)} | all | classes with columns | training s |")
    print("|---:|---|---|" + "---:|" * (len(classes) + 1) + "---|---:|")
    overall, events = {}, {}
    for seed in args.seeds:
        splits = {}  # one simulation per training protocol (mixed or one kind) and seed
        for name, (spec, changes) in chosen.items():
            if spec.one_kind not in splits:
                splits[spec.one_kind] = spec_split(spec, seed)
            data = splits[spec.one_kind]
            start = time.perf_counter()
            model = train(data.training, spec.config(seed, **changes)).model
            seconds = time.perf_counter() - start
            causal = classify_recording(model, data.test)
            for labelling, options in labellings(spec, model).items():
                labels = (offline_votes(model, data.test, causal, **options) if "method" not in options else
                          classify_recording(model, data.test, **options)).label
                per_class = class_accuracy(labels, data.test.truth["label"], classes)
                total = sum(per_class.values(), Score(0, 0))
                overall.setdefault((name, labelling), []).append([s.rate for s in per_class.values()] + [total.rate])
                for event, found in detections(spec, labels, data.test).items():
                    key = (name, labelling, event)
                    events[key] = events[key] + found if key in events else found
                print(f"| {seed} | {name} | {labelling} | " + " | ".join(f"{s.rate:.3f}" for s in per_class.values())
                      + f" | {total.rate:.3f} | {len(model.classes)} | {seconds:.0f} |", flush=True)
    print()
    print(f"| protocol | labels | mean over the seeds: {' | '.join(classes)} | all | lowest seed, all |")
    print("|---|---|" + "---:|" * (len(classes) + 2))
    for (name, labelling), rates in overall.items():
        means = np.nanmean(np.array(rates), axis=0)
        print(f"| {name} | {labelling} | " + " | ".join(f"{m:.3f}" for m in means)
              + f" | {np.min(np.array(rates)[:, -1]):.3f} |")
    if events:
        print()
        print("| protocol | labels | class | events detected | false alarms | per hour of riding |")
        print("|---|---|---|---:|---:|---:|")
        for (name, labelling, event), found in events.items():
            print(f"| {name} | {labelling} | {event} | {found.detected} / {found.events} ({found.rate:.3f}) | "
                  f"{found.false_alarms} | {found.false_alarms_per_hour:.0f} |")


if __name__ == "__main__":
    main()
