"""Change points for the segment vote: spotfree's compiled PELT against ``ruptures.Pelt(model="l2", jump=1)``.

Signals: piecewise-constant means (segments of 100-200 samples, unit-variance noise), standardised, one channel, as
the lateral model's yaw rate; penalty 4, shortest segment 3 samples. At 20 Hz, 1,300 samples are one simulated ride
(65 s), 72,000 an hour. Each time is the best of ``--repeats`` runs (ruptures: one run above 5,000 samples); both
must return the same breakpoints.

Run: ``python benchmarks/segment_speed.py [--sizes 1300 5000 20000 72000] [--repeats 3]``; writes
``benchmarks/results/segment_speed.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import ruptures

from machine import results_file
from spotfree.votes.segments import MIN_SIZE, change_points

PENALTY = 4.0
RUPTURES_UP_TO = 20000
"""Longest signal ruptures is timed on (its time grows faster than the length)."""


def signal(n: int, rng: np.random.Generator) -> np.ndarray:
    pieces = [rng.normal(rng.normal(0.0, 1.0), 0.5, int(rng.integers(100, 200))) for _ in range(n // 100 + 1)]
    x = np.concatenate(pieces)[:n]
    return ((x - x.mean()) / x.std())[:, None]


def best_of(repeats: int, run) -> tuple[float, np.ndarray]:
    times, result = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        result = run()
        times.append(time.perf_counter() - start)
    return min(times), np.asarray(result)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1300, 5000, 20000, 72000])
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    with results_file("segment_speed", "Change points for the segment vote: compiled PELT against ruptures",
                      ("numpy", "numba", "ruptures")):
        table(args.sizes, args.repeats)


def table(sizes: list[int], repeats: int) -> None:
    """Print one row per signal length: segments found, both times, their ratio, equal breakpoints."""
    change_points(signal(100, np.random.default_rng(0)), PENALTY)  # compile
    print("| samples | segments | spotfree (ms) | ruptures (ms) | ratio | same breakpoints |")
    print("|---:|---:|---:|---:|---:|---|")
    rng = np.random.default_rng(0)
    for n in sizes:
        x = signal(n, rng)
        ours, ends = best_of(repeats, lambda: change_points(x, PENALTY))
        if n <= RUPTURES_UP_TO:
            pelt = ruptures.Pelt(model="l2", min_size=MIN_SIZE, jump=1).fit(x)
            theirs, reference = best_of(repeats if n <= 5000 else 1, lambda: pelt.predict(pen=PENALTY))
            cells = f"{1e3 * theirs:.0f} | {theirs / ours:.0f} | {np.array_equal(ends, reference)}"
        else:
            cells = "- | - | -"
        print(f"| {n} | {len(ends)} | {1e3 * ours:.2f} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
