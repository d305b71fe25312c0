"""The live service's web API with FastAPI's TestClient: devices, rides, batches, refusals, rate, warnings, views,
push, pipeline; and ``spotfree serve --simulate`` in a subprocess."""

import json
import math
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from classify_fixtures import truth_model  # noqa: E402
from service_fixtures import bearer, columns as _columns, enrol, model, raw, sample_and_block_runs  # noqa: E402,F401
from spotfree.classify.batch import dictionary_classifier  # noqa: E402
from spotfree.classify.stream import RideClassifier  # noqa: E402
from spotfree.ride.api import create_app  # noqa: E402
from spotfree.ride.live import LiveRide, pipeline_spec  # noqa: E402
from spotfree.ride.sensorpush import PushResampler, parse_push  # noqa: E402
from spotfree.ride import service as service_module  # noqa: E402
from spotfree.ride.service import BACKLOG_SECONDS, RATE_FACTOR, RideService  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402
from spotfree.ride.store import RideStore  # noqa: E402
from spotfree.signal.frame import MOUNT  # noqa: E402
from spotfree.signal.mount import REPORT_KINDS  # noqa: E402


@pytest.fixture()
def client(tmp_path, model):
    service = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    with TestClient(create_app(service)) as c:
        c.service = service
        c.operator = bearer(service.new_operator_token())
        yield c


def _enrol(client):
    return enrol(client, client.operator)


def _device(client):
    return bearer(_enrol(client))


def _ride_rows(raw):
    return recording_rows(raw.select_experiment(2))


def test_live_ride_labels_equal_ride_classifier(raw, model):
    rows = _ride_rows(raw)
    live, reference = LiveRide(model), RideClassifier(model)
    got = [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows]
    want = [reference.update(r[1:4], r[4:7], r[0], r[9]) for r in rows]
    assert got == want
    assert {"sudden-braking", "cruising"} <= set(got)


@pytest.mark.parametrize("method", ["kcrc", "nearest"])
def test_live_ride_blocks_equal_sample_by_sample_across_gaps_and_nan(raw, model, method):
    rows = _ride_rows(raw)[:500].copy()
    rows[200:, 0] += 2.0  # a time gap longer than MAX_GAP: a new segment
    rows[350, 2] = np.nan  # a sample that is not finite: a gap of one sample
    clf = dictionary_classifier(model, method, causal=True)
    want, got_features, got_labels = sample_and_block_runs(LiveRide(model, clf), LiveRide(model, clf), rows,
                                                          [1, 5, 7, 3, 40])
    assert got_labels == [label for _, label in want]
    np.testing.assert_array_equal(got_features, np.array([f for f, _ in want]))
    assert got_labels[200] is None and got_labels[350] is None and got_labels[351] is None
    assert len(set(got_labels) - {None}) >= 2


def test_ride_streamed_recorded_and_listed(client, raw):
    headers = _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "segway", "rider_id": "r1", "skill": "novice"},
                          headers=headers).json()["ride_id"]
    rows = _ride_rows(raw)[:400]
    labels = []
    for k in range(0, len(rows), 50):
        ack = client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[k:k + 50])},
                          headers=headers)
        assert ack.status_code == 200, ack.text
        assert ack.json()["count"] == len(rows[k:k + 50])
        labels += ack.json()["labels"]
    expected = [LiveRide(client.service.model).update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows[:1]]
    assert labels[0] == expected[0]
    listed = client.get("/api/rides", headers=headers).json()
    assert listed[0]["ride_id"] == ride_id and listed[0]["live"] and listed[0]["skill"] == "novice"
    stored = client.get(f"/api/rides/{ride_id}", headers=headers).json()
    assert len(stored["samples"]["time"]) == 400
    assert stored["labels"]["default"] == labels
    assert np.allclose(stored["samples"]["ax"], rows[:, 1])
    assert client.post(f"/api/rides/{ride_id}/end", headers=headers).status_code == 200
    assert client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[-5:] + [1000, *[0] * 9])},
                       headers=headers).status_code == 403


@pytest.mark.parametrize("change, status", [
    (lambda s: s.update(ax=[None] + s["ax"][1:]), 400),
    (lambda s: s.update(time=s["time"][::-1]), 400),
    (lambda s: s.update(gx=s["gx"][:-1]), 400),
    (lambda s: s.pop("gz"), 400),
    (lambda s: s.update(ay=["x"] * len(s["ay"])), 400),
    (lambda s: s.update(ay=[str(v) for v in s["ay"]]), 400),  # numeric text is not converted
    (lambda s: s.update(gx=[True] * len(s["gx"])), 400),
    (lambda s: s["time"].__setitem__(-1, 1e300), 400),  # once killed the ride
    (lambda s: s.update(time=[t * 1000 for t in s["time"]]), 400),  # milliseconds
    (lambda s: s["time"].__setitem__(-1, s["time"][-2] + 3601.0), 400),  # a pause longer than MAX_STEP
    (lambda s: s["ax"].__setitem__(3, 1e300), 400),
    (lambda s: s.update(lat=[35.0] * len(s["lat"]), lon=[500.0] * len(s["lon"])), 400),
    (lambda s: s.update(speed=[-3.0] * len(s["speed"])), 400),
])
def test_bad_batch_refused_and_nothing_changes(client, raw, change, status):
    headers = _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers).json()["ride_id"]
    rows = _ride_rows(raw)
    assert client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[:40])},
                       headers=headers).status_code == 200
    bad = _columns(rows[40:60])
    change(bad)
    response = client.post(f"/api/rides/{ride_id}/samples", json={"samples": bad}, headers=headers)
    assert response.status_code == status, response.text
    assert len(client.get(f"/api/rides/{ride_id}", headers=headers).json()["samples"]["time"]) == 40
    # the stream goes on where it was: the same good batch is taken, labels as if nothing bad had come
    ack = client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[40:60])}, headers=headers)
    assert ack.status_code == 200
    live = LiveRide(client.service.model)
    assert ack.json()["labels"] == [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows[:60]][40:]


def test_tokens_rides_and_views_are_guarded(client, raw):
    owner, other = _device(client), _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=owner).json()["ride_id"]
    batch = {"samples": _columns(_ride_rows(raw)[:10])}
    assert client.post(f"/api/rides/{ride_id}/samples", json=batch, headers=other).status_code == 403
    assert client.post(f"/api/rides/{ride_id}/samples", json=batch).status_code == 401
    assert client.post(f"/api/rides/{ride_id}/samples", json=batch,
                       headers={"Authorization": "Bearer forged"}).status_code == 401
    assert client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"},
                       headers={"Authorization": "Bearer forged"}).status_code == 401
    assert client.post("/api/rides/nope/samples", json=batch, headers=owner).status_code == 404
    as_json = {**owner, "Content-Type": "application/json"}
    assert client.post(f"/api/rides/{ride_id}/samples", content=b"{\"samples\": NaN}",
                       headers=as_json).status_code == 400
    assert client.post(f"/api/rides/{ride_id}/samples", content=b"{}",
                       headers={**owner, "Content-Type": "text/plain"}).status_code == 415
    assert client.post(f"/api/rides/{ride_id}/samples", content=b"x" * 2_000_001, headers=owner).status_code == 413
    assert len(client.get(f"/api/rides/{ride_id}", headers=owner).json()["samples"]["time"]) == 0
    for page in ("/", "/rider", "/operator", "/static/pipeline.js"):
        assert client.get(page).status_code == 200
    assert client.post("/api/rides/" + ride_id).status_code == 405


class _Clock:
    """A monotonic clock the test moves by hand."""

    def __init__(self):
        self.now = 1000.0

    def monotonic(self):
        return self.now


@pytest.fixture()
def fake(monkeypatch):
    """The service's rate limit on a clock the test moves."""
    clock = _Clock()
    monkeypatch.setattr(service_module, "clock", clock)
    return clock


def test_rate_limit_counts_samples_and_takes_a_minute_of_backlog(client, raw, fake):
    headers = _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers).json()["ride_id"]
    rows, rate = _ride_rows(raw), client.service.model.rate
    url = f"/api/rides/{ride_id}/samples"
    # a phone back after 60 s offline resends its backlog at once, in 10 s batches: all taken
    backlog = int(BACKLOG_SECONDS * rate)
    for k in range(0, backlog, 200):
        assert client.post(url, json={"samples": _columns(rows[k:k + 200])}, headers=headers).status_code == 200
    refused = client.post(url, json={"samples": _columns(rows[backlog:backlog + 40])}, headers=headers)
    assert refused.status_code == 429 and refused.headers["retry-after"] == "1"
    assert len(client.get(f"/api/rides/{ride_id}", headers=client.operator).json()["samples"]["time"]) == backlog
    # sustained: RATE_FACTOR times the model's rate, whatever the batch size
    fake.now += 0.5
    sent, k = 0, backlog
    for size in (1, 1, 5, 10, 20, 3):
        assert client.post(url, json={"samples": _columns(rows[k:k + size])}, headers=headers).status_code == 200
        sent, k = sent + size, k + size
    assert sent == 0.5 * RATE_FACTOR * rate
    assert client.post(url, json={"samples": _columns(rows[k:k + 1])}, headers=headers).status_code == 429
    fake.now += 1 / (RATE_FACTOR * rate)
    assert client.post(url, json={"samples": _columns(rows[k:k + 1])}, headers=headers).status_code == 200
    with client.websocket_connect("/ws/ride") as ws:
        ws.send_json({"type": "resume", "token": headers["Authorization"][7:], "ride_id": ride_id})
        ws.receive_json()
        ws.send_json({"type": "batch", "seq": 9, "samples": _columns(rows[k + 1:k + 21])})
        reply = ws.receive_json()
        assert reply["status"] == 429 and reply["seq"] == 9
        assert reply["retry_after"] == pytest.approx(20 / (RATE_FACTOR * rate))


def test_sudden_stops_warn_once_each_and_are_recorded(client, raw, fake):
    """A simulated ride with three sudden stops streamed in phone-sized batches: one warning per stop, every warning
    at a stop, events recorded, trip figures in the ack (debouncing of a flickering label: test_ride_assistant)."""
    rec = raw.select_experiment(2)
    rows, truth = _ride_rows(raw), rec.truth["label"]
    headers = _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers).json()["ride_id"]
    last = rows[~np.isnan(rows[:, 7])][-1]
    assert client.post(f"/api/rides/{ride_id}/destination", json={"lat": last[7], "lon": last[8]},
                       headers=headers).status_code == 200
    assert client.post(f"/api/rides/{ride_id}/destination", json={"lat": 91, "lon": 0},
                       headers=headers).status_code == 400
    labels, warnings, events, states = [], [], [], []
    for k in range(0, len(rows), 5):
        fake.now += 0.25  # a phone's pace
        ack = client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[k:k + 5])},
                          headers=headers).json()
        labels += ack["labels"]
        warnings += ack["warnings"]
        events += ack["events"]
        states.append(ack["state"])
    assert client.post(f"/api/rides/{ride_id}/end", headers=headers).status_code == 200
    time = rows[:, 0]
    # stops: runs of braking in the truth (the simulator's near-sudden crossing stop is one too)
    braking = truth != "cruising"
    edges = np.flatnonzero(np.diff(np.r_[0, braking.astype(int), 0]))
    stops = list(zip(time[edges[::2]], time[edges[1::2] - 1]))
    sudden = [(a, b) for a, b in stops if "sudden-braking" in truth[(time >= a) & (time <= b)]]
    assert len(sudden) == 3
    assert "sudden-braking" in labels
    per_stop = [sum(a - 0.5 <= w["onset"] <= b for w in warnings) for a, b in stops]
    assert all(per_stop[stops.index(s)] == 1 for s in sudden) and max(per_stop) == 1
    assert sum(per_stop) == len(warnings)  # no warning away from a stop
    stored = client.get(f"/api/rides/{ride_id}", headers=client.operator).json()["events"]
    mounts = [e for e in stored if e["kind"] in REPORT_KINDS]
    assert [(e["kind"], e["start"]) for e in stored if e not in mounts] == [
        ("sudden-braking", w["onset"]) for w in warnings]
    # the tablet lies flat: its mount is reported, usual, as soon as it is known, and again once GPS tells forward
    assert [e["kind"] for e in mounts] == ["mount", "mount"] and mounts[0]["start"] < 5
    assert "nominal used" in mounts[0]["detail"] and "GPS speed" in mounts[1]["detail"]
    events = [e for e in events if e["kind"] not in REPORT_KINDS]
    assert len(events) == len(warnings) - 1 or len(events) == len(warnings)  # the last may end with the ride
    final = states[-1]
    assert final["distance"] > 50 and final["remaining"] < 20 and final["speed"] is not None
    assert any(s["eta"] is not None and s["eta"] > 0 for s in states)


def test_serve_simulate_end_to_end(tmp_path, model):
    """``spotfree serve --simulate sudden-braking`` in a subprocess: a ride appears, is recorded and warned of."""
    import signal
    import socket
    import sys
    import time

    import httpx

    model.save(tmp_path / "model.npz")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = subprocess.Popen([sys.executable, "-m", "spotfree.cli", "serve", "--port", str(port), "--database",
                               str(tmp_path / "rides.db"), "--model", str(tmp_path / "model.npz"), "--simulate",
                               "sudden-braking", "--speed", "10"],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    url, events, rides_listed = f"http://127.0.0.1:{port}", [], []
    token_file = tmp_path / "rides.db.operator-token"
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not events:
            time.sleep(0.3)
            assert server.poll() is None, server.stderr.read()
            if not token_file.exists():
                continue
            operator = {"Authorization": f"Bearer {token_file.read_text().strip()}"}
            try:
                rides_listed = httpx.get(url + "/api/rides", headers=operator).json()
            except httpx.TransportError:
                continue
            if rides_listed:
                events = [e for e in httpx.get(f"{url}/api/rides/{rides_listed[-1]['ride_id']}",
                                               headers=operator).json()["events"] if e["kind"] not in REPORT_KINDS]
        assert rides_listed and rides_listed[-1]["vehicle"].startswith("simulated sudden-braking")
        assert rides_listed[-1]["live"] and events and events[-1]["kind"] == "sudden-braking"
        assert httpx.get(url + "/rider").status_code == 200
        assert httpx.get(url + "/api/rides").status_code == 401
        assert oct(token_file.stat().st_mode & 0o777) == "0o600"
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(20)
    assert server.returncode == 0
    banner = server.stderr.read()
    assert str(token_file) in banner and token_file.read_text().strip() not in banner


def test_websocket_stream_ack_resume_and_views(client, raw):
    token = _enrol(client)
    rows = _ride_rows(raw)[:60]
    with client.websocket_connect("/ws/watch", headers=client.operator) as view:
        assert view.receive_json()["type"] == "hello"
        with client.websocket_connect("/ws/ride") as ws:
            ws.send_json({"type": "batch", "seq": 1, "samples": _columns(rows[:5])})
            assert ws.receive_json()["status"] == 401
            ws.send_json({"type": "start", "token": token, "vehicle": "v", "rider_id": "r"})
            ride_id = ws.receive_json()["ride_id"]
            ws.send_json({"type": "batch", "seq": 1, "samples": _columns(rows[:30])})
            ack = ws.receive_json()
            assert ack["type"] == "ack" and ack["seq"] == 1 and ack["count"] == 30
        assert view.receive_json()["type"] == "ride"
        published = view.receive_json()
        assert published["ride_id"] == ride_id and published["labels"] == ack["labels"]
        assert len(published["pitch"]) == 30
        with client.websocket_connect("/ws/ride") as ws:
            ws.send_json({"type": "resume", "token": token, "ride_id": ride_id})
            resumed = ws.receive_json()
            assert resumed["last_time"] == pytest.approx(rows[29, 0])
            ws.send_json({"type": "batch", "seq": 2, "samples": _columns(rows[20:40])})
            assert ws.receive_json()["status"] == 400  # already recorded: refused, nothing doubled
            ws.send_json({"type": "batch", "seq": 3, "samples": _columns(rows[30:60])})
            assert ws.receive_json()["count"] == 30
    assert len(client.get(f"/api/rides/{ride_id}", headers=client.operator).json()["samples"]["time"]) == 60


@pytest.mark.parametrize("message, code", [
    (b"\x01\x02", 1003),  # a binary frame
    ('{"type": "resume", "token": "t", "ride_id": {"a": 1}}', None),  # an object ride id: an error reply
    ('{"type": "batch", "seq": [1]}', None),
])
def test_websocket_refusals_answer_or_close_with_a_reason(client, message, code):
    from starlette.websockets import WebSocketDisconnect

    with client.websocket_connect("/ws/ride") as ws:
        if isinstance(message, bytes):
            ws.send_bytes(message)
            with pytest.raises(WebSocketDisconnect) as closed:
                ws.receive_json()
            assert closed.value.code == code and "binary" in closed.value.reason
            return
        ws.send_text(message)
        reply = ws.receive_json()
        assert reply["type"] == "error" and 400 <= reply["status"] < 500 and "\n" not in reply["message"]
        ws.send_text("[]")  # the socket is still open and answers
        assert ws.receive_json()["status"] == 400


def _push_message(session, t0_ns, rows, platform_sign=1.0):
    payload = []
    for r in rows:
        t = int(t0_ns + r[0] * 1e9)
        payload.append({"name": "totalacceleration", "time": t,
                        "values": {"x": platform_sign * r[1], "y": platform_sign * r[2], "z": platform_sign * r[3]}})
        payload.append({"name": "gyroscope", "time": t + 1000, "values": {"x": r[4], "y": r[5], "z": r[6]}})
    return {"messageId": 1, "sessionId": session, "deviceId": "dev", "payload": payload}


def test_sensor_logger_push(client, raw):
    headers = _device(client)
    rows = _ride_rows(raw)[:100]
    first = client.post("/push", json=_push_message("s1", 1.7e18, rows[:50]), headers=headers).json()
    second = client.post("/push?platform=ios", json=_push_message("s1", 1.7e18, rows[50:], -1.0),
                         headers=headers).json()
    assert first["ride_id"] == second["ride_id"]
    stored = client.get(f"/api/rides/{first['ride_id']}", headers=headers).json()["samples"]
    assert len(stored["time"]) == 99  # the last slot waits for a later reading
    assert np.allclose(stored["ax"], rows[:99, 1]) and np.allclose(stored["gz"], rows[:99, 6])
    assert client.post("/push", json={"payload": "x"}, headers=headers).status_code == 400
    assert client.post("/push", json=_push_message("s2", 1.7e18, rows[:5])).status_code == 401


def test_push_refusals_change_nothing_and_drops_are_counted(client, raw):
    headers = _device(client)
    rows = _ride_rows(raw)[:60]
    first = client.post("/push", json=_push_message("s1", 1.7e18, rows[:30]), headers=headers)
    assert first.status_code == 200 and first.json()["count"] == 29 and first.json()["dropped"] == 0
    ride = first.json()["ride_id"]
    stored = lambda: len(client.get(f"/api/rides/{ride}", headers=headers).json()["samples"]["time"])  # noqa: E731
    late = client.post("/push", json=_push_message("s1", 1.7e18, rows[:30]), headers=headers)  # sent twice
    assert late.status_code == 400 and "already stored" in late.json()["detail"]
    bad = _push_message("s1", 1.7e18, rows[30:40])
    bad["payload"][3]["values"]["x"] = 1e300  # beyond any phone's accelerometer: the whole message refused
    assert client.post("/push", json=bad, headers=headers).status_code == 400
    for broken in ({"x": "0.5", "y": 0.0, "z": 9.8}, [1.0, 2.0]):
        message = _push_message("s1", 1.7e18, rows[30:40])
        message["payload"][0]["values"] = broken
        assert client.post("/push", json=message, headers=headers).status_code == 400
    located = _push_message("s1", 1.7e18, rows[30:40])
    located["payload"].append({"name": "location", "time": int(1.7e18 + rows[35, 0] * 1e9), "values": [35.0, 139.0]})
    assert client.post("/push", json=located, headers=headers).status_code == 400
    assert stored() == 29
    # the refused messages left the session as it was: the next one goes on from slot 29
    again = _push_message("s1", 1.7e18, rows[30:40])
    again["payload"] = [r for r in again["payload"]
                        if not (r["name"] == "gyroscope" and r["time"] < 1.7e18 + rows[33, 0] * 1e9)]
    answer = client.post("/push", json=again, headers=headers).json()
    # slot 29 (pending) and 33-38 stored; 30-32 lacked a gyroscope reading: their accelerometer readings dropped
    assert answer["count"] == 7 and answer["dropped"] == 3 and stored() == 36


def test_push_resampler_averages_slots():
    readings = [("acc", 1e9 + k * 0.01, (k, 0.0, 9.8)) for k in range(10)]
    readings += [("gyr", 1e9 + k * 0.01, (0.0, 0.0, k)) for k in range(10)]
    readings += [("fix", 1e9 + 0.02, (35.0, 139.0, 2.0))]
    out = PushResampler(20.0).add(sorted(readings, key=lambda r: r[1]))
    # slot 0 holds readings 0-2 (0.00-0.02 s), slot 1 readings 3-7; slot 2 waits for a later reading
    assert out["time"] == [0.0, 0.05] and out["ax"] == [1.0, 5.0] and out["gz"] == [1.0, 5.0]
    assert math.isnan(out["lat"][0]) and out["lat"][1] == 35.0
    with pytest.raises(Exception, match="sessionId"):
        parse_push({"payload": []})


def test_pipeline_spec_round_trips_json(model):
    crc = json.loads(json.dumps(pipeline_spec(model, dictionary_classifier(model, "crc"))))
    d = len(model.channels) * model.window + 1
    assert len(crc["operator"]) == len(crc["classes"]) * d * d and crc["kernel"] is None
    assert crc["pick"] == [6, 3]
    kernel = json.loads(json.dumps(pipeline_spec(model)))["kernel"]  # the default method: kernel CRC_RLS
    f = kernel["features"]
    assert len(kernel["landmarks"]) == kernel["m"] * d and len(kernel["normalisation"]) == f * kernel["m"]
    assert len(json.loads(json.dumps(pipeline_spec(model)))["operator"]) == len(crc["classes"]) * f * f


@pytest.fixture(scope="module")
def summary_model(raw):
    """A dictionary of the summary representation (the page computes it in JavaScript); truth-named, for the
    mechanics."""
    return truth_model(raw.select_experiment(1), representation="summary")


UPRIGHT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""``v_device = UPRIGHT @ v_flat_device``: the simulated tablet stood upright in a holder, screen to the rider."""


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
@pytest.mark.parametrize("orientation, method, reject, summary, mount", [
    ("default", "kcrc", None, False, None), ("paper", "kcrc", None, False, None),
    ("default", "crc", None, False, None), ("default", "kcrc", 0.3, False, None),
    ("default", "kcrc", None, True, None), ("default", "kcrc", None, False, UPRIGHT),
    ("paper", "crc", None, False, UPRIGHT)], ids=["default", "paper", "crc", "reject", "summary", "upright",
                                                  "upright-paper-crc"])
def test_page_pipeline_labels_equal_server(tmp_path, raw, model, summary_model, orientation, method, reject,
                                           summary, mount):
    if summary:
        model = summary_model
    model.orientation = orientation
    try:
        rows = _ride_rows(raw)
        if mount is not None:
            rows[:, 1:4], rows[:, 4:7] = rows[:, 1:4] @ mount.T, rows[:, 4:7] @ mount.T
        clf = dictionary_classifier(model, method, reject=reject)
        live = LiveRide(model, classifier=clf)
        server = [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows]
        reports = live.mount.pop_reports()
        data = {"spec": pipeline_spec(model, clf), "rows": [[None if math.isnan(v) else v for v in r] for r in rows]}
    finally:
        model.orientation = "default"
    (tmp_path / "in.json").write_text(json.dumps(data))
    script = """
const P = require(process.argv[1]);
const d = JSON.parse(require('fs').readFileSync(process.argv[2]));
const p = new P.Pipeline(d.spec);
const labels = d.rows.map((r) => p.update(r[0], r.slice(1, 4), r.slice(4, 7), r[9] === null ? NaN : r[9]).label);
console.log(JSON.stringify({labels, used: p.mount.used, stage: p.mount.stage}));
"""
    from spotfree.ride.api import STATIC

    page = subprocess.run(["node", "-e", script, str(STATIC / "pipeline.js"), str(tmp_path / "in.json")],
                          capture_output=True, text=True, check=True)
    answer = json.loads(page.stdout)
    assert answer["labels"] == server
    assert len(set(server) - {None}) > 1  # the labels move: equality is not trivial
    assert answer["stage"] == live.mount.stage == "final" and len(reports) == 2  # vertical, then GPS forward
    np.testing.assert_allclose(answer["used"], live.mount.used, atol=1e-12)
    if mount is not None:  # the page switched with the server (twice: the labels would differ otherwise)
        assert not np.array_equal(live.mount.used, MOUNT)
