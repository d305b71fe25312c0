"""Load on ``spotfree serve``: N simulated phones streaming at 20 Hz over loopback WebSockets to a real server.

The server is ``spotfree serve`` (uvicorn) in a subprocess, its store a fresh SQLite file (synchronous FULL, the
default) per N. Each phone is a WebSocket client in this process: it starts a ride, then every ``--batch`` s sends
the samples of that span of a simulated sudden-braking ride (each phone from its own offset, so stops fall at
different moments) and waits for nothing (a phone keeps measuring). Phones start spread over one batch period.

Measured per N over ``--seconds`` s of streaming:

* batch-to-ack latency: from sending a batch to receiving its acknowledgement, which the server sends after the
  batch is classified, assisted and committed. A sample also waits on the phone until its batch is sent: up to
  ``batch - 1/rate`` s for the first sample of a batch, 0 for the last; that wait is the page's choice, not load;
* batch-to-warning latency: the same for the batches whose acknowledgement carries a warning;
* nothing lost: after the phones stop and every acknowledgement is in, the server is stopped and the samples
  rows in its SQLite file are counted against the acknowledged samples.

The model is a dictionary of every third window of one simulated ride named by the simulator's truth
(``tests/classify_fixtures.truth_model``): it warns on the simulated stops, which the trained default model does
not, and costs the same per sample (the CRC_RLS operator is ``(C d, d)`` whatever the number of columns).
The largest N with p99 batch-to-ack under 100 ms (and nothing lost) is printed; the run stops at the first N whose
p99 exceeds ten times that or that loses a sample. The 1-minute load average before each N is printed: on a shared
machine other jobs move the tail.

    python benchmarks/serve_load.py [--phones 10,25,50,100,200,500] [--seconds 15] [--batch 0.25]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import os
import platform
import signal
import socket
import sqlite3
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import httpx
import numpy as np
from websockets.asyncio.client import connect

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from classify_fixtures import rides, truth_model  # noqa: E402
from spotfree.ride.records import SAMPLE_COLUMNS  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402

LIMIT_MS = 100.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_server(folder: Path, model: Path, sync: str) -> tuple[subprocess.Popen, str]:
    port = _free_port()
    server = subprocess.Popen([sys.executable, "-m", "spotfree.cli", "serve", "--port", str(port), "--database",
                               str(folder / "rides.db"), "--model", str(model), "--sync", sync],
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise RuntimeError(f"spotfree serve exited: {server.stderr.read()}")
        try:
            httpx.get(url + "/api/model", timeout=2).raise_for_status()
            return server, url
        except httpx.TransportError:
            time.sleep(0.2)
    server.kill()
    raise RuntimeError("spotfree serve did not answer within 60 s")


class Phone:
    """One simulated phone: its ride's rows (time from 0), what it sent and what came back."""

    def __init__(self, token: str, rows: np.ndarray):
        self.token, self.rows = token, rows
        self.sent: dict[int, float] = {}
        self.acked = 0
        self.ack_ms: list[float] = []
        self.warn_ms: list[float] = []
        self.refused: list[str] = []

    async def ride(self, url: str, start: float, seconds: float, batch: float, rate: float) -> None:
        per_batch = round(batch * rate)
        async with connect(url.replace("http", "ws") + "/ws/ride", max_size=2**22) as ws:
            await ws.send(json.dumps({"type": "start", "token": self.token, "vehicle": "segway", "rider_id": "load"}))
            json.loads(await ws.recv())
            receiver = asyncio.create_task(self._receive(ws))
            loop = asyncio.get_running_loop()
            n_batches = int(seconds / batch)
            for k in range(n_batches):
                await asyncio.sleep(max(0.0, start + (k + 1) * batch - loop.time()))
                rows = self.rows[k * per_batch:(k + 1) * per_batch]
                samples = {name: [None if math.isnan(v) else float(v) for v in rows[:, j]]
                           for j, name in enumerate(SAMPLE_COLUMNS)}
                self.sent[k] = time.perf_counter()
                await ws.send(json.dumps({"type": "batch", "seq": k, "samples": samples}))
            deadline = time.perf_counter() + 30
            while len(self.ack_ms) + len(self.refused) < n_batches and time.perf_counter() < deadline:
                await asyncio.sleep(0.05)
            receiver.cancel()

    async def _receive(self, ws) -> None:
        async for raw in ws:
            now = time.perf_counter()
            reply = json.loads(raw)
            if reply.get("type") == "ack":
                ms = 1000.0 * (now - self.sent[reply["seq"]])
                self.ack_ms.append(ms)
                self.acked += reply["count"]
                if reply["warnings"]:
                    self.warn_ms.append(ms)
            elif reply.get("type") == "error":
                self.refused.append(reply["message"])


async def _warm_up(client: httpx.AsyncClient, rows: np.ndarray) -> None:
    """One ride of 100 samples first, so that compiling and first-call costs are not counted."""
    token = (await client.post("/api/devices", json={"name": "warm-up"})).json()["token"]
    headers = {"Authorization": f"Bearer {token}"}
    ride = (await client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers)).json()
    for k in range(0, 100, 5):
        samples = {name: [None if math.isnan(v) else float(v) for v in rows[k:k + 5, j]]
                   for j, name in enumerate(SAMPLE_COLUMNS)}
        (await client.post(f"/api/rides/{ride['ride_id']}/samples", json={"samples": samples},
                           headers=headers)).raise_for_status()
    await client.post(f"/api/rides/{ride['ride_id']}/end", headers=headers)


async def _load(url: str, phones: int, seconds: float, batch: float, rows: np.ndarray, rate: float) -> list[Phone]:
    async with httpx.AsyncClient(base_url=url) as client:
        await _warm_up(client, rows)
        tokens = [(await client.post("/api/devices", json={"name": f"load-{k}"})).json()["token"]
                  for k in range(phones)]
    rng = np.random.default_rng(0)
    span = int((seconds + 1) * rate)
    crowd = []
    for token in tokens:
        offset = int(rng.integers(0, len(rows) - span))
        part = rows[offset:offset + span].copy()
        part[:, 0] -= part[0, 0]
        crowd.append(Phone(token, part))
    start = asyncio.get_running_loop().time() + 1.0
    await asyncio.gather(*(p.ride(url, start + batch * k / phones, seconds, batch, rate)
                           for k, p in enumerate(crowd)))
    return crowd


def run(phones: int, seconds: float, batch: float, rows: np.ndarray, rate: float, model: Path,
        sync: str = "full") -> dict:
    with tempfile.TemporaryDirectory() as folder:
        server, url = _start_server(Path(folder), model, sync)
        try:
            crowd = asyncio.run(_load(url, phones, seconds, batch, rows, rate))
        finally:
            server.send_signal(signal.SIGINT)
            server.wait(30)
        with sqlite3.connect(Path(folder) / "rides.db") as db:
            stored = db.execute("SELECT COUNT(*) FROM samples").fetchone()[0] - 100  # less the warm-up ride
    ack = np.concatenate([p.ack_ms for p in crowd])
    warn = np.concatenate([p.warn_ms for p in crowd]) if any(p.warn_ms for p in crowd) else np.array([])
    sent = sum(len(p.sent) for p in crowd)
    return {"phones": phones, "batches": sent, "acked": len(ack), "refused": sum(len(p.refused) for p in crowd),
            "p50": float(np.percentile(ack, 50)), "p99": float(np.percentile(ack, 99)), "max": float(ack.max()),
            "warnings": len(warn), "warn_p50": float(np.percentile(warn, 50)) if len(warn) else math.nan,
            "warn_p99": float(np.percentile(warn, 99)) if len(warn) else math.nan,
            "acked_samples": sum(p.acked for p in crowd), "stored": stored}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phones", default="10,25,50,100,200,500")
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--batch", type=float, default=0.25, help="s of samples per batch (the page sends 0.25)")
    parser.add_argument("--sync", default="full", choices=("full", "normal"), help="spotfree serve --sync")
    args = parser.parse_args()
    raw = rides(seed=1, repeats=2)
    rows = recording_rows(raw.select_experiment(2))
    rate = raw.rate
    print(f"# serve_load: {platform.node()} {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC")
    print(f"# {args.seconds:g} s per N, {rate:g} Hz, batches of {args.batch:g} s, SQLite synchronous={args.sync.upper()}, "
          "latency in ms from sending a batch to its acknowledgement")
    print("| phones | load avg | batches sent | acked | refused | p50 | p99 | max | warnings | warn p50 | warn p99 "
          "| samples acked | rows stored |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    best = 0
    with tempfile.TemporaryDirectory() as folder:
        model = Path(folder) / "model.npz"
        truth_model(raw.select_experiment(1)).save(model)
        for phones in (int(n) for n in args.phones.split(",")):
            load = os.getloadavg()[0]
            r = run(phones, args.seconds, args.batch, rows, rate, model, args.sync)
            print(f"| {r['phones']} | {load:.1f} | {r['batches']} | {r['acked']} | {r['refused']} | {r['p50']:.1f} | "
                  f"{r['p99']:.1f} | {r['max']:.0f} | {r['warnings']} | {r['warn_p50']:.1f} | {r['warn_p99']:.1f} | "
                  f"{r['acked_samples']} | {r['stored']} |", flush=True)
            whole = r["acked"] == r["batches"] and r["stored"] == r["acked_samples"]
            if whole and r["p99"] < LIMIT_MS:
                best = phones
            if not whole or r["p99"] > 10 * LIMIT_MS:
                break
    print(f"# largest N with p99 < {LIMIT_MS:g} ms, every batch acknowledged and every acknowledged sample stored: "
          f"{best}")


if __name__ == "__main__":
    main()
