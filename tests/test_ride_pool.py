"""The live service with its rides in worker processes (``spotfree serve --workers``): the same acknowledgements,
labels, refusals and views as in one process, rides spread over the workers, and a killed worker failing only
its own rides' calls, replaced by a new worker that rebuilds those rides from the store."""

from __future__ import annotations

import os
import signal
import time

import pytest
from test_ride_service import _columns, model, raw  # noqa: F401 (fixtures)

from spotfree.errors import InputError
from spotfree.ride.live import LiveRide
from spotfree.ride.pool import RideServicePool
from spotfree.ride.service import BACKLOG_SECONDS, IDLE_SECONDS, RateError, RideService
from spotfree.ride.sources import recording_rows
from spotfree.ride.store import AccessError, NotFoundError, RideStore


@pytest.fixture(scope="module")
def pool(model, tmp_path_factory):
    service = RideServicePool(model, RideStore(tmp_path_factory.mktemp("pool") / "rides.db", synchronous="normal"),
                              processes=2)
    yield service
    service.close()


def test_pool_acknowledges_as_one_process_does(pool, model, raw, tmp_path):
    rows = recording_rows(raw.select_experiment(2))
    alone = RideService(model, RideStore(tmp_path / "alone.db", synchronous="normal"))
    _, token = pool.register_device("phone")
    _, own = alone.register_device("phone")
    first, second = pool.start_ride(token, "v", "r"), pool.start_ride(token, "v", "r")
    assert sorted(w.rides for w in pool._workers) == [1, 1]  # one ride on each worker
    reference = alone.start_ride(own, "v", "r")
    from fastapi.testclient import TestClient

    from spotfree.ride.api import create_app

    operator = {"Authorization": f"Bearer {pool.new_operator_token()}"}
    with TestClient(create_app(pool)) as client, client.websocket_connect("/ws/watch", headers=operator) as view:
        assert view.receive_json()["type"] == "hello"
        with client.websocket_connect("/ws/ride") as ws:
            ws.send_json({"type": "resume", "token": token, "ride_id": first})
            assert ws.receive_json()["last_time"] is None
            for k in range(0, 600, 20):
                ws.send_json({"type": "batch", "seq": k, "samples": _columns(rows[k:k + 20])})
                ack = ws.receive_json()
                expected = alone.ingest(own, reference, _columns(rows[k:k + 20]))
                assert {key: ack[key] for key in expected} == expected
            published = view.receive_json()
            assert published["type"] == "samples" and published["ride_id"] == first and len(published["pitch"]) == 20
            ws.send_json({"type": "batch", "seq": 1, "samples": _columns(rows[:5])})
            assert ws.receive_json()["status"] == 400  # already recorded
    assert pool.resume(token, first) == pytest.approx(rows[599, 0])
    pool.end_ride(token, first)
    assert first not in pool.open_rides() and second in pool.open_rides()
    assert len(pool.store.samples(first)["time"]) == 600
    with pytest.raises(AccessError, match="not open"):
        pool.ingest(token, first, _columns(rows[600:605]))
    with pytest.raises(NotFoundError):
        pool.resume(token, "no-such-ride")
    _, other = pool.register_device("other phone")
    with pytest.raises(AccessError, match="may not write"):
        pool.ingest(other, second, _columns(rows[:5]))
    with pytest.raises(InputError, match="destination"):
        pool.set_destination(token, second, 91.0, 0.0)
    # the rate bucket is the device's, in the server's process: its two rides, on two workers, share it
    _, fresh = pool.register_device("fast phone")
    one, two = pool.start_ride(fresh, "v", "r"), pool.start_ride(fresh, "v", "r")
    while pool._home[two] is pool._home[one]:
        two = pool.start_ride(fresh, "v", "r")
    backlog = int(BACKLOG_SECONDS * model.rate)
    for k in range(0, backlog, 200):
        pool.ingest(fresh, one, _columns(rows[k % 1200:k % 1200 + 200]) | {
            "time": list(k / model.rate + rows[:200, 0])})
    with pytest.raises(RateError) as refused:  # unless the 1200 samples above took over 5 s to send
        pool.ingest(fresh, two, _columns(rows[:400]))
    assert refused.value.retry_after > 0


def test_a_worker_closes_its_idle_rides_while_serving(pool, raw):
    rows = recording_rows(raw.select_experiment(2))[:200]
    _, token = pool.register_device("phone")
    idle, busy = pool.start_ride(token, "v", "r"), pool.start_ride(token, "v", "r")
    homes = {ride: pool._home[ride] for ride in (idle, busy)}
    for ride in (idle, busy):
        pool.ingest(token, ride, _columns(rows))
    started = pool.store.ride(idle).started
    assert pool.close_idle_rides(now=started + rows[-1, 0] + IDLE_SECONDS / 2) == []
    held = sum(w.rides for w in pool._workers)
    closed = pool.close_idle_rides(now=started + rows[-1, 0] + IDLE_SECONDS + 1)
    assert {idle, busy} <= set(closed)
    assert pool.store.ride(idle).ended == pytest.approx(started + rows[-1, 0])
    assert idle not in pool.open_rides() and busy not in pool.open_rides()
    assert sum(w.rides for w in pool._workers) <= held - 2 and all(w.alive() for w in homes.values())
    with pytest.raises(AccessError, match="not open"):  # the worker let go of its state too
        pool.ingest(token, busy, _columns(rows[-1:] + 1))
    assert len(pool.store.samples(busy)["time"]) == len(rows)


def test_a_killed_worker_is_replaced_and_its_rides_go_on(model, raw, tmp_path):
    rows = recording_rows(raw.select_experiment(2))
    service = RideServicePool(model, RideStore(tmp_path / "rides.db"), processes=2)
    try:
        _, token = service.register_device("phone")
        doomed, spared = service.start_ride(token, "v", "r"), service.start_ride(token, "v", "r")
        acked = service.ingest(token, doomed, _columns(rows[:20]))["count"]
        victim = service._home[doomed]
        os.kill(victim._process.pid, signal.SIGKILL)
        victim._process.join(30)
        deadline = time.monotonic() + 120
        while service.health()["restarts"] < 1 or service.health()["status"] != "ok":
            assert time.monotonic() < deadline, service.health()
            time.sleep(0.1)
        assert len(service.store.samples(doomed)["time"]) == acked
        assert service.resume(token, doomed) == pytest.approx(rows[19, 0])  # rebuilt from the store
        ack = service.ingest(token, doomed, _columns(rows[20:40]))
        live = LiveRide(model)
        assert ack["labels"] == [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows[:40]][20:]
        assert service.ingest(token, spared, _columns(rows[:20]))["count"] == 20
        assert len(service.store.samples(doomed)["time"]) == 40
    finally:
        service.close()


def _hold(lock, held) -> None:
    with lock:
        held.set()
        time.sleep(600)


def test_the_write_lock_of_a_killed_holder_is_free_again(tmp_path):
    """A worker killed in mid-commit must not leave the other workers waiting on its lock for good."""
    import multiprocessing

    from spotfree.ride.pool import WriteLock

    context = multiprocessing.get_context("spawn")
    lock, held = WriteLock(str(tmp_path / "rides.db.write-lock")), context.Event()
    holder = context.Process(target=_hold, args=(lock, held))
    holder.start()
    assert held.wait(60)
    os.kill(holder.pid, signal.SIGKILL)
    holder.join(30)
    started = time.monotonic()
    with lock:
        assert time.monotonic() - started < 5
