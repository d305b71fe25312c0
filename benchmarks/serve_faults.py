"""Faults under load: ``spotfree serve`` killed with SIGKILL (and, with ``--workers``, one of its ride workers)
while simulated phones stream, restarted, and every phone resuming its ride.

Each phone streams a simulated ride at 20 Hz over the WebSocket as the phone page does: batches of
``--batch`` s, one in flight, kept until acknowledged; after a lost connection it reconnects every 0.2 s and sends
``resume``, then drops what the server says it holds (``last_time``) and goes on. The fault loop waits
``--every`` s, kills the server (or a worker), restarts the server (a worker is replaced by the server itself), and
times how long until ``/api/health`` answers ``ok`` and until every phone has resumed.

Checked at the end, from the store: every acknowledged sample is stored (acked = stored, no acknowledged time
missing), and every ride went on as the same ride (a ``resume`` refused would start a new one: counted).

    python benchmarks/serve_faults.py --phones 200 --server-kills 20 --worker-kills 5 --workers 2

writes the command, machine, date and tables to ``benchmarks/results/serve_faults.md`` (``--out``).
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
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import httpx
import numpy as np
from websockets.asyncio.client import connect
from websockets.exceptions import WebSocketException

from spotfree.ride.default_model import default_model
from spotfree.ride.records import SAMPLE_COLUMNS
from spotfree.ride.sources import recording_rows
from spotfree.ride.store import RideStore
from spotfree.sim.scenarios import simulate_scenario

RATE = 20.0


class Phone:
    """One phone: its ride's rows (looped with growing times), the queue of rows not yet acknowledged, what was
    acknowledged, and how its resumes went."""

    def __init__(self, token: str, rows: np.ndarray, batch: int):
        self.token, self.rows, self.batch = token, rows, batch
        self.next_row = 0
        self.queue: list[np.ndarray] = []
        self.ride_id: str | None = None
        self.acked_times: list[float] = []
        self.resumes = self.new_rides = self.refused = 0
        self.lost_on_resume = 0
        self.last_ack = 0.0
        self.online = asyncio.Event()

    def record(self, n: int) -> None:
        """``n`` more samples recorded by the phone (time goes on past the end of its simulated ride)."""
        for _ in range(n):
            k = self.next_row
            row = self.rows[k % len(self.rows)].copy()
            row[0] = k / RATE
            self.queue.append(row)
            self.next_row += 1

    def message(self, seq: int) -> str:
        rows = np.array(self.queue[:self.batch])
        return json.dumps({"type": "batch", "seq": seq, "samples": {
            name: [None if math.isnan(v) else float(v) for v in rows[:, j]] for j, name in enumerate(SAMPLE_COLUMNS)}})

    async def run(self, url: str, stop: asyncio.Event) -> None:
        seq = 0
        while not stop.is_set():
            try:
                async with connect(url + "/ws/ride", open_timeout=5) as ws:
                    first = {"type": "resume", "token": self.token, "ride_id": self.ride_id} if self.ride_id \
                        else {"type": "start", "token": self.token, "vehicle": "segway", "rider_id": "faults"}
                    await ws.send(json.dumps(first))
                    reply = json.loads(await ws.recv())
                    if reply["type"] == "error":  # the ride cannot go on: a new one, as the page does
                        self.new_rides += 1
                        self.ride_id = None
                        continue
                    if reply["type"] == "resumed":
                        self.resumes += 1
                        held = reply["last_time"]
                        if self.acked_times and (held is None or held < self.acked_times[-1] - 1e-9):
                            self.lost_on_resume += 1
                        self.queue = [r for r in self.queue if held is None or r[0] > held + 1e-9]
                    self.ride_id = reply["ride_id"]
                    self.online.set()
                    while not stop.is_set():
                        if len(self.queue) < self.batch:
                            await asyncio.sleep(0.02)
                            continue
                        seq += 1
                        n = min(self.batch, len(self.queue))
                        await ws.send(self.message(seq))
                        answer = json.loads(await ws.recv())
                        if answer["type"] == "ack":
                            self.last_ack = time.perf_counter()
                            self.acked_times += [float(r[0]) for r in self.queue[:answer["count"]]]
                            del self.queue[:n]
                        else:
                            self.refused += 1
                            if answer.get("status") in (429, 503):
                                await asyncio.sleep(answer.get("retry_after", 1.0))
                            else:
                                del self.queue[:n]
            except (OSError, WebSocketException, asyncio.TimeoutError):
                self.online.clear()
                await asyncio.sleep(0.2)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(folder: Path, port: int, workers: int) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "spotfree.cli", "serve", "--port", str(port), "--database",
                             str(folder / "rides.db"), "--model", str(folder / "model.npz"), "--workers",
                             str(workers)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


async def _healthy(url: str, deadline: float = 120.0) -> float:
    """Seconds until ``/api/health`` answers ``ok``."""
    start = time.perf_counter()
    async with httpx.AsyncClient() as client:
        while time.perf_counter() - start < deadline:
            try:
                if (await client.get(url + "/api/health", timeout=2)).status_code == 200:
                    return time.perf_counter() - start
            except httpx.TransportError:
                pass
            await asyncio.sleep(0.1)
    raise RuntimeError("spotfree serve did not become healthy within 120 s")


def _workers_of(pid: int) -> list[int]:
    """The ride worker processes of the server ``pid`` (multiprocessing's spawned children, not its tracker)."""
    children = [int(c) for task in Path(f"/proc/{pid}/task").iterdir()
                for c in (task / "children").read_text().split()]
    return [c for c in children if b"spawn_main" in Path(f"/proc/{c}/cmdline").read_bytes()]


async def _recorder(phones: list[Phone], stop: asyncio.Event) -> None:
    """Every phone records a sample every 1 / RATE s, connected or not (as the page does)."""
    loop = asyncio.get_running_loop()
    start, k = loop.time(), 0
    while not stop.is_set():
        k += 1
        await asyncio.sleep(max(0.0, start + k / RATE - loop.time()))
        for p in phones:
            p.record(1)


async def _all_acked_since(phones: list[Phone], since: float) -> float:
    """Seconds from ``since`` until every phone has had an acknowledgement after it."""
    while not all(p.last_ack > since for p in phones):
        await asyncio.sleep(0.05)
    return time.perf_counter() - since


async def _all_online(phones: list[Phone], since: float) -> float:
    while not all(p.online.is_set() for p in phones):
        await asyncio.sleep(0.05)
    return time.perf_counter() - since


async def _faults(args, folder: Path, phones: list[Phone]) -> dict[str, list[dict]]:
    port = _free_port()
    url = f"http://127.0.0.1:{port}"
    server = _start(folder, port, args.workers)
    await _healthy(url)
    stop = asyncio.Event()
    tasks = [asyncio.create_task(p.run(url.replace("http", "ws"), stop)) for p in phones]
    tasks.append(asyncio.create_task(_recorder(phones, stop)))
    runs: dict[str, list[dict]] = {"server": [], "worker": []}
    plan = ["server"] * args.server_kills + ["worker"] * (args.worker_kills if args.workers else 0)
    try:
        await asyncio.wait_for(_all_online(phones, time.perf_counter()), 120)
        for kind in plan:
            await asyncio.sleep(args.every)
            acked_before = sum(len(p.acked_times) for p in phones)
            killed = time.perf_counter()
            if kind == "server":
                server.send_signal(signal.SIGKILL)
                server.wait(30)
                server = _start(folder, port, args.workers)
            else:
                os.kill(_workers_of(server.pid)[0], signal.SIGKILL)
            await asyncio.sleep(0.2)
            await _healthy(url)
            healthy = time.perf_counter() - killed
            resumed = await asyncio.wait_for(_all_acked_since(phones, killed), 120)
            runs[kind].append({"healthy": healthy, "resumed": resumed,
                               "acked": sum(len(p.acked_times) for p in phones) - acked_before})
            print(f"{kind} killed: health ok after {healthy:.2f} s, every phone acknowledged again after "
                  f"{resumed:.2f} s", flush=True)
        await asyncio.sleep(args.every)
    finally:
        stop.set()
        await asyncio.gather(*tasks, return_exceptions=True)
        server.send_signal(signal.SIGTERM)
        server.wait(60)
    return runs


def _check(folder: Path, phones: list[Phone]) -> dict:
    """Acknowledged samples against the store: how many acked, stored, and acked but missing."""
    acked = stored = missing = 0
    with RideStore(folder / "rides.db") as store:
        for p in phones:
            times = set(np.round(store.samples(p.ride_id)["time"], 6)) if p.ride_id else set()
            stored += len(times)
            acked += len(p.acked_times)
            missing += sum(1 for t in p.acked_times if round(t, 6) not in times)
    return {"acked": acked, "stored": stored, "missing": missing}


def _table(rows: list[dict]) -> str:
    if not rows:
        return "(none)\n"
    healthy, resumed = [r["healthy"] for r in rows], [r["resumed"] for r in rows]
    return ("| runs | health ok after (s) median / max | every phone acknowledged again after (s) median / max |\n"
            "|---:|---|---|\n"
            f"| {len(rows)} | {statistics.median(healthy):.2f} / {max(healthy):.2f} | "
            f"{statistics.median(resumed):.2f} / {max(resumed):.2f} |\n")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--phones", type=int, default=200)
    parser.add_argument("--server-kills", type=int, default=20)
    parser.add_argument("--worker-kills", type=int, default=5)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--every", type=float, default=5.0, help="seconds of streaming before each fault")
    parser.add_argument("--batch", type=float, default=0.25, help="seconds of samples per batch")
    parser.add_argument("--out", type=Path, default=Path(__file__).with_name("results") / "serve_faults.md")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        default_model().save(folder / "model.npz")
        rows = recording_rows(simulate_scenario("sudden-braking", repeats=1, seed=0))
        with RideStore(folder / "rides.db") as store:
            tokens = [store.register_device(f"phone-{k}")[1] for k in range(args.phones)]
        phones = [Phone(t, rows, max(1, round(args.batch * RATE))) for t in tokens]
        started = time.perf_counter()
        runs = asyncio.run(_faults(args, folder, phones))
        wall = time.perf_counter() - started
        check = _check(folder, phones)
    resumes = sum(p.resumes for p in phones)
    new_rides = sum(p.new_rides for p in phones)
    lost = sum(p.lost_on_resume for p in phones)
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.machine())
    report = (
        "# serve_faults\n\n"
        f"Command: `python benchmarks/serve_faults.py {' '.join(sys.argv[1:])}`\n\n"
        f"Date: {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC; machine: {cpu}, {os.cpu_count()} cores (shared "
        f"with other jobs), load average {os.getloadavg()[0]:.1f}; Python {platform.python_version()}; "
        f"{wall:.0f} s in all.\n\n"
        f"{args.phones} phones at {RATE:g} Hz over WebSockets, batches of {args.batch:g} s; `spotfree serve "
        f"--workers {args.workers}`, SQLite (synchronous FULL); a fault every {args.every:g} s.\n\n"
        "## Server killed (SIGKILL), then restarted\n\n" + _table(runs["server"]) +
        "\n## One ride worker killed (SIGKILL), replaced by the server\n\n" + _table(runs["worker"]) +
        "\n## Acknowledged samples and rides\n\n"
        "| acked | stored | acked but not stored | resumes | resume behind an ack | rides restarted as new |\n"
        "|---:|---:|---:|---:|---:|---:|\n"
        f"| {check['acked']} | {check['stored']} | {check['missing']} | {resumes} | {lost} | {new_rides} |\n")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    print(report)


if __name__ == "__main__":
    main()
