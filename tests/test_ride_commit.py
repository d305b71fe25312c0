"""Group commit of the ride store: concurrent writes share transactions, a refused write in a group changes
nothing while the others commit, a failed COMMIT fails its whole group, queued writes are committed on close; and
the quick value checks of a sample batch refuse exactly what the field-by-field checks refuse."""

from __future__ import annotations

import sqlite3
import threading
from concurrent.futures import wait
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from ride_fixtures import batch, postgres_server, store  # noqa: F401 (fixtures)

from spotfree.errors import InputError
from spotfree.ride import RideStore
from spotfree.ride import validation
from spotfree.ride.commit import GroupCommit
from spotfree.ride.store import AccessError, NotFoundError, SQLiteConnection
from spotfree.ride.records import SAMPLE_COLUMNS


def _ride(store):
    _, token = store.register_device("phone")
    return token, store.start_ride(token, "segway", "rider")


def test_pending_writes_share_a_commit_and_a_refused_one_changes_nothing(store):
    rides = [_ride(store) for _ in range(20)]
    groups = store._writer.groups
    with store._lock:  # the writer waits, so every batch below is pending at once
        futures = [store.submit_samples(token, ride, batch(0.0, 5)) for token, ride in rides]
        futures.append(store.submit_samples(*rides[0], batch(0.0, 5)))  # not after ride 0's last time
    wait(futures, timeout=60)
    assert [f.result() for f in futures[:-1]] == [5] * 20
    with pytest.raises(InputError, match="not after the last stored time"):
        futures[-1].result()
    assert store._writer.groups - groups <= 2  # 21 writes, one or two transactions
    assert [len(store.samples(ride)["time"]) for _, ride in rides] == [5] * 20
    assert len(store.labels(rides[0][1])["time"]) == 0


def test_batches_of_a_ride_commit_in_submission_order_with_their_events(tmp_path):
    from spotfree.ride import Event

    with RideStore(tmp_path / "rides.db", synchronous="normal") as store:
        token, ride = _ride(store)
        futures = [store.submit_samples(token, ride, batch(k * 0.25, 5), labels={"m": ["cruising"] * 5},
                                        events=[Event("sudden-braking", k, k + 0.5)] if k == 3 else ())
                   for k in range(8)]
        assert [f.result(timeout=60) for f in futures] == [5] * 8
        assert np.all(np.diff(store.samples(ride)["time"]) > 0) and len(store.labels(ride)["m"]) == 40
        assert [(e.kind, e.start) for e in store.events(ride)] == [("sudden-braking", 3.0)]
    with RideStore(tmp_path / "rides.db") as again:  # close committed everything
        assert len(again.samples(ride)["time"]) == 40


def test_a_group_of_rides_is_written_in_one_insert_per_table(tmp_path):
    with RideStore(tmp_path / "rides.db") as store:
        rides = [_ride(store) for _ in range(20)]
        statements = []
        store._db._connection.set_trace_callback(statements.append)
        with store._lock:
            futures = [store.submit_samples(token, ride, batch(0.0, 5), labels={"m": ["cruising"] * 5})
                       for token, ride in rides]
        assert [f.result(timeout=60) for f in futures] == [5] * 20
        inserts = [s for s in statements if s.startswith("INSERT INTO sample_blocks")]
        assert len(inserts) <= 2 and sum(s.count("), (") + 1 for s in inserts) == 20
        assert all(list(store.labels(ride)["m"]) == ["cruising"] * 5 for _, ride in rides)


def test_foreign_and_ended_rides_in_a_group_are_refused_alone_and_named(store):
    rides = [_ride(store) for _ in range(6)]
    store.end_ride(*rides[1])
    with store._lock:
        futures = [store.submit_samples(token, ride, batch(0.0, 5)) for token, ride in rides]
        futures.append(store.submit_samples(rides[2][0], rides[3][1], batch(1.0, 5)))  # another device's ride
        futures.append(store.submit_samples("no-such-token", rides[4][1], batch(1.0, 5)))
        futures.append(store.submit_samples(rides[5][0], "no-such-ride", batch(1.0, 5)))
    wait(futures, timeout=60)
    with pytest.raises(InputError, match="has ended"):
        futures[1].result()
    with pytest.raises(AccessError, match="belongs to another device"):
        futures[6].result()
    with pytest.raises(AccessError, match="unknown device token"):
        futures[7].result()
    with pytest.raises(NotFoundError, match="does not exist"):
        futures[8].result()
    assert [futures[k].result() for k in (0, 2, 3, 4, 5)] == [5] * 5
    assert [len(store.samples(ride)["time"]) for _, ride in rides] == [5, 0, 5, 5, 5, 5]


def test_together_runs_consecutive_writes_in_order_and_falls_back_to_each_alone(tmp_path):
    db = SQLiteConnection(str(tmp_path / "x.db"), "full")
    db.query("CREATE TABLE t (x INTEGER UNIQUE)", ())
    entered, gate = threading.Event(), threading.Event()

    @contextmanager
    def transaction():
        entered.set()
        gate.wait(30)  # the first group waits here until everything below is queued
        with db.transaction() as cursor:
            yield cursor

    class Insert:
        def __init__(self, x):
            self.x = x

        def __call__(self, db):
            db.execute("INSERT INTO t VALUES (?)", (self.x,))
            return self.x

    calls = []

    def together(db, writes):
        calls.append([w.x for w in writes])
        db.executemany("INSERT INTO t VALUES (?)", [(w.x,) for w in writes])  # all or, on a duplicate, nothing
        return [(True, w.x) for w in writes]

    writer = GroupCommit(transaction)
    first = writer.submit(Insert(0))
    assert entered.wait(30)  # the writer holds the first write alone; the rest queue behind it
    futures = [writer.submit(Insert(x), together) for x in (1, 2)]
    futures.append(writer.submit(lambda db: db.execute("INSERT INTO t VALUES (10)") and 10))
    futures += [writer.submit(Insert(x), together) for x in (3, 3, 4)]  # a duplicate: each alone then
    gate.set()
    wait([first, *futures], timeout=30)
    assert first.result() == 0 and calls == [[1, 2], [3, 3, 4]]
    assert [f.result() for f in futures[:4]] == [1, 2, 10, 3] and futures[5].result() == 4
    with pytest.raises(sqlite3.IntegrityError):
        futures[4].result()
    writer.close()
    assert sorted(x for (x,) in db.query("SELECT x FROM t", ())) == [0, 1, 2, 3, 4, 10]


def test_a_failed_commit_fails_every_write_of_its_group(tmp_path):
    connection = sqlite3.connect(tmp_path / "x.db", isolation_level=None, check_same_thread=False)
    connection.execute("CREATE TABLE t (x INTEGER)")
    fail = threading.Event()

    @contextmanager
    def transaction():
        cursor = connection.cursor()
        cursor.execute("BEGIN")
        try:
            yield cursor
        except BaseException:
            cursor.execute("ROLLBACK")
            raise
        if fail.is_set():
            cursor.execute("ROLLBACK")
            raise sqlite3.OperationalError("disk I/O error")
        cursor.execute("COMMIT")

    writer = GroupCommit(transaction)
    assert writer.submit(lambda db: db.execute("INSERT INTO t VALUES (1)") and 1).result(timeout=30) == 1
    fail.set()
    futures = [writer.submit(lambda db, k=k: db.execute("INSERT INTO t VALUES (?)", (k,))) for k in range(5)]
    for future in futures:
        with pytest.raises(sqlite3.OperationalError, match="disk I/O"):
            future.result(timeout=30)
    writer.close()
    assert connection.execute("SELECT x FROM t").fetchall() == [(1,)]


_LIMITS = {"time": (0.0, 1e6), "ax": (-200.0, 200.0), "gx": (-40.0, 40.0), "lat": (-100.0, 100.0),
           "lon": (-200.0, 200.0), "speed": (-5.0, 120.0)}
_SPECIAL = st.sampled_from([np.nan, np.inf, -np.inf])


@settings(max_examples=150, deadline=None)
@given(st.data())
def test_quick_value_checks_refuse_exactly_what_the_field_checks_refuse(data):
    table = np.column_stack([np.arange(6) * 0.05] + [np.zeros(6)] * 9)
    table[:, 3] = 9.81
    table[:, 7:10] = [36.0, 140.0, 3.0]
    for _ in range(data.draw(st.integers(0, 3))):
        row, column = data.draw(st.integers(0, 5)), data.draw(st.integers(1, len(SAMPLE_COLUMNS) - 1))
        low, high = _LIMITS.get(SAMPLE_COLUMNS[column], _LIMITS["ax" if column < 4 else "gx"])
        table[row, column] = data.draw(_SPECIAL | st.floats(low, high))
    quick = validation._passes(table, -np.inf)
    try:
        validation._check_gps(table, "ride")
        for column in range(1, 7):
            name = SAMPLE_COLUMNS[column]
            bound = validation.MAX_ACCELERATION if column < 4 else validation.MAX_ROTATION
            values = table[:, column]
            validation._refuse(~np.isfinite(values) | (np.abs(values) > bound), values, "ride", name, "")
        refused = False
    except InputError:
        refused = True
    assert quick == (not refused)
    if not quick:
        with pytest.raises(InputError):
            validation.sample_batch(table, None, "ride")


def test_a_shared_lock_is_held_around_each_write_transaction(tmp_path):
    class Counting:
        held = entered = 0

        def __enter__(self):
            self.entered += 1
            self.held += 1

        def __exit__(self, *exc):
            self.held -= 1

    lock = Counting()
    with RideStore(tmp_path / "rides.db", lock=lock) as store:
        token, ride = _ride(store)
        store.append_samples(token, ride, batch(0.0, 5))
        assert lock.held == 0 and lock.entered == 4  # schema, device, ride, batch
        store.samples(ride)
        assert lock.entered == 4  # reads do not take it
