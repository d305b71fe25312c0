"""Fleet pipeline: generate -> ingest -> process on a local Dask cluster (a worker killed mid-run) -> Parquet,
PostgreSQL on loopback, statistics by group; idempotent at every step."""

from __future__ import annotations

import hashlib
import os
import signal
import threading
import time
from pathlib import Path

import duckdb
import numpy as np
import pandas as pd
import pytest
from ride_fixtures import postgres_database, postgres_server  # noqa: F401 (fixture)
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.fleet import generate_fleet, ingest_logs, ingest_store, process_fleet, read_manifest
from spotfree.fleet.stats import GROUPS, fleet_stats
from spotfree.ride.default_model import default_model
from spotfree.ride.store import RideStore

RIDES = 16


@pytest.fixture(scope="module")
def fleet_store(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fleet")
    generate_fleet(folder / "logs", riders=6, rides=RIDES, vehicles=3, days=3, seed=5)
    location = str(folder / "rides.db")
    with RideStore(location, synchronous="normal") as store:
        report = ingest_logs(store, read_manifest(folder / "logs" / "rides.csv", folder / "logs" / "riders.csv"))
    assert len(report.added) == RIDES
    return location


@pytest.fixture(scope="module")
def cluster():
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as running:
        yield running


@pytest.fixture(scope="module")
def processed(fleet_store, cluster, tmp_path_factory):
    """Results of a run during which one worker process is killed with SIGKILL once 3 rides are written."""
    from dask.distributed import Client

    out = tmp_path_factory.mktemp("out")
    with Client(cluster) as client:
        pids = list(client.run(os.getpid).values())
    killed = []

    def kill_when_started():
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and len(list(out.glob("rides/*/*/*.parquet"))) < 3:
            time.sleep(0.05)
        os.kill(pids[0], signal.SIGKILL)
        killed.append(len(list(out.glob("rides/*/*/*.parquet"))))

    killer = threading.Thread(target=kill_when_started)
    killer.start()
    report = process_fleet(fleet_store, out, {"braking": default_model()}, scheduler=cluster.scheduler_address)
    killer.join()
    return out, report, killed


def _parquet(out: Path, table: str) -> pd.DataFrame:
    return duckdb.sql(f"SELECT * FROM read_parquet('{out}/{table}/*/*/*.parquet', hive_partitioning = false, "
                      "union_by_name = true)").df()


def test_generator_is_deterministic_and_skill_shapes_the_rides(tmp_path):
    a = generate_fleet(tmp_path / "a", riders=3, rides=2, seed=9)
    b = generate_fleet(tmp_path / "b", riders=3, rides=2, seed=9)
    for name in ("riders.csv", "rides.csv", "logs/ride-00001.csv", "logs/ride-00002.csv"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    from spotfree.fleet.generator import draw_rides, draw_riders

    rides = draw_rides(draw_riders(60, 1), 3000, 5, 7, 1).merge(draw_riders(60, 1)[["rider_id", "skill"]])
    sudden = rides.groupby("skill")["scenario"].apply(lambda s: (s == "sudden-braking").mean())
    assert sudden["novice"] > sudden["intermediate"] > sudden["expert"]
    assert list(a.rides.columns[:3]) == ["file", "ride", "rider_id"]


def test_ingest_again_adds_nothing_and_keeps_rider_metadata(fleet_store, tmp_path):
    folder = Path(fleet_store).parent / "logs"
    with RideStore(fleet_store) as store:
        again = ingest_logs(store, read_manifest(folder / "rides.csv", folder / "riders.csv"))
        rides = store.rides()
    assert (len(again.added), again.skipped) == (0, RIDES)
    riders = pd.read_csv(folder / "riders.csv").set_index("rider_id")
    for ride in rides:
        assert (ride.age_band, ride.gender, ride.skill) == tuple(riders.loc[ride.rider_id, ["age_band", "gender",
                                                                                           "skill"]])
    with RideStore(tmp_path / "copy.db") as copy, RideStore(fleet_store) as source:
        assert len(ingest_store(copy, source).added) == RIDES
        assert len(ingest_store(copy, source).added) == 0
        first = source.rides()[0]
        twin = [r for r in copy.rides() if (r.vehicle, r.rider_id, r.started) ==
                (first.vehicle, first.rider_id, first.started)][0]
        np.testing.assert_array_equal(copy.samples(twin.ride_id)["ax"], source.samples(first.ride_id)["ax"])


def test_killed_worker_loses_no_ride_and_each_ride_is_written_once(fleet_store, processed):
    out, report, killed = processed
    assert killed and killed[0] < RIDES, "the worker was killed after the run"
    assert not report.failed and len(report.processed) == RIDES
    rides = _parquet(out, "rides")
    with RideStore(fleet_store) as store:
        stored = {r.ride_id: len(store.samples(r.ride_id)["time"]) for r in store.rides()}
    assert sorted(rides["ride_id"]) == sorted(stored)
    samples = _parquet(out, "samples").groupby("ride_id").size()
    assert samples.to_dict() == stored
    assert rides.set_index("ride_id")["samples"].to_dict() == stored
    events = _parquet(out, "events")
    counts = events.groupby(["ride_id", "kind"]).size().unstack(fill_value=0)
    per_ride = rides.set_index("ride_id")
    assert counts["braking"].sum() == per_ride["braking_events"].sum()
    for table in ("rides", "samples", "events"):
        for path in (out / table).glob("*/*/*.parquet"):
            date, vehicle = path.parent.parent.name, path.parent.name
            row = per_ride.loc[path.stem]
            assert (date, vehicle) == (f"date={row['date']}", f"vehicle={row['vehicle']}")


def test_rerun_skips_done_rides_and_redo_rewrites_identical_files(fleet_store, processed, cluster):
    out, _, _ = processed
    digest = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in out.rglob("*.parquet")}
    model = {"braking": default_model()}
    again = process_fleet(fleet_store, out, model, scheduler=cluster.scheduler_address)
    assert (len(again.processed), again.skipped) == (0, RIDES)
    redo = process_fleet(fleet_store, out, model, scheduler=cluster.scheduler_address, redo=True)
    assert len(redo.processed) == RIDES
    assert {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in out.rglob("*.parquet")} == digest


@pytest.mark.postgres
def test_results_go_to_postgres_and_a_rerun_changes_nothing(fleet_store, processed, cluster, postgres_server):
    import psycopg

    out, _, _ = processed
    database = postgres_database(postgres_server)
    model = {"braking": default_model()}
    for _ in range(2):
        process_fleet(fleet_store, out, model, scheduler=cluster.scheduler_address, database=database)
        with psycopg.connect(database) as connection:
            rides = connection.execute("SELECT ride_id, braking_events, distance_m FROM fleet_rides "
                                       "ORDER BY ride_id").fetchall()
            events = connection.execute("SELECT count(*) FROM fleet_events").fetchone()[0]
        expected = _parquet(out, "rides").sort_values("ride_id")
        assert [r[0] for r in rides] == expected["ride_id"].tolist()
        np.testing.assert_allclose([r[2] for r in rides], expected["distance_m"])
        assert events == len(_parquet(out, "events"))


def test_stats_by_group_match_the_parquet_rows(processed, tmp_path):
    out, _, _ = processed
    tables = fleet_stats(out, tmp_path)
    rides = _parquet(out, "rides")
    for group in GROUPS:
        table = tables[group].set_index(group)
        assert table["rides"].sum() == RIDES
        assert (tmp_path / f"by_{group}.png").stat().st_size > 10_000
    skill = tables["skill"].set_index("skill")
    by_hand = rides.groupby("skill").apply(lambda r: r["braking_events"].sum() / (r["distance_m"].sum() / 1000))
    np.testing.assert_allclose(skill["braking_per_km"], by_hand[skill.index])
    assert "## By place" in (tmp_path / "stats.md").read_text()


def test_cli_ingest_without_inputs_exits_2(tmp_path):
    result = CliRunner().invoke(app, ["fleet", "ingest", "--store", str(tmp_path / "s.db")])
    assert result.exit_code == 2 and "nothing to ingest" in result.output
    result = CliRunner().invoke(app, ["fleet", "stats", str(tmp_path), "-o", str(tmp_path / "st")])
    assert result.exit_code == 2 and "fleet process" in result.output


def test_cli_process_and_stats_json_for_scripts(fleet_store, processed, cluster, tmp_path):
    """``fleet process --json`` (the shipped braking model when none is given) and ``fleet stats --json``: one JSON
    document on stdout each; ``--quiet`` prints nothing."""
    import json

    out, _, _ = processed
    result = CliRunner().invoke(app, ["fleet", "process", "--store", fleet_store, "-o", str(out), "--scheduler",
                                      cluster.scheduler_address, "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report == {"output": str(out), "models": ["braking"], "processed": [], "skipped": RIDES, "failed": {}}
    result = CliRunner().invoke(app, ["fleet", "stats", str(out), "-o", str(tmp_path), "--json"])
    assert result.exit_code == 0, result.output
    stats = json.loads(result.stdout)["stats"]
    assert list(stats) == list(GROUPS)
    for group in GROUPS:
        assert stats[group] == json.loads(pd.read_csv(tmp_path / f"by_{group}.csv").to_json(orient="records"))
        assert sum(row["rides"] for row in stats[group]) == RIDES
    quiet = CliRunner().invoke(app, ["fleet", "stats", str(out), "-o", str(tmp_path / "q"), "--quiet"])
    assert quiet.exit_code == 0 and quiet.stdout == "" and quiet.stderr == ""
    assert (tmp_path / "q" / "stats.md").exists()
