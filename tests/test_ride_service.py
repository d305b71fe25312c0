"""The live service's web API with FastAPI's TestClient: devices, rides, batches, refusals, views, push, pipeline."""

import json
import math
import shutil
import subprocess

import numpy as np
import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402

from classify_fixtures import rides, truth_model  # noqa: E402
from spotfree.classify.stream import RideClassifier  # noqa: E402
from spotfree.ride.api import create_app  # noqa: E402
from spotfree.ride.live import LiveRide, pipeline_spec  # noqa: E402
from spotfree.ride.records import SAMPLE_COLUMNS  # noqa: E402
from spotfree.ride.sensorpush import PushResampler, parse_push  # noqa: E402
from spotfree.ride.service import RideService  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402
from spotfree.ride.store import RideStore  # noqa: E402


@pytest.fixture(scope="module")
def raw():
    return rides(seed=1, repeats=2)


@pytest.fixture(scope="module")
def model(raw):
    return truth_model(raw.select_experiment(1))


@pytest.fixture()
def client(tmp_path, model):
    service = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    with TestClient(create_app(service)) as c:
        c.service = service
        yield c


def _device(client):
    body = client.post("/api/devices", json={"name": "phone"}).json()
    return {"Authorization": f"Bearer {body['token']}"}


def _columns(rows):
    return {name: [None if math.isnan(v) else float(v) for v in rows[:, j]] for j, name in enumerate(SAMPLE_COLUMNS)}


def _ride_rows(raw):
    return recording_rows(raw.select_experiment(2))


def test_live_ride_labels_equal_ride_classifier(raw, model):
    rows = _ride_rows(raw)
    live, reference = LiveRide(model), RideClassifier(model)
    got = [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows]
    want = [reference.update(r[1:4], r[4:7], r[0], r[9]) for r in rows]
    assert got == want
    assert {"sudden-braking", "cruising"} <= set(got)


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
    listed = client.get("/api/rides").json()
    assert listed[0]["ride_id"] == ride_id and listed[0]["live"] and listed[0]["skill"] == "novice"
    stored = client.get(f"/api/rides/{ride_id}").json()
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
    assert len(client.get(f"/api/rides/{ride_id}").json()["samples"]["time"]) == 40
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
                       headers={"Authorization": "Bearer forged"}).status_code == 403
    assert client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"},
                       headers={"Authorization": "Bearer forged"}).status_code == 401
    assert client.post("/api/rides/nope/samples", json=batch, headers=owner).status_code == 404
    assert client.post(f"/api/rides/{ride_id}/samples", content=b"{\"samples\": NaN}",
                       headers=owner).status_code == 400
    assert client.post(f"/api/rides/{ride_id}/samples", content=b"x" * 2_000_001, headers=owner).status_code == 413
    assert len(client.get(f"/api/rides/{ride_id}").json()["samples"]["time"]) == 0
    for page in ("/", "/rider", "/operator", "/static/pipeline.js"):
        assert client.get(page).status_code == 200
    assert client.post("/api/rides/" + ride_id).status_code == 405


def test_batch_rate_limited(client, raw):
    headers = _device(client)
    ride_id = client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers).json()["ride_id"]
    rows = _ride_rows(raw)
    codes = [client.post(f"/api/rides/{ride_id}/samples", json={"samples": _columns(rows[k:k + 1])},
                         headers=headers).status_code for k in range(60)]
    assert codes[:50] == [200] * 50 and 429 in codes[50:]


def test_websocket_stream_ack_resume_and_views(client, raw):
    token = client.post("/api/devices", json={}).json()["token"]
    rows = _ride_rows(raw)[:60]
    with client.websocket_connect("/ws/watch") as view:
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
    assert len(client.get(f"/api/rides/{ride_id}").json()["samples"]["time"]) == 60


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
    stored = client.get(f"/api/rides/{first['ride_id']}").json()["samples"]
    assert len(stored["time"]) == 99  # the last slot waits for a later reading
    assert np.allclose(stored["ax"], rows[:99, 1]) and np.allclose(stored["gz"], rows[:99, 6])
    assert client.post("/push", json={"payload": "x"}, headers=headers).status_code == 400
    assert client.post("/push", json=_push_message("s2", 1.7e18, rows[:5])).status_code == 401


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
    spec = json.loads(json.dumps(pipeline_spec(model)))
    d = len(model.channels) * model.window + 1
    assert len(spec["operator"]) == len(spec["classes"]) * d * d
    assert spec["pick"] == [6, 3]


@pytest.mark.skipif(shutil.which("node") is None, reason="node is not installed")
@pytest.mark.parametrize("orientation", ["default", "paper"])
def test_page_pipeline_labels_equal_server(tmp_path, raw, model, orientation):
    model.orientation = orientation
    try:
        rows = _ride_rows(raw)
        live = LiveRide(model)
        server = [live.update(r[0], r[1:4], r[4:7], r[9])[1] for r in rows]
        data = {"spec": pipeline_spec(model), "rows": [[None if math.isnan(v) else v for v in r] for r in rows]}
    finally:
        model.orientation = "default"
    (tmp_path / "in.json").write_text(json.dumps(data))
    script = """
const P = require(process.argv[1]);
const d = JSON.parse(require('fs').readFileSync(process.argv[2]));
const p = new P.Pipeline(d.spec);
console.log(JSON.stringify(d.rows.map((r) => p.update(r[0], r.slice(1, 4), r.slice(4, 7), r[9] === null ? NaN : r[9]).label)));
"""
    from spotfree.ride.api import STATIC

    page = subprocess.run(["node", "-e", script, str(STATIC / "pipeline.js"), str(tmp_path / "in.json")],
                          capture_output=True, text=True, check=True)
    assert json.loads(page.stdout) == server
