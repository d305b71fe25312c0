"""One client cannot exhaust the ride service for the others (issue 72): push sessions bounded and freed, quotas
per device, limits for the unauthenticated; FastAPI's TestClient and the service's own objects, in seconds."""

import math

import numpy as np
import pytest

pytest.importorskip("fastapi")

from service_fixtures import bearer, enrol, model, raw  # noqa: E402,F401
from test_ride_service import client  # noqa: E402,F401 (fixture)
from spotfree.ride.sensorpush import STALE_SECONDS, PushResampler  # noqa: E402

T0 = 1_700_000_000_000_000_000
"""A push message's UNIX time origin, ns."""


def _motion(second: int, rate: int = 100, gyroscope: bool = False) -> list[dict]:
    """One second (``second`` s after T0) of Sensor Logger readings at ``rate`` Hz: accelerometer without
    gravity and gravity (a phone with the gyroscope off), and the gyroscope when asked."""
    payload = []
    for k in range(rate):
        t = T0 + second * 1_000_000_000 + k * (1_000_000_000 // rate)
        payload.append({"name": "accelerometer", "time": t, "values": {"x": 0.1, "y": 0.0, "z": 0.0}})
        payload.append({"name": "gravity", "time": t, "values": {"x": 0.0, "y": 0.0, "z": 9.81}})
        if gyroscope:
            payload.append({"name": "gyroscope", "time": t + 1000, "values": {"x": 0.0, "y": 0.01, "z": 0.0}})
    return payload


def _readings(seconds: range, rate: int = 100, gyroscope: bool = True) -> list[tuple]:
    out = []
    for s in seconds:
        for k in range(rate):
            t = 1.7e9 + s + k / rate
            out.append(("acc", t, (0.1 * k, 0.0, 9.81)))
            if gyroscope:
                out.append(("gyr", t + 1e-6, (0.0, 0.01 * k, 0.0)))
            if k == 50:
                out.append(("fix", t, (35.0 + s * 1e-5, 139.0, 3.0)))
    return sorted(out, key=lambda r: r[1])


def test_push_resampler_bounds_unmatched_readings():
    resampler = PushResampler(20.0)
    for s in range(60):  # a minute of accelerometer readings at 100 Hz, no gyroscope
        out = resampler.add(_readings(range(s, s + 1), gyroscope=False))
        assert out["time"] == []
        assert resampler.held() <= STALE_SECONDS * 20 + 2 + 60  # slots of 3 s, the fixes of 3 s at most
    assert resampler.dropped >= 100 * (60 - STALE_SECONDS - 1)


def test_push_resampler_rollback_undoes_one_message():
    messages = [_readings(range(s, s + 1)) for s in range(4)]
    kept, undone = PushResampler(20.0), PushResampler(20.0)
    want = [kept.add(m) for m in messages]
    got = []
    for m in messages:
        undone.add(m)
        undone.rollback()  # the message's samples were refused by the store: the app sends it again
        got.append(undone.add(m))
    for a, b in zip(want, got):
        assert a.keys() == b.keys()
        for name in a:
            np.testing.assert_array_equal(np.array(a[name], dtype=float), np.array(b[name], dtype=float))
    assert kept.dropped == undone.dropped and kept.held() == undone.held()
    assert sum(len(w["time"]) for w in want) == 80
    assert [w["lat"].index(next(v for v in w["lat"] if not math.isnan(v))) for w in want] == [10] * 4


def test_push_sessions_without_gyroscope_stay_bounded_and_are_freed(client):
    headers = bearer(enrol(client, client.operator))
    dropped = []
    for s in range(12):
        answer = client.post("/push", json={"sessionId": "gyro-off", "payload": _motion(s)}, headers=headers)
        assert answer.status_code == 200, answer.text
        assert answer.json()["count"] == 0
        dropped.append(answer.json()["dropped"])
    sessions = client.app.state.push_sessions
    assert len(sessions) == 1
    (session,) = sessions._sessions.values()
    assert session.resampler.held() <= STALE_SECONDS * 20 + 2
    assert dropped[0] == 0 and sum(dropped) >= 100 * (12 - STALE_SECONDS - 1)  # counted, not kept
    # the ride ends (its device ends it; the service's idle check does the same): the session is freed, and the
    # session's next message starts a new ride
    assert client.post(f"/api/rides/{answer.json()['ride_id']}/end", headers=headers).status_code == 200
    assert len(sessions) == 0
    again = client.post("/push", json={"sessionId": "gyro-off", "payload": _motion(20, gyroscope=True)},
                        headers=headers)
    assert again.status_code == 200 and again.json()["ride_id"] != answer.json()["ride_id"]
    assert again.json()["count"] == 20  # slots 0-19 of a second; slot 20 waits for a later reading


def test_push_sessions_idle_are_freed(client):
    headers = bearer(enrol(client, client.operator))
    sessions = client.app.state.push_sessions
    sessions.idle = sessions.sweep = 0.0
    for name in ("a", "b", "c"):
        assert client.post("/push", json={"sessionId": name, "payload": _motion(0, gyroscope=True)},
                           headers=headers).status_code == 200
    assert len(sessions) == 1  # each message swept the sessions idle before it


def _rides(raw):
    from spotfree.ride.sources import recording_rows

    return recording_rows(raw.select_experiment(2))


def test_open_rides_are_capped_per_device(client):
    from spotfree.ride.service import MAX_OPEN_RIDES

    phone, other = bearer(enrol(client, client.operator)), bearer(enrol(client, client.operator, "other"))
    start = {"vehicle": "v", "rider_id": "r"}
    rides = [client.post("/api/rides", json=start, headers=phone).json()["ride_id"] for _ in range(MAX_OPEN_RIDES)]
    refused = client.post("/api/rides", json=start, headers=phone)
    assert refused.status_code == 429 and f"{MAX_OPEN_RIDES} open rides" in refused.json()["detail"]
    assert "end one" in refused.json()["detail"] and "\n" not in refused.json()["detail"]
    with client.websocket_connect("/ws/ride") as ws:
        ws.send_json({"type": "start", "token": phone["Authorization"][7:], **start})
        assert ws.receive_json()["status"] == 429
    assert client.post("/push", json={"sessionId": "s", "payload": _motion(0, gyroscope=True)},
                       headers=phone).status_code == 429
    assert len(client.app.state.push_sessions) == 0  # the refused session is not kept
    assert client.post("/api/rides", json=start, headers=other).status_code == 200  # another device is not hurt
    assert client.post(f"/api/rides/{rides[0]}/end", headers=phone).status_code == 200
    assert client.post("/api/rides", json=start, headers=phone).status_code == 200


def test_rate_bucket_is_per_device_and_ride_state_is_lazy(client, raw):
    from spotfree.ride.service import BACKLOG_SECONDS
    from test_ride_service import _columns

    phone = bearer(enrol(client, client.operator))
    start = {"vehicle": "v", "rider_id": "r"}
    first, second = (client.post("/api/rides", json=start, headers=phone).json()["ride_id"] for _ in range(2))
    held = client.service._open[second]
    assert held._live is None and held._assistant is None  # nothing made before the first batch
    rows, backlog = _rides(raw), int(BACKLOG_SECONDS * client.service.model.rate)
    for k in range(0, backlog, 400):
        assert client.post(f"/api/rides/{first}/samples", json={"samples": _columns(rows[k:k + 400])},
                           headers=phone).status_code == 200
    # the device's second ride shares the bucket the first one emptied
    refused = client.post(f"/api/rides/{second}/samples", json={"samples": _columns(rows[:40])}, headers=phone)
    assert refused.status_code == 429 and int(refused.headers["retry-after"]) >= 1
    assert held._live is None
    other = bearer(enrol(client, client.operator, "other"))
    ride = client.post("/api/rides", json=start, headers=other).json()["ride_id"]
    assert client.post(f"/api/rides/{ride}/samples", json={"samples": _columns(rows[:40])},
                       headers=other).status_code == 200
    assert client.service._open[ride]._live is not None
    assert client.post(f"/api/rides/{ride}/end", headers=other).status_code == 200
    assert ride not in client.service._open  # freed with its ride


def test_enrolment_body_is_small_before_anyone_is_known(client):
    from spotfree.ride.api import MAX_UNAUTHENTICATED_BODY

    big = {"code": "guessed", "name": "x" * MAX_UNAUTHENTICATED_BODY}
    refused = client.post("/api/devices", json=big)
    assert refused.status_code == 413 and str(MAX_UNAUTHENTICATED_BODY) in refused.json()["detail"]
    assert client.post("/api/devices", json={"code": "guessed", "name": "x"}).status_code == 403


def test_ride_socket_must_start_within_the_auth_deadline(client, monkeypatch):
    import time

    from starlette.websockets import WebSocketDisconnect

    from spotfree.ride import api

    monkeypatch.setattr(api, "AUTH_SECONDS", 0.2)
    with client.websocket_connect("/ws/ride") as ws:
        time.sleep(0.4)
        ws.send_text("[]")  # too late: the socket was closed at the deadline
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
    assert closed.value.code == 1008 and "within 0.2 s" in closed.value.reason
    with client.websocket_connect("/ws/ride") as ws:
        ws.send_text('{"type": "start", "pad": "' + "x" * api.MAX_UNAUTHENTICATED_BODY + '"}')
        with pytest.raises(WebSocketDisconnect) as closed:
            ws.receive_json()
    assert closed.value.code == 1009
    phone = enrol(client, client.operator)
    with client.websocket_connect("/ws/ride") as ws:  # a ride started in time goes on past the deadline
        ws.send_json({"type": "start", "token": phone, "vehicle": "v", "rider_id": "r"})
        assert ws.receive_json()["type"] == "started"
        time.sleep(0.3)
        ws.send_json({"type": "destination", "lat": 35.0, "lon": 139.0})
        assert ws.receive_json()["type"] == "destination"


def test_server_runs_under_uvicorns_own_limits(client):
    import socket
    import threading
    import time

    import uvicorn

    from spotfree.ride.server import MAX_HEADER_BYTES, uvicorn_limits

    limits = uvicorn_limits()
    assert 16 <= limits["limit_concurrency"]
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(client.app, host="127.0.0.1", port=port, log_level="critical",
                                           **{**limits, "limit_concurrency": 3}))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.02)
    try:
        def ask(extra: bytes = b"") -> bytes:
            with socket.create_connection(("127.0.0.1", port), timeout=5) as conn:
                conn.sendall(b"GET /api/health HTTP/1.1\r\nHost: x\r\n" + extra)
                time.sleep(0.05)  # what came so far is read before the rest
                try:
                    conn.sendall(b"\r\n")
                except OSError:  # the server answered and closed before the rest was sent
                    pass
                return conn.recv(64)
        assert ask().startswith(b"HTTP/1.1 200")
        # unfinished headers are buffered up to MAX_HEADER_BYTES, then refused
        assert ask(b"X-Pad: " + b"x" * MAX_HEADER_BYTES + b"\r\n").startswith(b"HTTP/1.1 400")
        idle = [socket.create_connection(("127.0.0.1", port)) for _ in range(3)]  # connections that say nothing
        try:
            time.sleep(0.1)
            assert ask().startswith(b"HTTP/1.1 503")  # answered at once, not left to hang
        finally:
            for conn in idle:
                conn.close()
    finally:
        server.should_exit = True
        thread.join(5)


@pytest.mark.parametrize("fix", [{"latitude": 1000.0, "longitude": 139.0}, {"latitude": 35.0, "longitude": -181.0},
                                 {"latitude": 35.0, "longitude": 139.0, "speed": 1e6}])
def test_push_fix_out_of_range_is_refused_and_does_not_poison_the_session(client, fix):
    headers = bearer(enrol(client, client.operator))
    first = client.post("/push", json={"sessionId": "s", "payload": _motion(0, gyroscope=True)}, headers=headers)
    assert first.status_code == 200
    # a fix at the session's last (pending) slot: once accepted, it went on a later message's first sample
    bad = _motion(1, gyroscope=True) + [{"name": "location", "time": T0 + 1_995_000_000, "values": fix}]
    refused = client.post("/push", json={"sessionId": "s", "payload": bad}, headers=headers)
    assert refused.status_code == 400 and "values." in refused.json()["detail"]
    for s in (1, 2, 3):  # the session goes on as if the refused message never came
        answer = client.post("/push", json={"sessionId": "s", "payload": _motion(s, gyroscope=True)},
                             headers=headers)
        assert answer.status_code == 200 and answer.json()["count"] == 20, answer.text


@pytest.mark.parametrize("column", ["ax", "time", "lat"])
def test_a_dict_typed_sample_column_is_a_400_not_a_500(client, column):
    phone = enrol(client, client.operator)
    ride = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=bearer(phone)).json()["ride_id"]
    samples = {c: [0.0, 0.05] for c in ("time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "lon")}
    samples[column] = {"a": 1.0, "b": 2.0}  # as long as the other columns
    answer = client.post(f"/api/rides/{ride}/samples", json={"samples": samples}, headers=bearer(phone))
    assert answer.status_code == 400 and f"field '{column}' must be a list of numbers" in answer.json()["detail"]
    with client.websocket_connect("/ws/ride") as ws:
        ws.send_json({"type": "resume", "token": phone, "ride_id": ride})
        assert ws.receive_json()["type"] == "resumed"
        ws.send_json({"type": "batch", "seq": 1, "samples": samples})
        assert ws.receive_json()["status"] == 400  # answered, and the socket stays open
        ws.send_json({"type": "end"})
        assert ws.receive_json()["type"] == "ended"


def test_a_new_sqlite_store_and_its_side_files_are_the_owners_only(tmp_path):
    import os
    import stat

    from ride_fixtures import batch
    from spotfree.ride.store import RideStore

    path = tmp_path / "rides.db"
    previous = os.umask(0o022)
    try:
        with RideStore(path, synchronous="normal") as store:
            _, token = store.register_device("phone")
            ride = store.start_ride(token, "v", "r")
            store.append_samples(token, ride, batch(0.0, 20))
            made = sorted(p.name for p in tmp_path.iterdir())
            modes = {p.name: stat.S_IMODE(p.stat().st_mode) for p in tmp_path.iterdir()}
    finally:
        os.umask(previous)
    assert "rides.db-wal" in made and set(modes.values()) == {0o600}, modes


def test_serve_on_a_port_in_use_says_so_in_one_line(tmp_path):
    import socket

    from typer.testing import CliRunner

    from spotfree.cli import app

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = CliRunner().invoke(app, ["serve", "--port", str(port), "--database", str(tmp_path / "r.db")])
    assert result.exit_code == 2 and f"127.0.0.1:{port} is in use by another program" in result.output
    assert len(result.output.strip().splitlines()) == 1 and not (tmp_path / "r.db").exists()


@pytest.mark.parametrize("url", ["postgresql://u:s3cret@[::1/db", "postgresql://u:s3%zzcret@host/db",
                                 "postgresql://u@h/db?password=s3cret&foo=bar"])
def test_a_malformed_postgresql_url_never_echoes_its_password(url):
    pytest.importorskip("psycopg")
    from spotfree.errors import InputError
    from spotfree.ride.postgres import PostgresConnection

    with pytest.raises(InputError) as refused:
        PostgresConnection(url)
    assert "s3" not in str(refused.value) and "***" in str(refused.value) and "\n" not in str(refused.value)


def test_the_watch_greeting_lists_a_device_only_its_own_open_rides(client):
    mine, theirs = enrol(client, client.operator), enrol(client, client.operator, "other")
    start = {"vehicle": "v", "rider_id": "r"}
    own = client.post("/api/rides", json=start, headers=bearer(mine)).json()["ride_id"]
    other = client.post("/api/rides", json=start, headers=bearer(theirs)).json()["ride_id"]
    with client.websocket_connect("/ws/watch", headers=bearer(mine)) as view:
        assert view.receive_json()["open"] == [own]
    with client.websocket_connect("/ws/watch", headers=client.operator) as view:
        assert set(view.receive_json()["open"]) == {own, other}


def test_a_ride_rebuilt_after_a_restart_does_not_stall_the_loop(tmp_path, model, raw):
    """A long open ride's first batch after a restart: its rebuild from the store runs in a thread while the
    event loop keeps ticking (before, the loop stopped for the whole replay)."""
    import asyncio
    import time

    from spotfree.ride.service import RideService
    from spotfree.ride.store import RideStore
    from test_ride_service import _columns

    rows = _rides(raw)
    path = tmp_path / "rides.db"
    first = RideService(model, RideStore(path, synchronous="normal"))
    _, token = first.register_device("phone")
    ride = first.start_ride(token, "v", "r")
    shift = np.zeros(rows.shape[1])
    long = np.vstack([rows + np.r_[k * (rows[-1, 0] + 0.05), shift[1:]] for k in range(8)])
    for k in range(0, len(long), 5000):
        first.ingest(token, ride, _columns(long[k:k + 5000]), check_rate=False)
    first.close()
    again = RideService(model, RideStore(path, synchronous="normal"))
    batch = _columns(rows[:20] + np.r_[long[-1, 0] + 0.05, shift[1:]])

    async def run():
        gaps, last, done = [], time.perf_counter(), asyncio.Event()

        async def tick():
            nonlocal last
            while not done.is_set():
                await asyncio.sleep(0.005)
                now = time.perf_counter()
                gaps.append(now - last)
                last = now
        ticker = asyncio.create_task(tick())
        started = time.perf_counter()
        ack = await again.ingest_async(token, ride, batch)
        took = time.perf_counter() - started
        done.set()
        await ticker
        return ack, took, max(gaps)
    try:
        ack, took, gap = asyncio.run(run())
    finally:
        again.close()
    assert ack["count"] == 20
    assert gap < max(0.1, took / 3), (gap, took)  # the loop ticked all along the rebuild


def test_the_idle_ride_thread_survives_any_error(tmp_path, model, monkeypatch, caplog):
    import time

    from spotfree.ride.service import RideService
    from spotfree.ride.store import RideStore

    service = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    rounds = []

    def flaky(*args, **kwargs):
        rounds.append(1)
        if len(rounds) == 2:
            raise KeyError("a corrupt row")  # not a SpotfreeError
        return []
    monkeypatch.setattr(service, "close_idle_rides", flaky)
    try:
        service.keep_tidy(every=0.02)
        deadline = time.monotonic() + 5
        while len(rounds) < 4 and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        service.close()
    assert len(rounds) >= 4 and "closing idle rides failed" in caplog.text


def test_a_worker_being_replaced_stalls_no_other_call(model, raw, tmp_path, monkeypatch):
    """A killed worker's replacement is started outside the pool's lock: while it starts (made slow here), health
    answers at once and says degraded, the other worker's rides go on, and new rides go to the live worker; a ride
    whose owner this process does not know (a restart) has it again once resumed."""
    import os
    import signal
    import time

    from spotfree.ride.pool import RideServicePool
    from spotfree.ride.store import RideStore
    from spotfree.ride.tokens import token_hash
    from test_ride_service import _columns

    rows = _rides(raw)
    pool = RideServicePool(model, RideStore(tmp_path / "rides.db", synchronous="normal"), processes=2)
    try:
        _, token = pool.register_device("phone")
        doomed, spared = pool.start_ride(token, "v", "r"), pool.start_ride(token, "v", "r")
        start = pool._start_worker

        def slow_start(index):
            time.sleep(2.0)  # a large model takes seconds to reach a new process
            return start(index)
        monkeypatch.setattr(pool, "_start_worker", slow_start)
        victim = pool._home[doomed]
        os.kill(victim._process.pid, signal.SIGKILL)
        victim._process.join(30)
        time.sleep(0.3)  # the reader thread has noticed and is starting the replacement
        began = time.monotonic()
        health = pool.health()
        assert time.monotonic() - began < 0.5 and health["status"] == "degraded" and health["restarts"] == 0
        began = time.monotonic()
        assert pool.ingest(token, spared, _columns(rows[:20]))["count"] == 20
        fresh = pool.start_ride(token, "v", "r")
        assert time.monotonic() - began < 1.5 and pool._home[fresh] is pool._home[spared]
        deadline = time.monotonic() + 120
        while pool.health()["status"] != "ok":
            assert time.monotonic() < deadline, pool.health()
            time.sleep(0.1)
        assert pool.health()["restarts"] == 1
        # as after a restart of the server: the ride's owner is known again once its device resumes it
        pool._owners.pop(doomed)
        assert pool.resume(token, doomed) is None
        assert pool._owners[doomed] == token_hash(token)
        assert pool.ingest(token, doomed, _columns(rows[:20]))["count"] == 20  # rebuilt from the store
    finally:
        pool.close()


def test_reading_a_long_ride_does_not_stall_the_loop(client, raw, monkeypatch):
    """GET /api/rides/{id}: the ride is read and encoded in a thread; the event loop only sends the bytes."""
    import asyncio

    from spotfree.ride import api
    from test_ride_service import _columns

    phone = bearer(enrol(client, client.operator))
    ride = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=phone).json()["ride_id"]
    rows = _rides(raw)[:200]
    assert client.post(f"/api/rides/{ride}/samples", json={"samples": _columns(rows)}, headers=phone).status_code == 200
    on_loop, clean = [], api._clean

    def watched(value):
        try:
            asyncio.get_running_loop()
            on_loop.append(True)
        except RuntimeError:  # no loop runs in this thread
            on_loop.append(False)
        return clean(value)
    monkeypatch.setattr(api, "_clean", watched)
    got = client.get(f"/api/rides/{ride}", headers=phone)
    assert got.status_code == 200 and len(got.json()["samples"]["time"]) == 200
    assert got.json()["samples"]["lat"][1] is None  # NaN as null, as before
    assert on_loop and not any(on_loop)


def test_enrolment_code_guesses_are_throttled_per_address(client):
    from spotfree.ride.api import ENROLMENT_GUESSES

    answers = [client.post("/api/devices", json={"code": f"guess-{k}"}).status_code
               for k in range(ENROLMENT_GUESSES + 1)]
    assert answers == [403] * ENROLMENT_GUESSES + [429]
    code = client.post("/api/enrolments", json={}, headers=client.operator).json()["code"]
    refused = client.post("/api/devices", json={"code": code})  # even a good code waits its turn
    assert refused.status_code == 429 and int(refused.headers["retry-after"]) >= 1
    assert "refused codes from this address" in refused.json()["detail"]


def test_an_operator_token_rotated_elsewhere_is_seen_here(tmp_path, model, monkeypatch):
    from spotfree.ride import service as service_module
    from spotfree.ride.service import RideService
    from spotfree.ride.store import AccessError, RideStore

    path = tmp_path / "rides.db"
    here = RideService(model, RideStore(path, synchronous="normal"))
    elsewhere = RideService(model, RideStore(path, synchronous="normal"))  # another worker process or server
    try:
        old = here.new_operator_token()
        monkeypatch.setattr(service_module, "OPERATOR_RECHECK_SECONDS", 0.0)
        assert elsewhere.require_operator(old).role == "operator"
        new = here.new_operator_token()  # rotated while both serve
        assert elsewhere.require_operator(new).role == "operator"
        with pytest.raises(AccessError):
            elsewhere.require_operator(old)
    finally:
        here.close()
        elsewhere.close()


def test_a_damaged_ride_is_unreadable_alone(client, raw, tmp_path):
    from spotfree.fleet.ingest import ingest_store
    from spotfree.ride.store import DamagedRideError, RideStore
    from test_ride_service import _columns

    phone = bearer(enrol(client, client.operator))
    rows = _rides(raw)[:100]
    rides = []
    for _ in range(2):
        ride = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=phone).json()["ride_id"]
        assert client.post(f"/api/rides/{ride}/samples", json={"samples": _columns(rows)},
                           headers=phone).status_code == 200
        rides.append(ride)
    damaged, sound = rides
    store = client.service.store
    with store._transaction() as db:  # a block cut short, as a damaged disk or a hand edit leaves it
        db.execute("UPDATE sample_blocks SET samples = substr(samples, 1, 13) WHERE ride_id = ?", (damaged,))
    with pytest.raises(DamagedRideError, match=f"ride {damaged}: its stored samples are damaged"):
        store.samples(damaged)
    answer = client.get(f"/api/rides/{damaged}", headers=phone)
    assert answer.status_code == 500 and "damaged" in answer.json()["detail"]
    assert client.get(f"/api/rides/{sound}", headers=phone).status_code == 200
    # the idle check closes it all the same (without replaying it), and closes the sound one
    client.service._open.clear()  # as after a restart: both rebuilt from the store
    closed = client.service.close_idle_rides(now=store.ride(sound).started + 10 * 3600)
    assert set(closed) == {damaged, sound}
    with RideStore(tmp_path / "fleet.db") as fleet:
        report = ingest_store(fleet, store)
    assert len(report.added) == 1 and report.damaged == [damaged] and "1 damaged" in str(report)
