"""Rides survive restarts: an open ride is rebuilt from the store (same labels as if nothing had happened), an idle
one is closed, ``spotfree serve`` killed with SIGKILL takes the phone's ``resume`` after its restart, and SIGTERM
stops it even after a watcher left."""

import json
import os
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from service_fixtures import columns, model, raw  # noqa: F401
from spotfree.ride.live import LiveRide
from spotfree.ride.server import SHUTDOWN_SECONDS
from spotfree.ride.service import IDLE_SECONDS, RideService
from spotfree.ride.sources import recording_rows
from spotfree.ride.store import AccessError, RideStore


def _labels(model, rows):
    live = LiveRide(model)
    return [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows]


def _phone_ride(model, path):
    """``(service, token, ride)``: a service over a new store at ``path``, a device and its open ride."""
    service = RideService(model, RideStore(path, synchronous="normal"))
    _, token = service.register_device("phone")
    return service, token, service.start_ride(token, "v", "r")


def _stream(service, token, ride, rows, start, stop):
    """Send rows[start:stop] in batches of 50; labels and warnings of the acknowledgements."""
    labels, warned = [], []
    for k in range(start, stop, 50):
        ack = service.ingest(token, ride, columns(rows[k:min(k + 50, stop)]), check_rate=False)
        labels += ack["labels"]
        warned += ack["warnings"]
    return labels, warned


def test_an_open_ride_goes_on_after_a_restart_as_if_nothing_happened(tmp_path, model, raw):
    rows = recording_rows(raw.select_experiment(2))
    half = len(rows) // 2 // 50 * 50
    reference, own, whole = _phone_ride(model, tmp_path / "reference.db")
    want_labels, want_warnings = _stream(reference, own, whole, rows, 0, len(rows))
    reference.end_ride(own, whole)

    first, token, ride = _phone_ride(model, tmp_path / "rides.db")
    labels, warned = _stream(first, token, ride, rows, 0, half)
    first.store.close()  # the process ends without ending the ride
    second = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    assert second.resume(token, ride) == pytest.approx(rows[half - 1, 0])
    more_labels, more_warned = _stream(second, token, ride, rows, half, len(rows))
    assert labels + more_labels == want_labels
    assert warned + more_warned == want_warnings and want_warnings
    _, other = second.register_device("other")
    with pytest.raises(AccessError, match="may not write"):
        second.resume(other, ride)
    second.end_ride(token, ride)
    assert second.store.events(ride) == reference.store.events(whole)
    with pytest.raises(AccessError, match="not open"):
        second.resume(token, ride)
    second.close()
    reference.close()


def test_idle_rides_are_closed_with_their_open_episodes(tmp_path, model, raw):
    rows = recording_rows(raw.select_experiment(2))[:300]
    service = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    _, token = service.register_device("phone")
    idle, busy = service.start_ride(token, "v", "r"), service.start_ride(token, "v", "r")
    for ride in (idle, busy):
        service.ingest(token, ride, columns(rows))
    started = service.store.ride(idle).started
    assert service.close_idle_rides(now=started + rows[-1, 0] + IDLE_SECONDS / 2) == []
    service._open.pop(idle)  # as after a restart: only the store holds it
    closed = service.close_idle_rides(now=started + rows[-1, 0] + IDLE_SECONDS + 1)
    assert sorted(closed) == sorted([idle, busy])
    assert service.store.ride(idle).ended == pytest.approx(started + rows[-1, 0])
    with pytest.raises(AccessError, match="not open"):
        service.ingest(token, busy, columns(rows[-1:] + 1))
    service.close()


def test_a_destination_outlives_a_restart(tmp_path, model, raw):
    rows = recording_rows(raw.select_experiment(2))[:400]
    fixes = rows[~np.isnan(rows[:, 7])]
    target = (float(fixes[-1, 7]) + 0.01, float(fixes[-1, 8]) + 0.01)  # about 1.4 km past the last fix
    reference, own, whole = _phone_ride(model, tmp_path / "reference.db")
    reference.set_destination(own, whole, *target)
    _stream(reference, own, whole, rows, 0, 350)
    want = reference.ingest(own, whole, columns(rows[350:]), check_rate=False)["state"]
    assert want["remaining"] > 1000 and want["eta"] > 0  # the destination is what the figures count to

    first, token, ride = _phone_ride(model, tmp_path / "rides.db")
    first.set_destination(token, ride, *target)
    _stream(first, token, ride, rows, 0, 350)
    first.store.close()  # the process ends with the ride open
    second = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    assert second.store.destination(ride) == pytest.approx(target)
    got = second.ingest(token, ride, columns(rows[350:]), check_rate=False)["state"]
    assert got == pytest.approx(want, nan_ok=True)
    _, other = second.register_device("other")
    with pytest.raises(AccessError, match="another device"):
        second.store.set_destination(other, ride, 0.0, 0.0)
    assert second.store.destination(ride) == pytest.approx(target)  # the refused write changed nothing
    second.close()
    reference.close()


def test_a_ride_that_cannot_go_on_is_continued_by_a_linked_ride(tmp_path, model, raw):
    from fastapi.testclient import TestClient

    from spotfree.ride.api import create_app
    from spotfree.ride.store import ForbiddenError, NotFoundError

    rows = recording_rows(raw.select_experiment(2))[:100]
    service, token, first = _phone_ride(model, tmp_path / "rides.db")
    _, other = service.register_device("other")
    service.ingest(token, first, columns(rows[:50]))
    service.end_ride(token, first)  # as when it was closed while the phone was away
    with TestClient(create_app(service)) as client, client.websocket_connect("/ws/ride") as ws:
        ws.send_json({"type": "resume", "token": token, "ride_id": first})
        assert ws.receive_json()["status"] == 403
        # what the phone page sends then: a new ride continuing the old one, with the samples it still holds
        ws.send_json({"type": "start", "token": token, "vehicle": "v", "rider_id": "r", "continues_from": first})
        second = ws.receive_json()["ride_id"]
        ws.send_json({"type": "batch", "seq": 1, "samples": columns(rows[50:] - [rows[50, 0], *[0] * 9])})
        assert ws.receive_json()["count"] == 50
        ws.send_json({"type": "start", "token": other, "vehicle": "v", "rider_id": "r", "continues_from": first})
        assert ws.receive_json()["status"] == 403  # another device's ride is not continued
    assert service.store.ride(second).continues_from == first and service.store.ride(first).continues_from is None
    third = service.start_ride(token, "v", "r", continues_from=second)
    assert service.store.continuation(first) == service.store.continuation(third) == [first, second, third]
    assert service.store.continuation(service.start_ride(token, "v", "r")) != [first, second, third]
    before = len(service.store.rides())
    with pytest.raises(NotFoundError, match="continues_from"):
        service.start_ride(token, "v", "r", continues_from="no-such-ride")
    with pytest.raises(ForbiddenError, match="another device"):
        service.start_ride(other, "v", "r", continues_from=first)
    assert len(service.store.rides()) == before  # a refused start opens nothing
    service.close()


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _serve(tmp_path, port):
    """``spotfree serve`` over ``tmp_path/rides.db`` in a subprocess, once it answers."""
    import httpx

    server = subprocess.Popen([sys.executable, "-m", "spotfree.cli", "serve", "--port", str(port), "--database",
                               str(tmp_path / "rides.db"), "--model", str(tmp_path / "model.npz")],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        assert server.poll() is None, server.stderr.read()
        try:
            if httpx.get(f"http://127.0.0.1:{port}/api/health", timeout=2).status_code == 200:
                return server
        except httpx.TransportError:
            time.sleep(0.2)
    server.kill()
    raise AssertionError("spotfree serve did not answer within 60 s")


@pytest.mark.slow
def test_serve_killed_then_restarted_resumes_the_ride_and_stops_on_sigterm(tmp_path, model, raw):
    from websockets.sync.client import connect

    model.save(tmp_path / "model.npz")
    rows = recording_rows(raw.select_experiment(2))[:200]
    port = _free_port()
    url = f"ws://127.0.0.1:{port}"
    server = _serve(tmp_path, port)
    try:
        store = RideStore(tmp_path / "rides.db")
        _, token = store.register_device("phone")
        store.close()
        with connect(url + "/ws/ride") as ws:
            ws.send(json.dumps({"type": "start", "token": token, "vehicle": "v", "rider_id": "r"}))
            ride = json.loads(ws.recv())["ride_id"]
            for k in range(0, 100, 20):
                ws.send(json.dumps({"type": "batch", "seq": k, "samples": columns(rows[k:k + 20])}))
                assert json.loads(ws.recv())["type"] == "ack"
        server.send_signal(signal.SIGKILL)
        server.wait(10)
        server = _serve(tmp_path, port)
        with connect(url + "/ws/ride") as ws:
            ws.send(json.dumps({"type": "resume", "token": token, "ride_id": ride}))
            resumed = json.loads(ws.recv())
            assert resumed["type"] == "resumed" and resumed["last_time"] == pytest.approx(rows[99, 0])
            ws.send(json.dumps({"type": "batch", "seq": 1, "samples": columns(rows[100:200])}))
            ack = json.loads(ws.recv())
            assert ack["labels"] == _labels(model, rows)[100:]
        operator = (tmp_path / "rides.db.operator-token").read_text().strip()
        with connect(url + "/ws/watch", additional_headers={"Authorization": f"Bearer {operator}"}) as view:
            assert json.loads(view.recv())["type"] == "hello"
        time.sleep(0.5)
        asked = time.monotonic()
        server.send_signal(signal.SIGTERM)  # once hung for good after a watcher had left
        server.wait(30)
        assert time.monotonic() - asked < SHUTDOWN_SECONDS / 2  # not held until the shutdown's time-out
        assert server.returncode == 0, server.stderr.read()
    finally:
        if server.poll() is None:
            os.kill(server.pid, signal.SIGKILL)
    store = RideStore(tmp_path / "rides.db")
    assert len(store.samples(ride)["time"]) == 200
    store.close()
