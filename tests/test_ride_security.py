"""Who may read and write what (the authorisation matrix), enrolment, security headers, and no secret in any
answer: the ride service's web API under FastAPI's TestClient."""

import pytest

pytest.importorskip("fastapi")
from fastapi.testclient import TestClient  # noqa: E402
from starlette.websockets import WebSocketDisconnect  # noqa: E402

from service_fixtures import bearer as _bearer, columns as _columns, enrol, model, raw  # noqa: E402,F401
from spotfree.ride.api import create_app  # noqa: E402
from spotfree.ride.redact import redact_location  # noqa: E402
from spotfree.ride.service import RideService  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402
from spotfree.ride.store import NotFoundError, RideStore  # noqa: E402


@pytest.fixture()
def world(tmp_path, model, raw):
    """A service with an operator, two enrolled devices A and B each with one ride, and the credentials:
    ``none``, ``forged``, ``A``, ``B``, ``operator`` (header dicts)."""
    service = RideService(model, RideStore(tmp_path / "rides.db", synchronous="normal"))
    with TestClient(create_app(service)) as client:
        operator = _bearer(service.new_operator_token())
        creds = {"none": {}, "forged": _bearer("forged-token"), "operator": operator}
        rows = recording_rows(raw.select_experiment(2))
        ride_of = {}
        for name in ("A", "B"):
            creds[name] = _bearer(enrol(client, operator, name))
            ride_of[name] = client.post("/api/rides", json={"vehicle": "v", "rider_id": f"rider-{name}"},
                                        headers=creds[name]).json()["ride_id"]
            assert client.post(f"/api/rides/{ride_of[name]}/samples", json={"samples": _columns(rows[:20])},
                               headers=creds[name]).status_code == 200
        client.service, client.creds, client.ride_of, client.rows = service, creds, ride_of, rows
        yield client


WHO = ("none", "forged", "A", "B", "operator")
MATRIX = [  # (action on device A's ride, expected status per credential in WHO order)
    ("list rides", (401, 401, 200, 200, 200)),
    ("read ride", (401, 401, 200, 403, 200)),
    ("write samples", (401, 401, 200, 403, 403)),
    ("set destination", (401, 401, 200, 403, 403)),
    ("end ride", (401, 401, 200, 403, 403)),
    ("issue enrolment code", (401, 401, 403, 403, 200)),
    ("start ride", (401, 401, 200, 200, 401)),
    ("push", (401, 401, 200, 200, 401)),
]


def _act(client, action, headers):
    ride = client.ride_of["A"]
    if action == "list rides":
        return client.get("/api/rides", headers=headers)
    if action == "read ride":
        return client.get(f"/api/rides/{ride}", headers=headers)
    if action == "write samples":
        return client.post(f"/api/rides/{ride}/samples", json={"samples": _columns(client.rows[20:30])},
                           headers=headers)
    if action == "set destination":
        return client.post(f"/api/rides/{ride}/destination", json={"lat": 35.0, "lon": 139.0}, headers=headers)
    if action == "end ride":
        return client.post(f"/api/rides/{ride}/end", headers=headers)
    if action == "issue enrolment code":
        return client.post("/api/enrolments", json={"uses": 2}, headers=headers)
    if action == "start ride":
        return client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers)
    payload = [{"name": "totalacceleration", "time": 1.7e18, "values": {"x": 0.0, "y": 9.8, "z": 0.0}}]
    return client.post("/push", json={"sessionId": "s", "payload": payload}, headers=headers)


@pytest.mark.parametrize("action, expected", MATRIX, ids=[a for a, _ in MATRIX])
def test_authorisation_matrix(world, action, expected):
    got = tuple(_act(world, action, world.creds[who]).status_code for who in WHO)
    assert got == expected, dict(zip(WHO, got))
    if action == "write samples":  # only the owner's batch was stored
        stored = world.get(f"/api/rides/{world.ride_of['A']}", headers=world.creds["operator"]).json()
        assert len(stored["samples"]["time"]) == 30


def test_a_device_lists_and_watches_only_its_own_rides(world):
    ride_a, ride_b = world.ride_of["A"], world.ride_of["B"]
    assert [r["ride_id"] for r in world.get("/api/rides", headers=world.creds["A"]).json()] == [ride_a]
    assert {r["ride_id"] for r in world.get("/api/rides", headers=world.creds["operator"]).json()} == {ride_a, ride_b}
    with world.websocket_connect("/ws/watch") as view:  # the credential as the first message
        view.send_json({"type": "auth", "token": world.creds["A"]["Authorization"][7:]})
        assert view.receive_json()["role"] == "device"
        for name in ("B", "A"):
            world.post(f"/api/rides/{world.ride_of[name]}/samples", json={"samples": _columns(world.rows[20:25])},
                       headers=world.creds[name])
        assert view.receive_json()["ride_id"] == ride_a  # B's batch, published first, never reached A's view
    with world.websocket_connect("/ws/watch", headers=world.creds["operator"]) as view:
        assert view.receive_json()["role"] == "operator"
        world.post(f"/api/rides/{ride_b}/samples", json={"samples": _columns(world.rows[25:30])},
                   headers=world.creds["B"])
        assert view.receive_json()["ride_id"] == ride_b


@pytest.mark.parametrize("first", [None, {"type": "auth", "token": "forged"}, {"type": "batch"}, b"\x00binary"])
def test_watch_without_a_valid_credential_is_closed_with_a_reason(world, first, monkeypatch):
    from spotfree.ride import api

    monkeypatch.setattr(api, "AUTH_SECONDS", 0.2)
    with world.websocket_connect("/ws/watch") as view:
        if isinstance(first, bytes):
            view.send_bytes(first)
        elif first is not None:
            view.send_json(first)
        with pytest.raises(WebSocketDisconnect) as closed:
            view.receive_json()
    assert closed.value.code in (1003, 1008) and closed.value.reason


def test_enrolment_needs_a_live_code_and_a_json_body(world):
    operator = world.creds["operator"]
    assert world.post("/api/devices", json={"name": "x"}).status_code == 403
    assert world.post("/api/devices", json={"name": "x", "code": "guessed"}).status_code == 403
    code = world.post("/api/enrolments", json={"uses": 1}, headers=operator).json()["code"]
    # a cross-site form can post text/plain: refused before the code is looked at, the code still unused
    form = world.post("/api/devices", content=f'{{"code": "{code}"}}', headers={"Content-Type": "text/plain"})
    assert form.status_code == 415
    assert world.post("/api/devices", json={"code": code}).status_code == 200
    assert world.post("/api/devices", json={"code": code}).status_code == 403  # used up
    expired = world.service.store.issue_enrolment(uses=5, ttl=1)[0]
    with world.service.store._transaction() as db:
        db.execute("UPDATE enrolments SET expires = 0")
    assert world.post("/api/devices", json={"code": expired}).status_code == 403
    for bad in ({"uses": 0}, {"uses": "3"}, {"uses": True}, {"ttl": 1e9}, {"ttl": float("nan")}):
        response = world.post("/api/enrolments", content=str(bad).replace("'", '"').replace("True", "true")
                              .replace("nan", "NaN"), headers={**operator, "Content-Type": "application/json"})
        assert response.status_code == 400, (bad, response.text)


def test_token_in_the_url_is_not_a_credential(world):
    token = world.creds["A"]["Authorization"][7:]
    assert world.get(f"/api/rides?token={token}").status_code == 401
    assert world.post(f"/push?token={token}", json={"sessionId": "s", "payload": []}).status_code == 401


def test_every_answer_carries_the_security_headers(world):
    for response in (world.get("/"), world.get("/operator"), world.get("/static/phone.js"), world.get("/api/model"),
                     world.get("/api/rides"), world.get("/nowhere")):
        headers = response.headers
        assert headers["x-content-type-options"] == "nosniff"
        assert headers["x-frame-options"] == "DENY" and headers["referrer-policy"] == "no-referrer"
        policy = headers["content-security-policy"]
        assert "frame-ancestors 'none'" in policy and "script-src 'self'" in policy
        assert "unsafe-inline" not in policy.split("script-src")[1].split(";")[0]
    for page in ("phone.html", "rider.html", "operator.html"):  # no inline script for the policy to block
        text = world.get("/" + page.replace("phone.html", "").replace(".html", "")).text
        assert "<script>" not in text


def test_no_store_location_or_password_in_answers(tmp_path, model):
    secret = "s3cr3t-pw"
    url = f"postgresql://rider:{secret}@db.example:5432/rides?sslmode=require&password={secret}"
    shown = redact_location(url)
    assert secret not in shown and "db.example" in shown and "rider" in shown
    assert redact_location("rides.db") == "rides.db"
    store = RideStore(tmp_path / "rides.db")
    with pytest.raises(NotFoundError) as missing:
        store.ride("nope")
    assert str(tmp_path) not in str(missing.value)
    service = RideService(model, store)
    with TestClient(create_app(service)) as client:
        operator = _bearer(service.new_operator_token())
        response = client.get("/api/rides/nope", headers=operator)
        assert response.status_code == 404 and str(tmp_path) not in response.text and "rides.db" not in response.text


def test_postgres_refusal_names_no_password(monkeypatch):
    pytest.importorskip("psycopg")
    from spotfree.errors import InputError

    secret = "s3cr3t-pw"
    with pytest.raises(InputError) as refused:  # nothing listens on port 1
        RideStore(f"postgresql://rider:{secret}@127.0.0.1:1/rides?password={secret}&connect_timeout=2")
    assert secret not in str(refused.value) and "***" in str(refused.value)
