"""Every stored ride processed in parallel on Dask distributed; results in Parquet (and PostgreSQL).

:func:`process_fleet` lists the store's ended rides, skips those already done with the same models, and maps
:func:`spotfree.fleet.process.process_ride` over the rest on a Dask cluster: a ``LocalCluster`` of ``workers``
single-threaded worker processes by default, or the existing cluster at ``scheduler`` (``tcp://HOST:PORT``);
the same tasks either way. A worker opens the store itself (its location is in the task), so a remote cluster
needs the store reachable from the workers (PostgreSQL, or a SQLite file on a shared path).

Output folder ``out``: ``rides/``, ``samples/`` and ``events/``, each partitioned as
``date=YYYY-MM-DD/vehicle=NAME/<ride_id>.parquet`` (``date`` the UTC day the ride started; the rides table
also holds both as columns). Read them with DuckDB, e.g.
``SELECT * FROM read_parquet('out/rides/**/*.parquet')``.

Idempotence and worker loss: a ride's files are written to temporary names and renamed into place, samples and
events first and the ``rides`` file last, so a ride is done exactly when its ``rides`` file exists. Files are a
function of the ride and the models (``config``: a digest of the models' arrays and metadata), so re-running
rewrites identical files or, by default, skips rides done with the same config. A task lost with a killed
worker is re-run by the scheduler on another worker and writes the same files under the same names: every ride
appears once.

With ``database`` (a ``postgresql://`` URL) the ride and event rows also go to the tables ``fleet_rides`` and
``fleet_events``, replaced ride by ride in one transaction.
"""

from __future__ import annotations

import hashlib
import json
import os
import urllib.parse
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import pandas as pd

from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.ride.records import Ride

TABLES = ("samples", "events", "rides")
"""Written in this order: a ride's ``rides`` file marks it done."""


@dataclass
class ProcessReport:
    """Rides processed now, rides skipped as done, and rides that failed with the reason."""

    processed: list[str] = field(default_factory=list)
    skipped: int = 0
    failed: dict[str, str] = field(default_factory=dict)
    rows: list[dict] = field(default_factory=list)

    def __str__(self) -> str:
        text = f"{len(self.processed)} rides processed, {self.skipped} already done"
        return text + "".join(f"\n  ride {r}: {why}" for r, why in self.failed.items())


def model_digest(models: dict[str, DictionaryModel]) -> str:
    """A digest of the models' names, arrays and metadata (what makes the results)."""
    h = hashlib.sha256()
    for name in sorted(models):
        h.update(name.encode())
        for key, value in sorted(vars(models[name]).items()):
            h.update(key.encode())
            h.update(value.tobytes() if hasattr(value, "tobytes") else json.dumps(value, default=str).encode())
    return h.hexdigest()[:16]


def partition(out: Path, table: str, date: str, vehicle: str) -> Path:
    """The folder of ``table``'s files of rides started on ``date`` on ``vehicle``."""
    return out / table / f"date={date}" / f"vehicle={urllib.parse.quote(vehicle, safe='')}"


def done_rides(out: Path, config: str) -> set[str]:
    """Ride ids whose results in ``out`` were made with ``config``."""
    files = list((out / "rides").glob("*/*/*.parquet"))
    if not files:
        return set()
    table = pd.concat([pd.read_parquet(f, columns=["ride_id", "config"]) for f in files])
    return set(table["ride_id"][table["config"] == config])


def process_fleet(store: str, out: str | Path, models: dict[str, DictionaryModel], *, scheduler: str | None = None,
                  workers: int = 2, database: str | None = None, redo: bool = False,
                  progress: Callable[[str], None] | None = None) -> ProcessReport:
    """Process the ended rides of the store at ``store`` into ``out`` (see the module docstring)."""
    from spotfree.ride.store import RideStore

    out = Path(out)
    config = model_digest(models)
    with RideStore(store) as source:
        rides = [r for r in source.rides() if r.ended is not None]
    done = set() if redo else done_rides(out, config)
    todo = [r for r in rides if r.ride_id not in done]
    report = ProcessReport(skipped=len(rides) - len(todo))
    if todo:
        _run_all(todo, store, out, models, config, scheduler, workers, report, progress)
    if database:
        write_database(database, out, [r.ride_id for r in rides])
    return report


def _run_all(todo: list[Ride], store: str, out: Path, models: dict[str, DictionaryModel], config: str,
             scheduler: str | None, workers: int, report: ProcessReport,
             progress: Callable[[str], None] | None) -> None:
    """Map :func:`run_ride` over ``todo`` on the cluster, filling ``report`` as rides finish."""
    from dask.distributed import Client, LocalCluster, as_completed

    if scheduler is None and workers < 1:
        raise InputError(f"fleet process: --workers {workers}; give at least 1")
    cluster = None if scheduler else LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                  dashboard_address=None)
    try:
        with Client(scheduler or cluster) as client:
            shared = client.submit(dict, models, key=f"models-{config}", pure=False)
            futures = client.map(run_ride, todo, store=store, out=str(out), models=shared, config=config,
                                 key=[f"ride-{r.ride_id}-{config}" for r in todo], retries=3)
            for future in as_completed(futures):
                ride_id, row, error = future.result()
                if error:
                    report.failed[ride_id] = error
                else:
                    report.processed.append(ride_id)
                    report.rows.append(row)
                if progress:
                    progress(f"{len(report.processed) + len(report.failed)}/{len(todo)} rides")
    finally:
        if cluster is not None:
            cluster.close()


_STORES: dict[str, object] = {}
_CLASSIFIERS: dict[str, dict] = {}


def run_ride(ride: Ride, store: str, out: str, models: dict[str, DictionaryModel],
             config: str) -> tuple[str, dict | None, str | None]:
    """Worker task: process one ride and write its files; ``(ride_id, ride row, None)``, or the reason it
    could not be processed (a ride too short or malformed) as the third item."""
    from spotfree.classify.batch import dictionary_classifier
    from spotfree.fleet.process import process_ride
    from spotfree.ride.store import RideStore

    if store not in _STORES:
        _STORES[store] = RideStore(store)
    if config not in _CLASSIFIERS:
        _CLASSIFIERS[config] = {name: dictionary_classifier(m, causal=True) for name, m in models.items()}
    try:
        tables = process_ride(ride, _STORES[store].samples(ride.ride_id), models, config, _CLASSIFIERS[config])
    except InputError as exc:
        return ride.ride_id, None, str(exc)
    row = tables["ride"].iloc[0]
    for table in TABLES:
        folder = partition(Path(out), table, row["date"], ride.vehicle)
        folder.mkdir(parents=True, exist_ok=True)
        tmp = folder / f".{ride.ride_id}.{uuid.uuid4().hex}.tmp"
        tables["ride" if table == "rides" else table].to_parquet(tmp, index=False)
        os.replace(tmp, folder / f"{ride.ride_id}.parquet")
    return ride.ride_id, row.to_dict(), None


FLEET_SCHEMA = (
    "CREATE TABLE IF NOT EXISTS fleet_rides (ride_id TEXT PRIMARY KEY, rider_id TEXT, vehicle TEXT, "
    "age_band TEXT, gender TEXT, skill TEXT, date TEXT, place TEXT, started DOUBLE PRECISION, "
    "duration_s DOUBLE PRECISION, distance_m DOUBLE PRECISION, samples INTEGER, braking_events INTEGER, "
    "sudden_stops INTEGER, mean_speed DOUBLE PRECISION, config TEXT)",
    "CREATE TABLE IF NOT EXISTS fleet_events (ride_id TEXT NOT NULL, kind TEXT NOT NULL, "
    "start_time DOUBLE PRECISION NOT NULL, end_time DOUBLE PRECISION, peak_decel DOUBLE PRECISION, "
    "onset_speed DOUBLE PRECISION, PRIMARY KEY (ride_id, kind, start_time))",
)


def write_database(database: str, out: Path, ride_ids: list[str]) -> None:
    """Replace the rows of ``ride_ids`` in ``fleet_rides`` and ``fleet_events`` from their Parquet files."""
    import psycopg

    if not database.startswith(("postgresql://", "postgres://")):
        raise InputError(f"--database {database!r}: give a postgresql:// URL")
    wanted = set(ride_ids)
    rides = _read(out, "rides", wanted)
    events = _read(out, "events", wanted)
    columns = list(rides.columns)
    with psycopg.connect(database) as connection, connection.transaction():
        for statement in FLEET_SCHEMA:
            connection.execute(statement)
        for ride_id, row in zip(rides["ride_id"], rides.itertuples(index=False)):
            connection.execute("DELETE FROM fleet_events WHERE ride_id = %s", (ride_id,))
            connection.execute("DELETE FROM fleet_rides WHERE ride_id = %s", (ride_id,))
            connection.execute(f"INSERT INTO fleet_rides ({', '.join(columns)}) "
                               f"VALUES ({', '.join(['%s'] * len(columns))})", [_plain(v) for v in row])
        with connection.cursor() as cursor:
            cursor.executemany("INSERT INTO fleet_events (ride_id, kind, start_time, end_time, peak_decel, "
                               "onset_speed) VALUES (%s, %s, %s, %s, %s, %s)",
                               [tuple(_plain(v) for v in row) for row in events.itertuples(index=False)])


def _read(out: Path, table: str, ride_ids: set[str]) -> pd.DataFrame:
    files = [f for f in (out / table).glob("*/*/*.parquet") if f.stem in ride_ids]
    return pd.concat([pd.read_parquet(f) for f in sorted(files)], ignore_index=True) if files else pd.DataFrame()


def _plain(value):
    """A Python scalar for the driver (NaN as NULL)."""
    value = value.item() if hasattr(value, "item") else value
    return None if isinstance(value, float) and value != value else value
