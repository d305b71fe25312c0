"""The web API of :class:`~spotfree.ride.service.RideService` (FastAPI).

Pages: ``/`` the phone page (streams DeviceMotion and Geolocation), ``/rider`` and ``/operator`` the views
(read-only), ``/static/*`` their scripts. Devices (``Authorization: Bearer <token>``, or the ``token`` field of a
WebSocket message):

* ``POST /api/devices`` ``{"name"}`` -> ``{"device_id", "token"}`` (the token is shown once);
* ``POST /api/rides`` ``{"vehicle", "rider_id", "age_band"?, "gender"?, "skill"?}`` -> ``{"ride_id"}``;
* ``POST /api/rides/{id}/samples`` ``{"samples": {column: [...]}}`` -> the acknowledgement;
* ``POST /api/rides/{id}/destination`` ``{"lat", "lon"}``; ``POST /api/rides/{id}/end``;
* ``WS /ws/ride``: ``{"type": "start", "token", "vehicle", "rider_id"}`` or ``{"type": "resume", "token",
  "ride_id"}``, then ``{"type": "batch", "seq", "samples"}`` (answered ``{"type": "ack", "seq", ...}``),
  ``{"type": "destination", "lat", "lon"}``, ``{"type": "end"}``; a refused message is answered
  ``{"type": "error", "status", "message"}`` (``seq`` too for a batch, ``retry_after`` s for a 429) and changes
  nothing;
* ``POST /push?platform=android|ios`` the Sensor Logger app's HTTP push (:mod:`spotfree.ride.sensorpush`): one
  ride per ``sessionId``.

Views: ``GET /api/model`` (the pipeline for the page, :func:`~spotfree.ride.live.pipeline_spec`),
``GET /api/rides``, ``GET /api/rides/{id}`` (samples, features, labels, events, for replay) and ``WS /ws/watch``
(``?ride=`` one ride) stream what the service publishes; nothing a view sends is read.

Refusals: 400 bad input, 401 no or unknown token, 403 a ride of another device, 404 unknown ride, 413 a body over
:data:`MAX_BODY` bytes, 429 samples sent faster than the service takes them (``Retry-After``; see
:mod:`spotfree.ride.service`).
"""

from __future__ import annotations

import inspect
import math
from importlib.resources import files
from pathlib import Path

from fastapi import FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect
import orjson
from fastapi.responses import FileResponse, JSONResponse
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool

from spotfree.errors import InputError, SpotfreeError
from spotfree.ride.sensorpush import PushResampler, parse_push
from spotfree.ride.service import RateError, RideService
from spotfree.ride.store import AccessError, NotFoundError

MAX_BODY = 2_000_000
"""Bytes in one request body or WebSocket message."""
STATIC = Path(str(files("spotfree.ride") / "static"))


def _status(exc: Exception) -> int:
    if isinstance(exc, NotFoundError):
        return 404
    if isinstance(exc, RateError):
        return 429
    if isinstance(exc, AccessError):
        return 403 if "may not write" in str(exc) or "not open" in str(exc) else 401
    return 400


async def _call(function, *args, **kwargs):
    """Await a service coroutine, or run a blocking service call in the thread pool; refusals become HTTP errors
    (429 with Retry-After)."""
    try:
        if inspect.iscoroutinefunction(function):
            return await function(*args, **kwargs)
        return await run_in_threadpool(function, *args, **kwargs)
    except (SpotfreeError, ValueError) as exc:
        headers = {"Retry-After": str(math.ceil(exc.retry_after))} if isinstance(exc, RateError) else None
        raise HTTPException(_status(exc), str(exc), headers=headers) from None


def _token(request: Request) -> str:
    header = request.headers.get("authorization", "")
    if header.lower().startswith("bearer "):
        return header[7:].strip()
    token = request.query_params.get("token")
    if not token:
        raise HTTPException(401, "no device token; send 'Authorization: Bearer <token>' (POST /api/devices gives one)")
    return token


async def _body(request: Request) -> dict:
    raw = await request.body()
    if len(raw) > MAX_BODY:
        raise HTTPException(413, f"body of {len(raw)} bytes; send at most {MAX_BODY}")
    try:
        body = _json(raw or b"{}")
    except InputError as exc:
        raise HTTPException(400, f"body {exc}") from None
    if not isinstance(body, dict):
        raise HTTPException(400, "body must be a JSON object")
    return body


def _json(raw: bytes | str):
    """Strict JSON (orjson): NaN and Infinity are refused (InputError)."""
    try:
        return orjson.loads(raw)
    except orjson.JSONDecodeError as exc:
        raise InputError(f"is not JSON ({exc}); send finite numbers or null, no NaN or Infinity") from None


def _clean(value):
    """NumPy arrays and NaN to JSON (lists, None)."""
    if hasattr(value, "tolist"):
        value = value.tolist()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, list):
        return [_clean(v) for v in value]
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    return value


def create_app(service: RideService) -> FastAPI:
    """The FastAPI application serving ``service`` (see the module docstring)."""
    app = FastAPI(title="spotfree ride assistant", docs_url=None, redoc_url=None)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    sessions: dict[tuple[str, str], tuple[str, PushResampler]] = {}

    for route, page in (("/", "phone.html"), ("/rider", "rider.html"), ("/operator", "operator.html")):
        app.add_api_route(route, lambda page=page: FileResponse(STATIC / page), methods=["GET"],
                          include_in_schema=False)

    @app.get("/api/model")
    def model():
        return service.spec

    @app.post("/api/devices")
    async def register(request: Request):
        body = await _body(request)
        device_id, token = await _call(service.register_device, body.get("name", ""))
        return {"device_id": device_id, "token": token}

    @app.post("/api/rides")
    async def start(request: Request):
        body, token = await _body(request), _token(request)
        meta = {k: body.get(k) for k in ("age_band", "gender", "skill")}
        ride_id = await _call(service.start_ride, token, body.get("vehicle"), body.get("rider_id"), **meta)
        return {"ride_id": ride_id}

    @app.post("/api/rides/{ride_id}/samples")
    async def samples(ride_id: str, request: Request):
        body, token = await _body(request), _token(request)
        return await _call(service.ingest_async, token, ride_id, body.get("samples"))

    @app.post("/api/rides/{ride_id}/destination")
    async def destination(ride_id: str, request: Request):
        body, token = await _body(request), _token(request)
        await _call(service.set_destination, token, ride_id, body.get("lat"), body.get("lon"))
        return {"ride_id": ride_id}

    @app.post("/api/rides/{ride_id}/end")
    async def end(ride_id: str, request: Request):
        await _call(service.end_ride, _token(request), ride_id)
        return {"ride_id": ride_id}

    @app.get("/api/rides")
    async def rides():
        listed = await _call(service.store.rides)
        live = set(service.open_rides())
        return [{**vars(r), "live": r.ride_id in live} for r in reversed(listed)]

    @app.get("/api/rides/{ride_id}")
    async def ride(ride_id: str):
        def read():
            return {"ride": vars(service.store.ride(ride_id)), "samples": service.store.samples(ride_id),
                    "features": service.store.features(ride_id), "labels": service.store.labels(ride_id),
                    "events": [vars(e) for e in service.store.events(ride_id)], "model": service.model_name}
        return JSONResponse(_clean(await _call(read)))

    @app.post("/push")
    async def push(request: Request):
        body, token = await _body(request), _token(request)
        platform = request.query_params.get("platform", "android")
        try:
            session, readings = parse_push(body, platform)
        except InputError as exc:
            raise HTTPException(400, str(exc)) from None
        key = (token, session)
        if key not in sessions:
            ride_id = await _call(service.start_ride, token, "sensor-logger", body.get("deviceId") or "unknown")
            sessions[key] = (ride_id, PushResampler(service.model.rate))
        ride_id, resampler = sessions[key]
        columns = resampler.add(readings)
        if not columns["time"]:
            return {"ride_id": ride_id, "count": 0}
        ack = await _call(service.ingest_async, token, ride_id, columns)
        return {"ride_id": ride_id, **ack}

    @app.websocket("/ws/ride")
    async def stream(websocket: WebSocket):
        await websocket.accept()
        token = ride_id = None
        try:
            while True:
                raw = await websocket.receive_text()
                reply = await _ws_message(service, raw, token, ride_id)
                if reply.get("type") in ("started", "resumed"):
                    token, ride_id = reply.pop("_token"), reply["ride_id"]
                await websocket.send_text(orjson.dumps(reply, option=orjson.OPT_SERIALIZE_NUMPY).decode())
        except WebSocketDisconnect:
            return

    @app.websocket("/ws/watch")
    async def watch(websocket: WebSocket):
        await websocket.accept()
        queue = service.watch(websocket.query_params.get("ride"))
        try:
            await websocket.send_json({"type": "hello", "open": service.open_rides()})
            while True:
                await websocket.send_json(await queue.get())
        except (WebSocketDisconnect, RuntimeError):
            return
        finally:
            service.unwatch(queue)

    return app


async def _ws_message(service: RideService, raw: str, token: str | None, ride_id: str | None) -> dict:
    """The reply to one message of a device's WebSocket (see the module docstring)."""
    seq = None
    try:
        if len(raw) > MAX_BODY:
            raise InputError(f"message of {len(raw)} bytes; send at most {MAX_BODY}")
        try:
            message = _json(raw)
        except InputError as exc:
            raise InputError(f"message {exc}") from None
        if not isinstance(message, dict):
            raise InputError("a message must be a JSON object with a 'type'")
        kind, seq = message.get("type"), message.get("seq")
        if kind == "start":
            meta = {k: message.get(k) for k in ("age_band", "gender", "skill")}
            new = await run_in_threadpool(service.start_ride, message.get("token"), message.get("vehicle"),
                                          message.get("rider_id"), **meta)
            return {"type": "started", "ride_id": new, "_token": message.get("token")}
        if kind == "resume":
            wanted = message.get("ride_id")
            last = await run_in_threadpool(service.resume, message.get("token"), wanted)
            return {"type": "resumed", "ride_id": wanted, "_token": message.get("token"), "last_time": last}
        if ride_id is None:
            raise AccessError("no ride on this connection; send a 'start' or 'resume' message first")
        if kind == "batch":
            ack = await service.ingest_async(token, ride_id, message.get("samples"))
            return {"type": "ack", "seq": seq, **ack}
        if kind == "destination":
            await run_in_threadpool(service.set_destination, token, ride_id, message.get("lat"), message.get("lon"))
            return {"type": "destination", "ride_id": ride_id}
        if kind == "end":
            await run_in_threadpool(service.end_ride, token, ride_id)
            return {"type": "ended", "ride_id": ride_id}
        raise InputError(f"unknown message type {kind!r}; send start, resume, batch, destination or end")
    except (SpotfreeError, ValueError) as exc:
        reply = {"type": "error", "status": _status(exc), "message": str(exc), "seq": seq}
        return {**reply, "retry_after": exc.retry_after} if isinstance(exc, RateError) else reply
