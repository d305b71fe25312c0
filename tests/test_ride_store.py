"""The ride store on SQLite and on a local PostgreSQL server: round trips, devices and tokens, ownership,
transactional validation of bad batches, and no acknowledged sample lost when the writer is killed."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import textwrap
import threading

import numpy as np
import pytest
from ride_fixtures import batch, postgres_server, store  # noqa: F401 (fixtures)

from spotfree.errors import InputError
from spotfree.ride import AccessError, Event, NotFoundError, RideStore
from spotfree.ride.records import SAMPLE_COLUMNS
from spotfree.ride.tokens import token_hash
from spotfree.ride.validation import MAX_BATCH


def _ride(store, **fields):
    _, token = store.register_device("phone")
    ride = store.start_ride(token, "segway-i2", "rider-7", model="braking-v1", **fields)
    return token, ride


def test_samples_features_labels_round_trip(store):
    token, ride = _ride(store, age_band="65-74", gender="f", skill="novice")
    first, second = batch(0.0, 30), batch(1.5, 30)
    features = {"pitch": np.linspace(0, 0.1, 30), "acc_long": np.full(30, np.nan)}
    assert store.append_samples(token, ride, first, features=features,
                                labels={"braking-v1": [None] * 10 + ["cruising"] * 20}) == 30
    store.append_samples(token, ride, second, labels={"braking-v1": ["sudden-braking"] * 30})
    got = store.samples(ride)
    assert list(got) == list(SAMPLE_COLUMNS)
    for name in SAMPLE_COLUMNS:
        np.testing.assert_array_equal(got[name], np.r_[first[name], second[name]], err_msg=name)
    assert np.isnan(got["lat"][1]) and got["lat"][0] == first["lat"][0]
    np.testing.assert_array_equal(store.samples(ride, since=1.5)["time"], second["time"][1:])
    stored = store.features(ride)
    np.testing.assert_array_equal(stored["time"], first["time"])
    np.testing.assert_array_equal(stored["pitch"], features["pitch"])
    assert np.isnan(stored["acc_long"]).all() and np.isnan(stored["roll"]).all()
    labels = store.labels(ride)
    assert list(labels) == ["time", "braking-v1"]
    assert labels["braking-v1"][0] is None and labels["braking-v1"][10] == "cruising"
    assert labels["braking-v1"][-1] == "sudden-braking"


def test_labels_of_several_models_are_columns(store):
    token, ride = _ride(store)
    samples = batch(0.0, 4)
    store.append_samples(token, ride, samples, labels={"a": ["x", "y", "x", "y"]})
    store.append_labels(token, ride, "b", samples["time"][1::2], ["p", "q"])
    labels = store.labels(ride)
    assert list(labels) == ["time", "a", "b"]
    assert list(labels["b"]) == [None, "p", None, "q"] and list(labels["a"]) == ["x", "y", "x", "y"]
    with pytest.raises(InputError, match="not after the last stored time"):
        store.append_labels(token, ride, "b", [0.1], ["r"])


def test_ride_metadata_events_and_listing(store):
    token, ride = _ride(store, skill="expert")
    store.add_event(token, ride, Event("sudden-braking", 2.0, 2.5))
    store.add_event(token, ride, Event("sudden-braking", 2.0, 3.1, "peak 4.2 m/s^2"))
    store.add_event(token, ride, Event("lateral", 1.0, 1.2))
    assert store.events(ride) == [Event("lateral", 1.0, 1.2), Event("sudden-braking", 2.0, 3.1, "peak 4.2 m/s^2")]
    info = store.ride(ride)
    assert (info.vehicle, info.rider_id, info.model, info.skill, info.ended) == \
           ("segway-i2", "rider-7", "braking-v1", "expert", None)
    store.end_ride(token, ride, ended=info.started + 60.0)
    assert store.ride(ride).ended == info.started + 60.0
    other_token, other = _ride(store)
    assert [r.ride_id for r in store.rides()] == [ride, other]
    assert [r.ride_id for r in store.rides(store.authenticate(other_token))] == [other]
    with pytest.raises(NotFoundError, match="list the rides"):
        store.ride("nope")
    with pytest.raises(InputError, match="event"):
        store.add_event(other_token, other, Event("x", 3.0, 2.0))


def test_tokens_are_per_device_and_stored_hashed(store, tmp_path):
    device, token = store.register_device("a")
    other_device, other_token = store.register_device("b")
    assert store.authenticate(token) == device != other_device == store.authenticate(other_token)
    assert len(token) >= 43 and token != other_token
    for bad in ("", "x" * 43, token[:-1]):
        with pytest.raises(AccessError):
            store.authenticate(bad)
    with pytest.raises(AccessError):
        store.start_ride("forged", "segway", "rider")
    hashes = [row[0] for row in store._query("SELECT token_hash FROM devices ORDER BY name")]
    assert hashes == [token_hash(token), token_hash(other_token)]
    dumped = "\n".join(str(row) for row in store._query("SELECT * FROM devices"))
    assert token not in dumped and other_token not in dumped


def test_a_device_writes_only_to_its_own_open_rides(store):
    token, ride = _ride(store)
    intruder, _ = _ride(store)
    store.append_samples(token, ride, batch(0.0, 5))
    with pytest.raises(AccessError, match="another device"):
        store.append_samples(intruder, ride, batch(1.0, 5))
    with pytest.raises(AccessError):
        store.add_event(intruder, ride, Event("sudden-braking", 0.0, 0.1))
    with pytest.raises(AccessError):
        store.end_ride(intruder, ride)
    with pytest.raises(NotFoundError):
        store.append_samples(token, "no-such-ride", batch(1.0, 5))
    store.end_ride(token, ride)
    with pytest.raises(InputError, match="has ended"):
        store.append_samples(token, ride, batch(1.0, 5))
    assert len(store.samples(ride)["time"]) == 5 and store.events(ride) == []


def _set(column, row, value):
    def change(samples):
        samples[column] = np.array(samples[column], dtype=object)
        samples[column][row] = value
    return change


BAD_BATCHES = {
    "NaN acceleration": (_set("ax", 3, np.nan), "'ax', row 4"),
    "missing gyro value": (_set("gz", 0, None), "'gz', row 1"),
    "acceleration beyond 16 g": (_set("az", 2, 200.0), "'az', row 3"),
    "text in a number field": (_set("gx", 1, "fast"), "not a number"),
    "time not increasing": (_set("time", 5, 0.1), "increase strictly"),
    "time not after the stored samples": (lambda s: s.update(time=s["time"] - 0.6), "not after the last stored"),
    "negative time": (lambda s: s.update(time=s["time"] - 100), "'time', row 1"),
    "milliseconds sent as seconds": (lambda s: s.update(time=10.0 + (s["time"] - 1.0) / 1000), "faster than"),
    "lat without lon": (_set("lon", 0, np.nan), "lat and lon together"),
    "latitude out of range": (_set("lat", 0, 95.0), "'lat', row 1"),
    "negative speed": (_set("speed", 0, -1.0), "'speed', row 1"),
    "unknown field": (lambda s: s.update(temperature=np.zeros(10)), "unknown sample field 'temperature'"),
    "missing field": (lambda s: s.pop("gy"), "'gy' is missing"),
    "fields of different lengths": (lambda s: s.update(ax=s["ax"][:-1]), "differ in length"),
    "empty batch": (lambda s: s.update({k: v[:0] for k, v in s.items()}), "0 samples in one batch"),
}


@pytest.mark.parametrize("name", BAD_BATCHES)
def test_a_bad_batch_is_refused_and_changes_nothing(store, name):
    token, ride = _ride(store)
    store.append_samples(token, ride, batch(0.0, 10), labels={"m": ["a"] * 10})
    before = (store.samples(ride), store.labels(ride))
    bad = batch(1.0, 10)
    change, message = BAD_BATCHES[name]
    change(bad)
    with pytest.raises(InputError, match=message):
        store.append_samples(token, ride, bad, labels={"m": ["b"] * 10})
    after = (store.samples(ride), store.labels(ride))
    for a, b in zip(before, after):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=a[k].dtype == float) for k in a)


@pytest.mark.parametrize("features, labels, message", [
    ({"pitch": [np.inf] * 10}, None, "finite features"),
    ({"yaw": [0.0] * 10}, None, "unknown feature 'yaw'"),
    (None, {"m": ["a"] * 9}, "list of 10 labels"),
    (None, {"m": ["a"] * 9 + ["x" * 101]}, "printable text"),
    (None, {"": ["a"] * 10}, "'model' is empty"),
])
def test_bad_features_or_labels_refuse_the_whole_batch(store, features, labels, message):
    token, ride = _ride(store)
    with pytest.raises(InputError, match=message):
        store.append_samples(token, ride, batch(0.0, 10), features=features, labels=labels)
    assert len(store.samples(ride)["time"]) == 0 and len(store.labels(ride)["time"]) == 0


def test_batch_size_limit_and_text_fields(store):
    token, ride = _ride(store)
    with pytest.raises(InputError, match=f"send 1 to {MAX_BATCH}"):
        store.append_samples(token, ride, batch(0.0, MAX_BATCH + 1, rate=200.0))
    assert store.append_samples(token, ride, batch(0.0, MAX_BATCH, rate=200.0)) == MAX_BATCH
    with pytest.raises(InputError, match="'vehicle' is empty"):
        store.start_ride(token, "", "rider")
    with pytest.raises(InputError, match="'rider_id' must be printable"):
        store.start_ride(token, "segway", "rider\n7")
    with pytest.raises(InputError, match="UNIX seconds"):
        store.start_ride(token, "segway", "rider", started=1.7e12)


def test_concurrent_writers_share_one_store(store):
    rides = [_ride(store) for _ in range(4)]

    def write(token, ride):
        for k in range(10):
            store.append_samples(token, ride, batch(k, 20))

    threads = [threading.Thread(target=write, args=r) for r in rides]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert [len(store.samples(ride)["time"]) for _, ride in rides] == [200] * 4


def test_sqlite_store_reopens_with_its_rides(tmp_path):
    path = tmp_path / "rides.db"
    with RideStore(path, synchronous="normal") as first:
        token, ride = _ride(first)
        first.append_samples(token, ride, batch(0.0, 7))
    with RideStore(path) as again:
        assert len(again.samples(ride)["time"]) == 7
        assert again.authenticate(token) == again.ride(ride).device_id
        again._query("SELECT 1")
        with again._transaction() as db:
            db.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    with pytest.raises(InputError, match="schema version 99"):
        RideStore(path)
    with pytest.raises(InputError, match="synchronous"):
        RideStore(tmp_path / "other.db", synchronous="off")
    (tmp_path / "junk.db").write_bytes(b"not a database" * 100)
    with pytest.raises(InputError, match="not a usable SQLite ride store"):
        RideStore(tmp_path / "junk.db")


WRITER = textwrap.dedent("""
    import sys
    import numpy as np
    from spotfree.ride.store import RideStore
    store = RideStore(sys.argv[1])
    _, token = store.register_device("phone")
    ride = store.start_ride(token, "segway", "rider")
    print("ride", ride, flush=True)
    k = 0
    while True:
        t = (k + np.arange(5)) / 20.0
        samples = {c: np.zeros(5) for c in ("ax", "ay", "gx", "gy", "gz")}
        samples.update(time=t, az=np.full(5, 9.81))
        store.append_samples(token, ride, samples, labels={"m": ["cruising"] * 5})
        print("ack", k + 4, flush=True)
        k += 5
""")


def test_no_acknowledged_sample_is_lost_when_the_writer_is_killed(tmp_path, acks=25):
    path = tmp_path / "rides.db"
    writer = subprocess.Popen([sys.executable, "-c", WRITER, str(path)], stdout=subprocess.PIPE, text=True)
    try:
        ride = writer.stdout.readline().split()[1]
        acknowledged = [int(writer.stdout.readline().split()[1]) for _ in range(acks)]
        writer.send_signal(signal.SIGKILL)
    finally:
        writer.kill()
        writer.wait(timeout=30)
    assert writer.returncode == -signal.SIGKILL
    with sqlite3.connect(path) as raw:
        assert raw.execute("PRAGMA integrity_check").fetchall() == [("ok",)]
    with RideStore(path) as store:
        stored = np.round(store.samples(ride)["time"] * 20.0).astype(int)
        labels = store.labels(ride)
    assert stored[-1] >= acknowledged[-1]
    np.testing.assert_array_equal(stored, np.arange(len(stored)))  # whole batches only, none torn
    assert len(stored) % 5 == 0 and len(labels["time"]) == len(stored)


@pytest.mark.parametrize("labels, row", [(["cruising", "sudden\nbraking", "cruising"], 2),
                                         (["cruising", None, ["cruising"]], 3),
                                         (["cruising", "x" * 101, None], 2), (["", "cruising", None], 1)])
def test_a_bad_label_is_refused_by_its_row(labels, row):
    from spotfree.ride.validation import label_batch

    with pytest.raises(InputError, match=f"'labels row {row}'"):
        label_batch(labels, 3, "ride r", "labels")
    assert label_batch(["cruising", None, "cruising"], 3, "ride r", "labels") == ["cruising", None, "cruising"]


def test_the_median_time_step_is_numpys():
    from spotfree.ride.validation import MIN_RATE, _median_step_ok

    rng = np.random.default_rng(5)
    for n in range(1, 40):
        for _ in range(50):
            t = np.cumsum(rng.exponential(1.0 / MIN_RATE, n))
            assert _median_step_ok(t) == (n < 3 or float(np.median(np.diff(t))) <= 1.0 / MIN_RATE)
