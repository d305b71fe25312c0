"""Fleet processing throughput: rides and samples per second on a local Dask cluster of 1 and 2 workers.

Generates a fleet (``--rides``, seed 0), ingests it into a SQLite store, then runs ``process_fleet`` with
``redo=True`` for each worker count (cluster start-up timed apart from processing) and reports each worker's
peak resident memory (``ru_maxrss``). Usage: ``python benchmarks/fleet_throughput.py --rides 120``; writes
``benchmarks/results/fleet_throughput.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import os
import resource
import tempfile
import time
from pathlib import Path

from dask.distributed import Client, LocalCluster

from machine import results_file
from spotfree.fleet import generate_fleet, ingest_logs, process_fleet, read_manifest
from spotfree.ride.default_model import default_model
from spotfree.ride.store import RideStore


def _peak_rss_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--rides", type=int, default=120)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="fleet-bench-"))
    generate_fleet(folder / "logs", riders=30, rides=args.rides, seed=0)
    store = str(folder / "rides.db")
    with RideStore(store, synchronous="normal") as s:
        ingest_logs(s, read_manifest(folder / "logs" / "rides.csv", folder / "logs" / "riders.csv"))
    models = {"braking": default_model()}
    with results_file("fleet_throughput", "Fleet processing throughput on a local Dask cluster",
                      ("numpy", "dask", "distributed", "pyarrow")):
        print(f"{args.rides} simulated rides of 30 riders (seed 0), SQLite store, one braking model.\n")
        print("| workers | cluster start (s) | rides | samples | processing (s) | rides/s | samples/s | "
              "vs 1 worker | peak RSS per worker (MiB) | load average after |")
        print("|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|")
        throughput(store, folder / "out", models)


def throughput(store: str, out: Path, models: dict) -> None:
    """Print one row per worker count (1, 2): ``process_fleet`` of every ride of ``store`` into ``out``."""
    base = None
    for workers in (1, 2):
        t0 = time.perf_counter()
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None) as c, \
                Client(c) as client:
            start = time.perf_counter() - t0
            t1 = time.perf_counter()
            report = process_fleet(store, out, models, scheduler=c.scheduler_address, redo=True)
            elapsed = time.perf_counter() - t1
            rss = list(client.run(_peak_rss_mib).values())
        samples = sum(int(r["samples"]) for r in report.rows)
        rate = len(report.processed) / elapsed
        base = base or rate
        print(f"| {workers} | {start:.1f} | {len(report.processed)} | {samples} | {elapsed:.1f} | {rate:.2f} | "
              f"{samples / elapsed:.0f} | {rate / base:.2f}x | {', '.join(f'{m:.0f}' for m in rss)} | "
              f"{os.getloadavg()[0]:.1f} |", flush=True)


if __name__ == "__main__":
    main()
