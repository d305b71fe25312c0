"""Issue 35's goals over several seeds: ``spotfree evaluate`` run once per seed, its goals table gathered.

The goals table of ``spotfree evaluate`` reads one seed; the simulated riders, the training rides and the learner's
random choices all follow the seed, and a model's lowest class can move by ten points from one seed to the next. This
runs the whole evaluation (:func:`spotfree.evaluation.run.evaluate`, the paper's protocol) for every seed, each into
a temporary folder, and prints per goal the figure it reads (per-sample rows: the lowest class's accuracy away from
true changes; events: F1), offline / live, for every seed; their mean and lowest; and on how many seeds the goal
was met and the model was at or above its supervised MiniRocket peer.

    python benchmarks/evaluate_seeds.py [--seeds 0 1 2 3 4] [--quick]

Writes ``benchmarks/results/evaluate_seeds.md`` (command, machine, date, tables).
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

from machine import results_file
from spotfree.evaluation.report import GOALS, Goal, goals, markdown_table
from spotfree.evaluation.run import evaluate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    parser.add_argument("--quick", action="store_true", help="spotfree evaluate --quick (for a smoke run)")
    args = parser.parse_args()
    runs = {}
    with tempfile.TemporaryDirectory() as folder:
        for seed in args.seeds:
            print(f"seed {seed}: spotfree evaluate", flush=True, end="")
            ev = evaluate(f"{folder}/seed-{seed}", seed=seed, quick=args.quick)
            runs[seed] = goals(ev)
            print(f" ({ev.seconds:.0f} s)", flush=True)
    with results_file("evaluate_seeds", "Issue 35's goals over seeds (spotfree evaluate once per seed)"):
        print(report(runs, args.quick))


def report(runs: dict[int, list[Goal]], quick: bool) -> str:
    """Markdown: per goal, offline / live per seed, their mean and lowest, the seeds meeting it."""
    header = ["goal", *[f"seed {s}" for s in runs], "mean", "lowest", "goal met", "at or above the peer",
              "peer mean"]
    rows = []
    for row in zip(*runs.values()):  # one goal, every seed
        first = row[0]
        off, live = np.array([g.offline for g in row]), np.array([g.live for g in row])
        peers = np.array([g.peer for g in row if g.peer is not None])

        def figure(value: float) -> str:
            return f"{value:.3f}" if first.events else f"{100 * value:.1f}"

        rows.append([first.name, *[f"{figure(a)} / {figure(b)}" for a, b in zip(off, live)],
                     f"{figure(off.mean())} / {figure(live.mean())}", f"{figure(off.min())} / {figure(live.min())}",
                     _seeds_with([g.met for g in row]), _seeds_with([g.above_peer for g in row]),
                     " / ".join(map(figure, peers.mean(axis=0))) if len(peers) else "-"])
    protocol = "spotfree evaluate --quick (two experiments per scenario: a smoke run)" if quick else \
        "spotfree evaluate (the paper's protocol)"
    return f"""Protocol: {protocol}, once per seed; every figure is the one its goals table reads.
Per-sample rows: the lowest per-class accuracy (%) away from true changes, offline / live (goal: >=
{100 * GOALS['offline']:g} / >= {100 * GOALS['live']:g}; hand postures {100 * GOALS['postures']:g}, gestures >=
{100 * GOALS['gestures offline']:g} / >= {100 * GOALS['gestures live']:g}). Events: F1 offline / live (goal: >=
{GOALS['event_f1']:g} with at most {GOALS['alarms_per_hour']:g} false alarms per hour). The peer is MiniRocket trained
with every label on the same rides, offline / live, the supervised ceiling of each figure; "at or above the peer":
offline at least the peer's offline, live at least its live.

""" + markdown_table(header, rows)


def _seeds_with(checks: list[bool | None]) -> str:
    """``k of n``: the seeds where a check held, of those where it applies (``-`` where it applies to none)."""
    known = [c for c in checks if c is not None]
    return f"{sum(known)} of {len(known)}" if known else "-"


if __name__ == "__main__":
    main()
