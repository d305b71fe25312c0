"""The floor under ``spotfree serve``'s load: the same web stack answering the same messages and doing nothing else.

A FastAPI app on uvicorn (the options of :func:`spotfree.ride.server.run_server`: no per-message deflate) with the
endpoints ``benchmarks/serve_load.py`` calls. A batch on ``/ws/ride`` is parsed (orjson, as the service does) and
answered at once with an acknowledgement of the service's shape (one label per sample, the assistant's figures):
no checks, features, classification, assistant or store. ``python benchmarks/serve_load.py --floor`` runs the
phones against it, so that the server CPU per batch of this stack alone is measured beside the service's.

    python benchmarks/serve_floor.py --port 8765
"""

from __future__ import annotations

import argparse
import itertools

import orjson
import uvicorn
from fastapi import FastAPI, WebSocket, WebSocketDisconnect

STATE = {"speed": 4.2, "distance": 120.5, "lat": 35.1, "lon": 139.2, "eta": None, "label": "cruising",
         "warning": None}
"""Figures of the size the service's acknowledgement carries."""


def floor_app() -> FastAPI:
    app = FastAPI()
    numbers = itertools.count()

    @app.get("/api/model")
    async def model() -> dict:
        return {"classes": ["cruising"]}

    @app.post("/api/enrolments")
    async def enrolment() -> dict:
        return {"code": f"c{next(numbers)}"}

    @app.post("/api/devices")
    async def device() -> dict:
        return {"device_id": f"d{next(numbers)}", "token": f"t{next(numbers)}"}

    @app.post("/api/rides")
    async def ride() -> dict:
        return {"ride_id": f"r{next(numbers)}"}

    @app.post("/api/rides/{ride_id}/samples")
    async def samples(ride_id: str) -> dict:
        return {"count": 0}

    @app.post("/api/rides/{ride_id}/end")
    async def end(ride_id: str) -> dict:
        return {"ride_id": ride_id}

    @app.websocket("/ws/ride")
    async def stream(websocket: WebSocket):
        await websocket.accept()
        try:
            while True:
                message = orjson.loads(await websocket.receive_text())
                if message.get("type") == "start":
                    reply = {"type": "started", "ride_id": f"r{next(numbers)}"}
                else:
                    n = len(message["samples"]["time"])
                    reply = {"type": "ack", "seq": message.get("seq"), "count": n, "labels": ["cruising"] * n,
                             "state": STATE, "warnings": [], "events": []}
                await websocket.send_text(orjson.dumps(reply).decode())
        except WebSocketDisconnect:
            return

    return app


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--port", type=int, required=True)
    args = parser.parse_args()
    uvicorn.run(floor_app(), host="127.0.0.1", port=args.port, log_level="warning", ws_per_message_deflate=False)


if __name__ == "__main__":
    main()
