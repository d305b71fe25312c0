"""Ride store write rate: acknowledged batches per second on SQLite (synchronous FULL and NORMAL) and, when a
``postgresql://`` URL is given, on PostgreSQL; one batch = 10 raw samples (0.5 s at 20 Hz) with features and labels,
one transaction each, as the service writes a phone's batch.

    python benchmarks/ride_store_commit.py [--batches 300] [--postgres URL]

Writes ``benchmarks/results/ride_store_commit.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from machine import results_file
from spotfree.ride.records import FEATURE_COLUMNS
from spotfree.ride.store import RideStore

SAMPLES = 10


def run(location: str, synchronous: str, batches: int) -> tuple[float, float]:
    """(batches per second, median ms per batch) for ``batches`` acknowledged appends."""
    with RideStore(location, synchronous=synchronous) as store:
        _, token = store.register_device("bench")
        ride = store.start_ride(token, "segway", "bench", model="m")
        rng = np.random.default_rng(0)
        took = []
        start = time.perf_counter()
        for k in range(batches):
            t = (k * SAMPLES + np.arange(SAMPLES)) / 20.0
            samples = {c: rng.normal(0, 1, SAMPLES) for c in ("ax", "ay", "gx", "gy", "gz")}
            samples.update(time=t, az=np.full(SAMPLES, 9.81))
            features = {c: rng.normal(0, 1, SAMPLES) for c in FEATURE_COLUMNS}
            began = time.perf_counter()
            store.append_samples(token, ride, samples, features=features, labels={"m": ["cruising"] * SAMPLES})
            took.append(time.perf_counter() - began)
        total = time.perf_counter() - start
    return batches / total, 1e3 * float(np.median(took))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--batches", type=int, default=300)
    parser.add_argument("--postgres", default=None)
    args = parser.parse_args()
    with results_file("ride_store_commit", "Ride store: acknowledged write rate", ("numpy", "psycopg")):
        print(f"{args.batches} batches of {SAMPLES} samples, one commit each.\n")
        print("| store | batches/s | samples/s | median ms/batch |")
        print("|---|---:|---:|---:|")
        with tempfile.TemporaryDirectory(dir=Path.cwd()) as folder:
            for synchronous in ("full", "normal"):
                rate, median = run(str(Path(folder) / f"{synchronous}.db"), synchronous, args.batches)
                print(f"| SQLite WAL, synchronous={synchronous} | {rate:.0f} | {rate * SAMPLES:.0f} | {median:.2f} |")
        if args.postgres:
            rate, median = run(args.postgres, "full", args.batches)
            print(f"| PostgreSQL (synchronous_commit=on) | {rate:.0f} | {rate * SAMPLES:.0f} | {median:.2f} |")


if __name__ == "__main__":
    main()
