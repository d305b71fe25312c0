"""A ride store of schema version 1 (a row per sample) opens as today's version (a row per batch) and loses
nothing, as does a store of version 2 (rides without continuation and destination); an upgrade that fails leaves
the file as it was."""

import sqlite3

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.ride import blocks
from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS, Event
from spotfree.ride.store import RideStore
from spotfree.ride.tokens import token_hash

OLD_FEATURES = FEATURE_COLUMNS[:-2]  # written before the two newest channels existed
REAL = "DOUBLE PRECISION"
VERSION_1 = (
    "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    f"CREATE TABLE devices (device_id TEXT PRIMARY KEY, name TEXT NOT NULL, token_hash TEXT NOT NULL UNIQUE, "
    f"created {REAL} NOT NULL)",
    f"CREATE TABLE rides (ride_id TEXT PRIMARY KEY, device_id TEXT NOT NULL REFERENCES devices (device_id), "
    f"vehicle TEXT NOT NULL, rider_id TEXT NOT NULL, started {REAL} NOT NULL, ended {REAL}, model TEXT, "
    "age_band TEXT, gender TEXT, skill TEXT)",
    "CREATE TABLE samples (ride_id TEXT NOT NULL REFERENCES rides (ride_id), t DOUBLE PRECISION NOT NULL, "
    + ", ".join(f"{c} {REAL}" for c in SAMPLE_COLUMNS[1:]) + ", PRIMARY KEY (ride_id, t))",
    f"CREATE TABLE features (ride_id TEXT NOT NULL REFERENCES rides (ride_id), t {REAL} NOT NULL, "
    + ", ".join(f"{c} {REAL}" for c in OLD_FEATURES) + ", PRIMARY KEY (ride_id, t))",
    f"CREATE TABLE labels (ride_id TEXT NOT NULL REFERENCES rides (ride_id), model TEXT NOT NULL, t {REAL} NOT NULL, "
    "label TEXT, PRIMARY KEY (ride_id, model, t))",
    f"CREATE TABLE events (ride_id TEXT NOT NULL REFERENCES rides (ride_id), kind TEXT NOT NULL, start_time {REAL} "
    f"NOT NULL, end_time {REAL} NOT NULL, detail TEXT NOT NULL, PRIMARY KEY (ride_id, kind, start_time))",
)
N = 2 * blocks.UPGRADE_BLOCK + 300  # three blocks after the upgrade


def _version_1_store(path):
    """A version-1 file: ride "long" of N samples (no GPS fix in the first 50, features on all but the last 7,
    labels of two models with one None), ride "short" of 3 samples and no features; one event."""
    rng = np.random.default_rng(3)
    table = rng.normal(size=(N, len(SAMPLE_COLUMNS)))
    table[:, 0] = np.arange(N) / 20.0
    table[:50, 7:] = np.nan
    features = rng.normal(size=(N - 7, len(OLD_FEATURES)))
    labels = rng.choice(["cruising", "normal-braking"], N).astype(object)
    labels[10] = None
    with sqlite3.connect(path) as db:
        for statement in VERSION_1:
            db.execute(statement)
        db.execute("INSERT INTO meta VALUES ('schema_version', '1')")
        db.execute("INSERT INTO devices VALUES ('dev', 'phone', ?, 1.7e9)", (token_hash("secret"),))
        for ride in ("long", "short"):
            db.execute("INSERT INTO rides (ride_id, device_id, vehicle, rider_id, started, skill) "
                       "VALUES (?, 'dev', 'segway', 'r7', 1.7e9, 'novice')", (ride,))
        rows = [("long", *(None if np.isnan(v) else v for v in row)) for row in table.tolist()]
        rows += [("short", float(k), *([1.0] * 6), None, None, None) for k in range(3)]
        db.executemany(f"INSERT INTO samples VALUES ({', '.join('?' * (1 + len(SAMPLE_COLUMNS)))})", rows)
        db.executemany(f"INSERT INTO features VALUES ({', '.join('?' * (2 + len(OLD_FEATURES)))})",
                       [("long", t, *row) for t, row in zip(table[:N - 7, 0].tolist(), features.tolist())])
        for model, values in (("braking", labels), ("lateral", ["straight"] * N)):
            db.executemany("INSERT INTO labels VALUES ('long', ?, ?, ?)",
                           [(model, t, v) for t, v in zip(table[:, 0].tolist(), values)])
        db.execute("INSERT INTO events VALUES ('long', 'sudden-braking', 3.0, 4.5, 'hard stop')")
    return table, features, labels


def test_version_1_store_is_rewritten_into_blocks_and_loses_nothing(tmp_path):
    path = tmp_path / "old.db"
    table, features, labels = _version_1_store(path)
    with RideStore(path) as store:
        samples = store.samples("long")
        np.testing.assert_array_equal(np.column_stack([samples[c] for c in SAMPLE_COLUMNS]), table)
        assert len(store.samples("short")["time"]) == 3
        np.testing.assert_array_equal(store.samples("long", since=100.0)["time"], table[table[:, 0] > 100, 0])
        stored = store.features("long")
        assert len(stored["time"]) == N  # the 7 samples without features are NaN rows of their block
        for j, name in enumerate(OLD_FEATURES):
            np.testing.assert_array_equal(stored[name][:N - 7], features[:, j])
        assert all(np.isnan(stored[c]).all() for c in FEATURE_COLUMNS[-2:])
        assert np.isnan(stored["pitch"][N - 7:]).all()
        assert len(store.features("short")["time"]) == 0
        read = store.labels("long")
        np.testing.assert_array_equal(read["time"], table[:, 0])
        assert list(read["braking"]) == list(labels) and set(read["lateral"]) == {"straight"}
        assert store.events("long") == [Event("sudden-braking", 3.0, 4.5, "hard stop")]
        assert store.ride("long").skill == "novice"
        # recording goes on after the last upgraded sample, with today's feature channels
        with pytest.raises(InputError, match="not after the last stored time"):
            store.append_samples("secret", "long", {**_batch(table[-1, 0]), "time": [table[-1, 0]]})
        after = table[-1, 0] + 0.05
        store.append_samples("secret", "long", _batch(after), features={FEATURE_COLUMNS[-1]: [2.0]})
        assert store.features("long")[FEATURE_COLUMNS[-1]][-1] == 2.0
        assert store._query("SELECT sum(n) FROM sample_blocks WHERE ride_id = 'long'")[0][0] == N + 1
    with sqlite3.connect(path) as db:
        names = {row[0] for row in db.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        assert {"samples", "features", "labels"}.isdisjoint(names)
        assert db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("3",)


def test_failed_upgrade_leaves_the_version_1_file_as_it_was(tmp_path, monkeypatch):
    path = tmp_path / "old.db"
    _version_1_store(path)
    before = path.read_bytes()
    monkeypatch.setattr(blocks, "INSERT_LABELS", "INSERT INTO no_such_table VALUES (?, ?, ?, ?, ?, ?, ?)")
    with pytest.raises(sqlite3.OperationalError, match="no_such_table"):
        RideStore(path)
    with sqlite3.connect(path) as db:
        assert db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("1",)
        assert db.execute("SELECT count(*) FROM samples").fetchone() == (N + 3,)
        assert db.execute("SELECT count(*) FROM sqlite_master WHERE name = 'sample_blocks'").fetchone() == (0,)
    monkeypatch.undo()
    with RideStore(path) as store:
        assert len(store.samples("long")["time"]) == N
    assert before != path.read_bytes()


def _batch(t: float) -> dict:
    return {"time": [t], "ax": [0.0], "ay": [0.0], "az": [9.81], "gx": [0.0], "gy": [0.0], "gz": [0.0]}


def test_a_version_2_store_opens_with_continuation_and_destination(tmp_path):
    path = tmp_path / "v2.db"
    table = np.column_stack([np.arange(5) / 20.0, np.ones((5, len(SAMPLE_COLUMNS) - 1))])
    with sqlite3.connect(path) as db:
        for statement in (*VERSION_1[:3], *blocks.SCHEMA):  # version 2: version 1's rides table, rows in blocks
            db.execute(statement)
        db.execute("INSERT INTO meta VALUES ('schema_version', '2')")
        db.execute("INSERT INTO devices VALUES ('dev', 'phone', ?, 1.7e9)", (token_hash("secret"),))
        db.execute("INSERT INTO rides (ride_id, device_id, vehicle, rider_id, started) "
                   "VALUES ('open', 'dev', 'segway', 'r7', 1.7e9)")
        db.execute(blocks.INSERT_SAMPLES, blocks.sample_row("open", table, None, None))
        assert "continues_from" not in [c[1] for c in db.execute("PRAGMA table_info(rides)")]
    with RideStore(path) as store:
        assert store.ride("open").continues_from is None and store.destination("open") is None
        np.testing.assert_array_equal(store.samples("open")["time"], table[:, 0])
        store.set_destination("secret", "open", 35.7, 139.7)
        assert store.destination("open") == (35.7, 139.7)
        later = store.start_ride("secret", "segway", "r7", continues_from="open")
        assert store.continuation("open") == ["open", later]
    with sqlite3.connect(path) as db:
        assert db.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone() == ("3",)
