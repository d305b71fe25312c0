"""The web API of :class:`~spotfree.ride.service.RideService` (FastAPI).

Credentials: every call but the pages, ``/static/*`` and ``GET /api/model`` needs ``Authorization: Bearer
<token>`` (never a token in the URL), checked before the body is read. The operator token (``spotfree serve``
writes it to a file on first start, :mod:`spotfree.ride.server`) reads every ride and issues enrolment codes; a
device token, got once with an enrolment code, writes and reads only the rides that device started.

Pages: ``/`` the phone page (streams DeviceMotion and Geolocation), ``/rider`` and ``/operator`` the views,
``/static/*`` their scripts; a page holds no data, it asks for it with a credential. Devices:

* ``POST /api/devices`` ``{"name", "code"}`` (an enrolment code, no credential) -> ``{"device_id", "token"}``
  (the token is shown once);
* ``POST /api/rides`` ``{"vehicle", "rider_id", "age_band"?, "gender"?, "skill"?, "continues_from"?}`` ->
  ``{"ride_id"}`` (``continues_from``: the id of this device's earlier ride that this one continues);
* ``POST /api/rides/{id}/samples`` ``{"samples": {column: [...]}}`` -> the acknowledgement;
* ``POST /api/rides/{id}/destination`` ``{"lat", "lon"}``; ``POST /api/rides/{id}/end``;
* ``WS /ws/ride``: ``{"type": "start", "token", "vehicle", "rider_id", ...}`` (the optional fields of
  ``POST /api/rides`` too) or ``{"type": "resume", "token",
  "ride_id"}``, then ``{"type": "batch", "seq", "samples"}`` (answered ``{"type": "ack", "seq", ...}``),
  ``{"type": "destination", "lat", "lon"}``, ``{"type": "end"}``; a refused message is answered
  ``{"type": "error", "status", "message"}`` (``seq`` too for a batch, ``retry_after`` s for a 429) and changes
  nothing; a binary frame is answered by closing the socket (code 1003, with the reason); a socket that has not
  started or resumed a ride within :data:`AUTH_SECONDS` is closed (1008), and one that sends a message over
  :data:`MAX_UNAUTHENTICATED_BODY` bytes before it has (1009);
* ``POST /push?platform=android|ios`` the Sensor Logger app's HTTP push (:mod:`spotfree.ride.sensorpush`): one
  ride per ``sessionId`` (freed when the ride ends or idles); parsed and resampled in a thread, in time linear in
  its size. The answer counts the samples stored (``count``) and the readings ``dropped`` (a slot only one motion
  sensor filled, within :data:`~spotfree.ride.sensorpush.STALE_SECONDS`); a refused message (4xx) changes nothing
  and may be sent again.

An address whose enrolment codes were refused :data:`ENROLMENT_GUESSES` times is answered 429 until its
guesses refill. Operator: ``POST /api/enrolments`` ``{"uses"?, "ttl"?}`` -> ``{"code", "expires", "uses"}``.
Views (the operator; a device for its own rides): ``GET /api/rides``, ``GET /api/rides/{id}`` (samples, features, labels, events, for
replay) and ``WS /ws/watch`` (``?ride=`` one ride; the credential in the ``Authorization`` header or in a first
message ``{"type": "auth", "token"}`` sent within :data:`AUTH_SECONDS`) stream what the service publishes.
``GET /api/model`` is the pipeline for the page (:func:`~spotfree.ride.live.pipeline_spec`); ``GET /api/health``
(no credential) the service's :meth:`~spotfree.ride.service.RideService.health`, 503 while degraded.

Restarts: a ride open in the store goes on after the server restarts (or its worker dies): ``resume`` and every
later call rebuild it from the stored samples (:mod:`spotfree.ride.service`). A ride that ended (or was closed
after :data:`~spotfree.ride.service.IDLE_SECONDS` without samples) is refused with 403; the phone page then starts
a new ride with the samples it still holds, ``continues_from`` the old one (the store keeps the link). A
destination set on a ride is kept in the store and outlives the restart too.

Every HTTP answer carries the headers of :data:`SECURITY_HEADERS` and a Content-Security-Policy that lets a page
load and connect only to this server and not be framed. A body with a credential must be ``application/json``
(a cross-site form cannot send that without the browser asking first).

Refusals (one line in ``detail``): 400 bad input, 401 no or unknown credential, 403 a ride of another device, a
view without the operator token or a bad enrolment code, 404 unknown ride, 413 a body over :data:`MAX_BODY` bytes
(:data:`MAX_UNAUTHENTICATED_BODY` for an enrolment; refused while it is read), 415 a body that is not JSON, 429
samples sent faster than the service takes them (``Retry-After``), a start beyond the device's open rides (see
:mod:`spotfree.ride.service`) or too many refused enrolment codes, 500 a ride whose stored blocks are damaged
(:class:`~spotfree.ride.store.DamagedRideError`: that ride only), 503 a ride worker being replaced
(``Retry-After``: send again).
"""

from __future__ import annotations

import asyncio
import contextlib
import inspect
import math
import re
import time as clock
from importlib.resources import files
from pathlib import Path

import orjson
from fastapi import FastAPI, HTTPException, Request, WebSocket, WebSocketDisconnect
from fastapi.responses import FileResponse, JSONResponse, Response
from fastapi.staticfiles import StaticFiles
from starlette.concurrency import run_in_threadpool
from starlette.websockets import WebSocketState

from spotfree.errors import InputError, SpotfreeError
from spotfree.ride import validation
from spotfree.ride.sensorpush import PushResampler, PushSessions, parse_push
from spotfree.ride.service import OPERATOR, Identity, RateError, RideService, SampleBucket, UnavailableError
from spotfree.ride.store import AccessError, DamagedRideError, ForbiddenError, NotFoundError, QuotaError
from spotfree.ride.tokens import token_hash

MAX_BODY = 2_000_000
"""Bytes in one request body or WebSocket message."""
MAX_UNAUTHENTICATED_BODY = 4096
"""Bytes in a body or WebSocket message read before its sender is known: an enrolment, a ride socket's ``start``
or ``resume``, a watcher's ``auth``."""
ENROLMENT_GUESSES = 10
"""Refused enrolment codes one client address may send at once; then one more per ``60 / ENROLMENT_GUESSES`` s
(429 with ``Retry-After`` meanwhile)."""
AUTH_SECONDS = 10.0
"""Seconds a socket has to give its credential once connected: a watcher its ``{"type": "auth", "token"}``, a ride
socket a ``start`` or ``resume`` that is taken (else it is closed, 1008)."""
STATIC = Path(str(files("spotfree.ride") / "static"))
SECURITY_HEADERS = (
    (b"x-content-type-options", b"nosniff"),
    (b"x-frame-options", b"DENY"),
    (b"referrer-policy", b"no-referrer"),
    (b"cross-origin-opener-policy", b"same-origin"),
    (b"cache-control", b"no-store"),
)
"""Headers on every HTTP answer (with the Content-Security-Policy of :func:`content_security_policy`)."""
_HOST = re.compile(r"^[A-Za-z0-9.\-]+(:[0-9]{1,5})?$|^\[[0-9A-Fa-f:.]+\](:[0-9]{1,5})?$")


def content_security_policy(host: str | None) -> bytes:
    """The page policy: scripts, styles, images and connections from this server only (its WebSocket at
    ``host`` named, for browsers whose ``'self'`` does not cover ``ws:``), no plugins, no framing. Inline styles
    are allowed (the views colour labels with them); inline scripts are not."""
    sockets = f" ws://{host} wss://{host}" if host and _HOST.match(host) else ""
    return ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
            f"connect-src 'self'{sockets}; object-src 'none'; base-uri 'none'; form-action 'self'; "
            "frame-ancestors 'none'").encode()


class SecurityHeaders:
    """ASGI middleware: :data:`SECURITY_HEADERS` and the Content-Security-Policy on every HTTP answer."""

    def __init__(self, app):
        self.app = app

    async def __call__(self, scope, receive, send):
        if scope["type"] != "http":
            return await self.app(scope, receive, send)
        host = dict(scope.get("headers", ())).get(b"host", b"").decode("latin-1")
        extra = [*SECURITY_HEADERS, (b"content-security-policy", content_security_policy(host))]

        async def send_with_headers(message):
            if message["type"] == "http.response.start":
                message = {**message, "headers": [*message.get("headers", ()), *extra]}
            await send(message)
        await self.app(scope, receive, send_with_headers)


def _status(exc: Exception) -> int:
    if isinstance(exc, DamagedRideError):
        return 500
    if isinstance(exc, NotFoundError):
        return 404
    if isinstance(exc, (RateError, QuotaError)):
        return 429
    if isinstance(exc, UnavailableError):
        return 503
    if isinstance(exc, ForbiddenError):
        return 403
    if isinstance(exc, AccessError):
        return 403 if "may not write" in str(exc) or "not open" in str(exc) else 401
    return 400


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


async def _call(function, *args, **kwargs):
    """Await a service coroutine, or run a blocking service call in the thread pool; refusals become HTTP errors
    (429 with Retry-After)."""
    try:
        if inspect.iscoroutinefunction(function):
            return await function(*args, **kwargs)
        return await run_in_threadpool(function, *args, **kwargs)
    except (SpotfreeError, ValueError) as exc:
        headers = {"Retry-After": str(math.ceil(exc.retry_after))} \
            if isinstance(exc, (RateError, UnavailableError)) else None
        if isinstance(exc, AccessError) and _status(exc) == 401:
            headers = {"WWW-Authenticate": "Bearer"}
        raise HTTPException(_status(exc), _one_line(exc), headers=headers) from None


def _bearer(headers) -> str | None:
    """The token of an ``Authorization: Bearer <token>`` header (None without one)."""
    header = headers.get("authorization", "")
    scheme, _, token = header.partition(" ")
    return token.strip() or None if scheme.lower() == "bearer" else None


async def _identify(service: RideService, request: Request, operator: bool = False) -> tuple[Identity, str]:
    """``(who, token)`` of the request's credential, checked before its body is read (401/403 otherwise)."""
    token = _bearer(request.headers)
    check = service.require_operator if operator else service.identify
    return await _call(check, token), token


async def _body(request: Request, limit: int = MAX_BODY) -> dict:
    """The JSON object of the body, read at most ``limit`` bytes far (413 as soon as it is over: the declared
    length, or the bytes read so far); 415 unless it is ``application/json``."""
    declared = request.headers.get("content-length")
    if declared is not None and (not declared.isdigit() or int(declared) > limit):
        raise HTTPException(413, f"body of {declared:.20} bytes; send at most {limit}")
    chunks, size = [], 0
    async for chunk in request.stream():
        size += len(chunk)
        if size > limit:
            raise HTTPException(413, f"body over {limit} bytes; send at most {limit}")
        chunks.append(chunk)
    raw = b"".join(chunks)
    if raw and request.headers.get("content-type", "").split(";")[0].strip().lower() != "application/json":
        raise HTTPException(415, "send the body as JSON with 'Content-Type: application/json'")
    body = await run_in_threadpool(_object, raw or b"{}") if size > _INLINE_JSON else _object(raw or b"{}")
    return body


_INLINE_JSON = 64_000
"""Bytes of a body parsed on the event loop; a longer one is parsed in a thread."""


def _object(raw: bytes) -> dict:
    try:
        body = _json(raw)
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


def _ride_id(value: object) -> str:
    """A ride id as sent (path or message): printable text of at most MAX_TEXT characters (InputError)."""
    return validation.text(value, "request", "ride_id")


def _body_schema(properties: dict, required: tuple[str, ...] = ()) -> dict:
    """The OpenAPI ``requestBody`` of a JSON object (what the handlers read; they check it themselves)."""
    schema = {"type": "object", "properties": properties}
    if required:
        schema["required"] = list(required)
    return {"requestBody": {"required": True, "content": {"application/json": {"schema": schema}}}}


_TEXT = {"type": "string", "maxLength": 100}
_RIDE_META = ("age_band", "gender", "skill", "continues_from")
"""Optional fields of a ride's start (HTTP and WebSocket): the rider's descriptors and the ride it continues."""
_NUMBERS = {"type": "array", "items": {"type": ["number", "null"]}, "maxItems": 50}
_BODIES = {
    "devices": _body_schema({"name": _TEXT, "code": _TEXT}, ("code",)),
    "enrolments": _body_schema({"uses": {"type": "integer"}, "ttl": {"type": "number"}}),
    "rides": _body_schema({"vehicle": _TEXT, "rider_id": _TEXT, "age_band": _TEXT, "gender": _TEXT, "skill": _TEXT,
                           "continues_from": _TEXT}, ("vehicle", "rider_id")),
    "samples": _body_schema({"samples": {"type": "object", "properties": {
        c: _NUMBERS for c in ("time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed")}}}, ("samples",)),
    "destination": _body_schema({"lat": {"type": "number"}, "lon": {"type": "number"}}, ("lat", "lon")),
    "push": _body_schema({"messageId": {"type": "integer"}, "sessionId": _TEXT, "deviceId": _TEXT,
                          "payload": {"type": "array", "maxItems": 40, "items": {"type": "object", "properties": {
                              "name": {"enum": ["totalacceleration", "accelerometer", "gravity", "gyroscope",
                                                "location", "other"]},
                              "time": {"type": "number"},
                              "values": {"type": "object", "properties": {
                                  k: {"type": "number"} for k in ("x", "y", "z", "latitude", "longitude",
                                                                  "speed")}}}}}},
                         ("sessionId", "payload")),
}
"""Request bodies as the OpenAPI schema shows them (``/openapi.json``), for clients and for schema-driven fuzzing
(tests/test_ride_fuzz.py)."""


def create_app(service: RideService) -> FastAPI:
    """The FastAPI application serving ``service`` (see the module docstring)."""
    app = FastAPI(title="spotfree ride assistant", docs_url=None, redoc_url=None)
    app.add_middleware(SecurityHeaders)
    app.mount("/static", StaticFiles(directory=STATIC), name="static")
    sessions = app.state.push_sessions = PushSessions(service)

    for route, page in (("/", "phone.html"), ("/rider", "rider.html"), ("/operator", "operator.html")):
        app.add_api_route(route, lambda page=page: FileResponse(STATIC / page), methods=["GET"],
                          include_in_schema=False)

    @app.get("/api/model")
    def model():
        return service.spec

    @app.get("/api/health")
    def health():
        report = service.health()
        return JSONResponse(report, status_code=200 if report["status"] == "ok" else 503)

    guesses: dict[str, SampleBucket] = {}

    @app.post("/api/devices", openapi_extra=_BODIES["devices"])
    async def register(request: Request):
        address = request.client.host if request.client else ""
        if len(guesses) > 10_000:  # addresses whose bucket is full again hold nothing worth keeping
            now = clock.monotonic()
            for stale in [a for a, b in guesses.items() if b.full(now)]:
                del guesses[stale]
        bucket = guesses.setdefault(address, SampleBucket(ENROLMENT_GUESSES, ENROLMENT_GUESSES / 60.0))
        try:
            bucket.take(1, "enrolment")
        except RateError as exc:
            raise HTTPException(429, f"enrolment: {ENROLMENT_GUESSES} refused codes from this address; send again in "
                                     f"{math.ceil(exc.retry_after)} s with the code the operator gave",
                                headers={"Retry-After": str(math.ceil(exc.retry_after))}) from None
        body = await _body(request, MAX_UNAUTHENTICATED_BODY)
        try:
            device_id, token = await _call(service.enrol_device, body.get("code"), body.get("name", ""))
        except HTTPException as exc:
            if exc.status_code != 403:  # only a refused code counts as a guess
                bucket.give(1)
            raise
        bucket.give(1)
        return {"device_id": device_id, "token": token}

    @app.post("/api/enrolments", openapi_extra=_BODIES["enrolments"])
    async def enrolment(request: Request):
        await _identify(service, request, operator=True)
        body = await _body(request)
        uses = body.get("uses", 1)
        code, expires = await _call(service.issue_enrolment, uses, body.get("ttl", 3600.0))
        return {"code": code, "expires": expires, "uses": uses}

    @app.post("/api/rides", openapi_extra=_BODIES["rides"])
    async def start(request: Request):
        _, token = await _identify(service, request)
        body = await _body(request)
        meta = {k: body.get(k) for k in _RIDE_META}
        ride_id = await _call(service.start_ride, token, body.get("vehicle"), body.get("rider_id"), **meta)
        return {"ride_id": ride_id}

    @app.post("/api/rides/{ride_id}/samples", openapi_extra=_BODIES["samples"])
    async def samples(ride_id: str, request: Request):
        _, token = await _identify(service, request)
        body = await _body(request)
        return await _call(service.ingest_async, token, ride_id, body.get("samples"))

    @app.post("/api/rides/{ride_id}/destination", openapi_extra=_BODIES["destination"])
    async def destination(ride_id: str, request: Request):
        _, token = await _identify(service, request)
        body = await _body(request)
        await _call(service.set_destination, token, ride_id, body.get("lat"), body.get("lon"))
        return {"ride_id": ride_id}

    @app.post("/api/rides/{ride_id}/end")
    async def end(ride_id: str, request: Request):
        _, token = await _identify(service, request)
        await _call(service.end_ride, token, ride_id)
        return {"ride_id": ride_id}

    @app.get("/api/rides")
    async def rides(request: Request):
        who, _ = await _identify(service, request)
        listed = await _call(service.store.rides, None if who.role == OPERATOR else who.device_id)
        live = set(service.open_rides())
        return [{**vars(r), "live": r.ride_id in live} for r in reversed(listed)]

    @app.get("/api/rides/{ride_id}")
    async def ride(ride_id: str, request: Request):
        who, _ = await _identify(service, request)

        def read() -> bytes:  # read and encoded in a thread: a long ride's JSON is tens of MB
            return orjson.dumps(_clean({
                "ride": vars(service.readable(who, ride_id)), "samples": service.store.samples(ride_id),
                "features": service.store.features(ride_id), "labels": service.store.labels(ride_id),
                "events": [vars(e) for e in service.store.events(ride_id)], "model": service.model_name}))
        return Response(await _call(read), media_type="application/json")

    @app.post("/push", openapi_extra=_BODIES["push"])
    async def push(request: Request, platform: str = "android"):
        _, token = await _identify(service, request)
        body = await _body(request)
        try:
            session, readings = await run_in_threadpool(parse_push, body, platform)
        except InputError as exc:
            raise HTTPException(400, _one_line(exc)) from None
        key = (token_hash(token), session)
        held = sessions.get(key)
        async with held.lock:  # one message of a session at a time, in order
            if held.ride_id is None:
                device = body.get("deviceId")
                device = device if isinstance(device, str) and device.isprintable() else "unknown"
                try:
                    ride_id = await _call(service.start_ride, token, "sensor-logger", device[:validation.MAX_TEXT])
                except HTTPException:
                    sessions.forget(key, held)
                    raise
                sessions.started(key, held, ride_id, PushResampler(service.model.rate))
            resampler, before = held.resampler, held.resampler.dropped
            # resampled in place, in a thread, and undone unless its samples are stored: a refused message
            # leaves the session as it was, and the app may send it again
            try:
                columns = await run_in_threadpool(resampler.add, readings)
            except InputError as exc:
                raise HTTPException(400, _one_line(exc)) from None
            ack = {"count": 0}
            try:
                if columns["time"]:
                    ack = await _call(service.ingest_async, token, held.ride_id, columns)
            except BaseException:
                resampler.rollback()
                raise
        return {"ride_id": held.ride_id, **ack, "dropped": resampler.dropped - before}

    @app.websocket("/ws/ride")
    async def stream(websocket: WebSocket):
        await websocket.accept()
        token = ride_id = None
        deadline = asyncio.get_running_loop().time() + AUTH_SECONDS
        try:
            while True:
                if ride_id is None:  # before a start or resume is taken: a deadline, small messages
                    try:
                        raw = await asyncio.wait_for(_receive_text(websocket),
                                                     deadline - asyncio.get_running_loop().time())
                    except asyncio.TimeoutError:
                        await _close(websocket, 1008, f"no ride started or resumed within {AUTH_SECONDS:g} s; "
                                                      "send a 'start' or 'resume' message first")
                        return
                    if raw is not None and len(raw) > MAX_UNAUTHENTICATED_BODY:
                        await _close(websocket, 1009, f"message of {len(raw)} bytes before a ride is started; "
                                                      f"send at most {MAX_UNAUTHENTICATED_BODY}")
                        return
                else:
                    raw = await _receive_text(websocket)
                if raw is None:
                    return
                reply = await _ws_message(service, raw, token, ride_id)
                if reply.get("type") in ("started", "resumed"):
                    token, ride_id = reply.pop("_token"), reply["ride_id"]
                await websocket.send_text(orjson.dumps(reply, option=orjson.OPT_SERIALIZE_NUMPY).decode())
        except WebSocketDisconnect:
            return

    @app.websocket("/ws/watch")
    async def watch(websocket: WebSocket):
        await websocket.accept()
        try:
            who = await _watcher(service, websocket)
        except WebSocketDisconnect:
            return
        if who is None:
            return
        queue = service.watch(websocket.query_params.get("ride"), who)

        async def forward() -> None:
            await websocket.send_json({"type": "hello", "role": who.role, "open": service.open_rides_for(who)})
            while True:
                await websocket.send_json(await queue.get())
        # the socket is read as well as written: a watcher that leaves (or a server shutting down) is noticed at
        # once, not at the next published message, which may never come
        sender = asyncio.create_task(forward())
        try:
            while (await websocket.receive())["type"] != "websocket.disconnect":
                pass
        except (WebSocketDisconnect, RuntimeError):
            pass
        finally:
            sender.cancel()
            with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError):
                await sender
            service.unwatch(queue)

    return app


async def _close(websocket: WebSocket, code: int, reason: str) -> None:
    """Close with ``code`` and a one-line ``reason`` (at most the 123 bytes a close frame holds)."""
    if websocket.application_state != WebSocketState.DISCONNECTED:
        await websocket.close(code, reason.encode()[:123].decode(errors="ignore"))


async def _receive_text(websocket: WebSocket) -> str | None:
    """The next text message; a binary frame closes the socket (1003, with the reason) and gives None."""
    message = await websocket.receive()
    if message["type"] == "websocket.disconnect":
        raise WebSocketDisconnect(message.get("code", 1000))
    if message.get("text") is None:
        await _close(websocket, 1003, "binary frames are not accepted; send JSON text")
        return None
    return message["text"]


async def _watcher(service: RideService, websocket: WebSocket) -> Identity | None:
    """Who watches: the ``Authorization`` header, or a first ``{"type": "auth", "token"}`` message within
    :data:`AUTH_SECONDS`; None once the socket was closed (1008 with the reason) for a missing or bad one."""
    token = _bearer(websocket.headers)
    if token is None:
        try:
            raw = await asyncio.wait_for(_receive_text(websocket), AUTH_SECONDS)
        except asyncio.TimeoutError:
            await _close(websocket, 1008, f"no credential within {AUTH_SECONDS:g} s; send "
                                          "{\"type\": \"auth\", \"token\": ...} first")
            return None
        if raw is None:
            return None
        try:
            message = _json(raw) if len(raw) <= MAX_UNAUTHENTICATED_BODY else None
        except InputError:
            message = None
        token = message.get("token") if isinstance(message, dict) and message.get("type") == "auth" else None
    try:
        return await run_in_threadpool(service.identify, token)
    except AccessError as exc:
        await _close(websocket, 1008, _one_line(exc))
        return None


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
        if not (seq is None or (isinstance(seq, int) and not isinstance(seq, bool) and abs(seq) < 2 ** 53)):
            seq = None
            raise InputError("field 'seq' must be a whole number (or left out)")
        if kind == "start":
            meta = {k: message.get(k) for k in _RIDE_META}
            new = await run_in_threadpool(service.start_ride, message.get("token"), message.get("vehicle"),
                                          message.get("rider_id"), **meta)
            return {"type": "started", "ride_id": new, "_token": message.get("token")}
        if kind == "resume":
            wanted = _ride_id(message.get("ride_id"))
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
        raise InputError(f"unknown message type {kind!r:.40}; send start, resume, batch, destination or end")
    except (SpotfreeError, ValueError) as exc:
        reply = {"type": "error", "status": _status(exc), "message": _one_line(exc), "seq": seq}
        return {**reply, "retry_after": exc.retry_after} if isinstance(exc, (RateError, UnavailableError)) \
            else reply
