"""Training cost of the general learner against the amount of data: time and peak memory at four sizes, and the
fitted exponent ``b`` of ``cost ~ size^b`` (1: linear).

Data: generated recordings of 2 minutes at 20 Hz with as many channels as a body-worn log has
(:data:`spotfree.signal.body.BODY_CHANNELS`), each carrying three periodic motions, a level and rest (each recording
declares the two or three classes it holds), 7.5 to 60 minutes in all.
Each size is fitted in a fresh process, so its peak resident memory (``ru_maxrss``) is its own.

    python benchmarks/learner_scale.py [--minutes 7.5 15 30 60]

Writes ``benchmarks/results/learner_scale.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from machine import describe

RESULTS = Path(__file__).resolve().parent / "results" / "learner_scale.md"
RATE = 20.0
KINDS = {"rest": (0.0, 0.0), "walk": (2.0, 1.0), "run": (3.0, 2.5), "cycle": (1.0, 1.5), "lean": (0.0, -2.0)}
"""Class: (frequency Hz, amplitude or level)."""


def recordings(minutes: float, seed: int = 0):
    from spotfree.io.recording import Recording
    from spotfree.signal.body import BODY_CHANNELS

    width = len(BODY_CHANNELS)
    rng = np.random.default_rng(seed)
    names = list(KINDS)
    out, sets = [], []
    for k in range(int(round(minutes / 2))):
        chosen = ["rest"] + list(rng.choice(names[1:], size=rng.integers(1, 3), replace=False))
        parts = []
        while sum(len(p) for p in parts) < 2 * 60 * RATE:
            kind = chosen[rng.integers(len(chosen))]
            n = int(rng.uniform(3, 12) * RATE)
            f, a = KINDS[kind]
            t = np.arange(n) / RATE
            base = a * np.sin(2 * np.pi * f * t + rng.uniform(0, 6)) if f else np.full(n, a)
            parts.append(base[:, None] * rng.uniform(0.5, 1.5, width) + rng.normal(0, 0.2, (n, width)))
        x = np.vstack(parts)[: int(2 * 60 * RATE)]
        out.append(Recording(time=np.arange(len(x)) / RATE, channels={f"c{i}": x[:, i] for i in range(width)},
                             rate=RATE, source=f"r{k}"))
        sets.append(sorted(set(chosen)))
    return out, sets


def child(minutes: float) -> None:
    from spotfree.learner import SetSupervisedLearner

    recs, sets = recordings(minutes)
    start = time.perf_counter()
    learner = SetSupervisedLearner(seed=0).fit(recs, sets)
    seconds = time.perf_counter() - start
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({"minutes": minutes, "windows": int(sum(len(e) for e in learner.window_ends_)),
                      "seconds": seconds, "peak_mb": peak_mb}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=float, nargs="+", default=[7.5, 15.0, 30.0, 60.0])
    parser.add_argument("--child", type=float, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        child(args.child)
        return
    rows = []
    for m in args.minutes:
        proc = subprocess.run([sys.executable, __file__, "--child", str(m)], capture_output=True, text=True, check=True)
        rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        print(rows[-1], file=sys.stderr)
    size = np.log([r["windows"] for r in rows])
    b_time = np.polyfit(size, np.log([r["seconds"] for r in rows]), 1)[0]
    b_mem = np.polyfit(size, np.log([r["peak_mb"] for r in rows]), 1)[0]
    lines = ["# Training cost of the general learner against the amount of data", "",
             f"- command: `python benchmarks/learner_scale.py {' '.join(sys.argv[1:])}`".replace("  ", " "),
             f"- machine: {describe()}", f"- date: {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
             "- goal (issue 31): an hour of 20 Hz recordings in under 30 s and under 1 GB", "",
             "| minutes of 20 Hz data | windows | fit s | peak resident MB |", "|---|---|---|---|"]
    lines += [f"| {r['minutes']:g} | {r['windows']} | {r['seconds']:.1f} | {r['peak_mb']:.0f} |" for r in rows]
    lines += ["", f"Fitted exponent (cost ~ windows^b): time b = {b_time:.2f}, peak memory b = {b_mem:.2f} "
              "(memory includes the interpreter and libraries)."]
    RESULTS.parent.mkdir(exist_ok=True)
    RESULTS.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
