"""The evaluation's protocol (``spotfree evaluate``) over several simulator seeds, spotfree's classifiers only.

Per seed: simulate the three scenarios (7 experiments each), train the dictionary without labels on experiment 1 of
the normal- and sudden-braking files (:mod:`spotfree.evaluation.protocol`), then label every test sample with
CRC_RLS, kernel CRC_RLS and the nearest-columns rule on the same dictionary, causal and centred windows. Printed:
dictionary purity and columns per class (cruising / normal / sudden), per-sample accuracy per scenario and over all
tests, and the sudden-braking labels inside the normal-braking tests (the paper's count: 6 of 7800). The report of
one seed (``spotfree evaluate``) adds the supervised peers; this shows how much the figures move with the seed.
``--peers`` also runs the supervised MiniRocket and 1-NN peers of the report (causal windows, every training label;
needs aeon: ``pip install -e '.[eval]'``) on the same tests.

``--set FIELD=VALUE`` changes a field of the training's configuration (:class:`~spotfree.training.TrainingConfig`;
the value read as a Python literal), to compare a rule with and without it.

    python benchmarks/evaluation_seeds.py --seeds 0 1 2 3 4 [--peers] [--set upright=0]
"""

from __future__ import annotations

import argparse
import ast
import os
import platform
import time
from datetime import datetime, timezone

import numpy as np

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.evaluation.measure import make_peers, peer_runs
from spotfree.evaluation.protocol import SCENARIOS, Protocol, simulate, train_dictionary
from spotfree.training import TrainingConfig, dictionary_purity

METHODS = ("crc", "kcrc", "nearest")
CLASSES = ("cruising", "normal-braking", "sudden-braking")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--peers", action="store_true", help="also the supervised MiniRocket and 1-NN peers")
    parser.add_argument("--set", nargs="+", action="extend", default=[], metavar="FIELD=VALUE",
                        help="change fields of the training configuration, e.g. upright=0 (repeatable)")
    args = parser.parse_args()
    changes = {}
    for item in args.set:
        field, _, value = item.partition("=")
        if field not in TrainingConfig.__dataclass_fields__ or not value:
            parser.error(f"--set {item}: give FIELD=VALUE with a field of TrainingConfig, e.g. upright=0")
        try:
            changes[field] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            parser.error(f"--set {item}: the value must be a Python literal (a number, True/False, a quoted string)")
    print(f"# evaluation_seeds {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; {platform.machine()}, "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}; Python {platform.python_version()}, "
          f"numpy {np.__version__}" + (f"; training changes {changes}" if changes else ""))
    print("| seed | purity c/n/s | columns c/n/s | method | windows | normal-braking | sudden-braking | cruising | "
          "all tests | sudden labels in normal tests |")
    print("|---:|---|---|---|---|---:|---:|---:|---:|---:|")
    totals = {(m, a): [0, 0] for m in METHODS for a in ("causal", "centred")}
    for seed in args.seeds:
        protocol = Protocol(seed=seed)
        data = simulate(protocol)
        trained = train_dictionary(data, protocol, changes)
        model = trained.result.model
        purity = dictionary_purity(trained.result, trained.experiments)
        columns = {c: int((model.column_class == i).sum()) for i, c in enumerate(model.classes)}
        pur = "/".join(f"{purity[c]:.2f}" if c in purity else "-" for c in CLASSES)
        cols = "/".join(str(columns.get(c, 0)) for c in CLASSES)
        for method in METHODS:
            for alignment in ("causal", "centred"):
                clf = dictionary_classifier(model, method, causal=alignment == "causal")
                labels = {s: classify_recording(model, data[s].test, method, centred=alignment == "centred",
                                                classifier=clf).label for s in SCENARIOS}
                _report(seed, pur, cols, method, alignment, labels, data, totals)
        if args.peers:
            peers = make_peers(model, protocol)
            peers = {name: peer for name, peer in peers.items() if "ClaSP" not in name}
            for name, runs in peer_runs(peers, data).items():
                labels = {s: runs.runs[s].decided() for s in SCENARIOS}
                _report(seed, "-", "-", name.split(" (")[0], "causal", labels, data, totals)
    print()
    print("| method | windows | all tests, all seeds |")
    print("|---|---|---:|")
    for (method, alignment), (right, total) in totals.items():
        print(f"| {method} | {alignment} | {100 * right / total:.2f} |")


def _report(seed, pur, cols, method, alignment, labels: dict, data, totals: dict) -> None:
    """Print one table row for ``labels`` (per scenario, ``""`` where unscored) and add it to ``totals``."""
    cells, right, total, false_sudden = [], 0, 0, ""
    for scenario in SCENARIOS:
        label = labels[scenario]
        scored = label != ""
        hits = int(np.sum(label[scored] == data[scenario].test.truth["label"][scored]))
        cells.append(f"{100 * hits / scored.sum():.2f}")
        right, total = right + hits, total + int(scored.sum())
        if scenario == "normal-braking":
            false_sudden = f"{int(np.sum(label == 'sudden-braking'))} of {int(scored.sum())}"
    counts = totals.setdefault((method, alignment), [0, 0])
    counts[0] += right
    counts[1] += total
    print(f"| {seed} | {pur} | {cols} | {method} | {alignment} | {' | '.join(cells)} | {100 * right / total:.2f} | "
          f"{false_sudden} |")


if __name__ == "__main__":
    start = time.perf_counter()
    main()
    print(f"\n# wall time {time.perf_counter() - start:.0f} s")
