"""Load on ``spotfree serve``: N simulated phones streaming at 20 Hz over loopback WebSockets to a real server.

The server is ``spotfree serve`` (uvicorn) in a subprocess, its store a fresh SQLite file (synchronous FULL, the
default) per N, its rides in the server's process or, with ``--workers K``, in K worker processes. The phones run
in ``--clients`` processes of their own (default 2), so that the load client is not one Python process doing all
the sending and receiving; each phone is a WebSocket client that starts a ride, then every ``--batch`` s sends the
samples of that span of a simulated sudden-braking ride (each phone from its own offset, so stops fall at
different moments; the messages are encoded before the run) and waits for nothing (a phone keeps measuring).
Phones start spread over one batch period, once every client process has connected all of its phones.

Measured per N over ``--seconds`` s of streaming:

* batch-to-ack latency: from sending a batch to receiving its acknowledgement, which the server sends after the
  batch is classified, assisted and committed. A sample also waits on the phone until its batch is sent: up to
  ``batch - 1/rate`` s for the first sample of a batch, 0 for the last; that wait is the page's choice, not load;
* sample-to-warning latency: from the moment the sample that raises a warning is taken to the acknowledgement
  that carries the warning. As the page does, a phone sends its batch at once when that sample is taken (it runs
  the same pipeline and gets the same labels), so the sample does not wait for the rest of its batch: each phone's
  warning samples are found beforehand with the server's own ride pipeline and assistant
  (:func:`_warning_samples`), and its batches are cut after them;
* nothing lost: after the phones stop and every acknowledgement is in, the server is stopped and the samples
  in its SQLite file are counted against the acknowledged samples;
* CPU: user + system seconds of the server's process tree and of the client processes over the streaming, per
  second (cores) and per acknowledged batch (ms). Server, clients and other jobs share the machine's cores; the
  1-minute load average after each N is printed, since other jobs move the tail.

The model is a dictionary of every third window of one simulated ride named by the simulator's truth
(``tests/classify_fixtures.truth_model``): it warns on the simulated stops, which the trained default model does
not, and costs the same per sample (the CRC_RLS operator is ``(C d, d)`` whatever the number of columns).
The largest N with p99 batch-to-ack under 100 ms (and nothing lost) is printed; the run stops at the first N whose
p99 exceeds ten times that or that loses a sample.

Two kinds of interference, each its own run (the issue's goal names both):

* ``--hostile``: a separate process sends, once a second while the phones stream, a ``POST /push`` of
  ``HOSTILE_BYTES`` (4 MB, a Sensor Logger message) with a made-up token, over a new connection each time, writing
  the whole body as fast as the server takes it; the status of each answer and the time to it are reported;
* ``--busy-core``: a separate process spins on one core (a pure Python loop) from before the phones connect until
  they stop, as another job on the machine would.

``--floor`` runs the same phones against ``benchmarks/serve_floor.py``: the same web stack answering every batch
at once and storing nothing, the part of the server's CPU that no work on the batch can remove ("rows stored" is
then the acknowledged samples).

    python benchmarks/serve_load.py [--phones 10,25,50,100,200,500] [--seconds 15] [--batch 1] [--clients 2]
                                    [--workers 0] [--sync full] [--floor] [--hostile] [--busy-core]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import math
import multiprocessing
import os
import platform
import signal
import socket
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import httpx
import numpy as np
import orjson
from websockets.asyncio.client import connect

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from classify_fixtures import rides, truth_model  # noqa: E402
from machine import results_file  # noqa: E402
from spotfree.classify.batch import dictionary_classifier  # noqa: E402
from spotfree.model import DictionaryModel  # noqa: E402
from spotfree.ride.live import LiveRide  # noqa: E402
from spotfree.ride.records import SAMPLE_COLUMNS  # noqa: E402
from spotfree.ride.service import assistant_factory  # noqa: E402
from spotfree.ride.sources import recording_rows  # noqa: E402
from spotfree.ride.store import RideStore  # noqa: E402

LIMIT_MS = 100.0
HOSTILE_BYTES = 4_000_000
"""Bytes of the hostile client's ``/push`` body."""
HOSTILE_PERIOD = 1.0
"""Seconds between the hostile client's posts."""


def _hostile_body() -> bytes:
    """A Sensor Logger push of about HOSTILE_BYTES: accelerometer and gravity readings."""
    reading = (b'{"name": "accelerometer", "time": 1700000000000000000, '
               b'"values": {"x": 0.123456789, "y": 9.812345678, "z": 0.012345678}}, ')
    count = HOSTILE_BYTES // len(reading)
    return b'{"messageId": 1, "sessionId": "hostile", "deviceId": "x", "payload": [' + reading * (count - 1) \
        + reading[:-2] + b"]}"


def _hostile(url: str, stop, answers) -> None:
    """The hostile client (a process of its own): every HOSTILE_PERIOD s, a new connection posts the 4 MB body
    to ``/push`` with a made-up token; ``(status line, ms to it)`` of each answer onto ``answers`` at the end."""
    host, port = url.removeprefix("http://").split(":")
    body = _hostile_body()
    head = (f"POST /push HTTP/1.1\r\nHost: {host}\r\nAuthorization: Bearer made-up-token\r\n"
            f"Content-Type: application/json\r\nContent-Length: {len(body)}\r\n\r\n").encode()
    out, next_time = [], time.monotonic()
    while not stop.wait(max(0.0, next_time - time.monotonic())):
        next_time += HOSTILE_PERIOD
        start = time.perf_counter()
        try:
            with socket.create_connection((host, int(port)), timeout=10) as conn:
                try:
                    conn.sendall(head + body)
                except OSError:  # the server answered and closed before taking the whole body
                    pass
                status = conn.recv(256).split(b"\r\n")[0].decode(errors="replace") or "closed"
        except OSError as exc:
            status = f"error {type(exc).__name__}"
        out.append((status, 1000.0 * (time.perf_counter() - start)))
    answers.put(out)


def _spin(stop) -> None:
    """Keep one core busy until ``stop`` is set (the busy-core job)."""
    while not stop.is_set():
        for _ in range(100_000):
            pass


class _Interference:
    """The hostile client or the busy-core job in a process of its own, from ``start`` to ``stop`` (which returns
    the hostile client's answers, empty for the busy core)."""

    def __init__(self, kind: str | None, url: str):
        context = multiprocessing.get_context("spawn")
        self.kind, self._stop, self._answers = kind, context.Event(), context.Queue()
        target, args = (_hostile, (url, self._stop, self._answers)) if kind == "hostile" else (_spin, (self._stop,))
        self._process = context.Process(target=target, args=args, daemon=True) if kind else None

    def start(self) -> None:
        if self._process is not None:
            self._process.start()

    def stop(self) -> list[tuple[str, float]]:
        if self._process is None:
            return []
        self._stop.set()
        answers = self._answers.get(timeout=60) if self.kind == "hostile" else []
        self._process.join(30)
        return answers


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start_server(folder: Path, model: Path, sync: str, workers: int, floor: bool) -> tuple[subprocess.Popen, str]:
    port = _free_port()
    command = ([sys.executable, str(Path(__file__).with_name("serve_floor.py")), "--port", str(port)] if floor else
               [sys.executable, "-m", "spotfree.cli", "serve", "--port", str(port), "--database",
                str(folder / "rides.db"), "--model", str(model), "--sync", sync, "--workers", str(workers)])
    # the server's messages go to a file: a pipe nobody reads fills up and stops the server when it writes
    log = open(folder / "server.log", "w")
    server = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=log, text=True)
    log.close()
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise RuntimeError(f"spotfree serve exited: {(folder / 'server.log').read_text()}")
        try:
            httpx.get(url + "/api/model", timeout=2).raise_for_status()
            return server, url
        except httpx.TransportError:
            time.sleep(0.2)
    server.kill()
    raise RuntimeError("spotfree serve did not answer within 60 s")


def _warning_samples(model: DictionaryModel, rows: np.ndarray, classifier=None) -> set[int]:
    """Indices of the samples of ``rows`` (a ride from its start) at which the server's pipeline and assistant
    raise a warning (:class:`~spotfree.ride.live.LiveRide`, :func:`~spotfree.ride.service.assistant_factory`);
    ``classifier``: the model's causal classifier, when already fitted."""
    classifier = dictionary_classifier(model, causal=True) if classifier is None else classifier
    live, assistant = LiveRide(model, classifier), assistant_factory(model)()
    _, labels = live.update_block(rows)
    warned = assistant.update_block(rows[:, [SAMPLE_COLUMNS.index(c) for c in ("time", "lat", "lon", "speed")]]
                                    .tolist(), labels)
    return {int(np.searchsorted(rows[:, 0], w.time)) for w in warned}


def batch_ends(n_samples: int, per_batch: int, warns: set[int]) -> list[int]:
    """The index after the last sample of every batch: every ``per_batch`` samples, and right after a sample that
    warns (the page's rule)."""
    ends, last = [], 0
    for k in range(n_samples):
        if k + 1 - last >= per_batch or k in warns:
            ends.append(k + 1)
            last = k + 1
    return ends


class Phone:
    """One simulated phone: its batches as JSON text (encoded before the run) with the offset (s from its start) at
    which each is sent, what it sent and what came back."""

    def __init__(self, token: str, rows: np.ndarray, ends: list[int], rate: float):
        self.token = token
        starts = [0, *ends[:-1]]
        self.messages = [(end / rate, json.dumps({"type": "batch", "seq": k, "samples": {
            name: [None if math.isnan(v) else float(v) for v in rows[a:end, j]]
            for j, name in enumerate(SAMPLE_COLUMNS)}})) for k, (a, end) in enumerate(zip(starts, ends))]
        self.sent: dict[int, float] = {}
        self.acked = 0
        self.ack_ms: list[float] = []
        self.warn_ms: list[float] = []
        self.refused: list[str] = []

    async def connect(self, url: str):
        ws = await connect(url.replace("http", "ws") + "/ws/ride", max_size=2**22)
        await ws.send(json.dumps({"type": "start", "token": self.token, "vehicle": "segway", "rider_id": "load"}))
        json.loads(await ws.recv())
        return ws

    async def ride(self, ws, start: float) -> None:
        receiver = asyncio.create_task(self._receive(ws))
        loop = asyncio.get_running_loop()
        for k, (offset, message) in enumerate(self.messages):
            await asyncio.sleep(max(0.0, start + offset - loop.time()))
            self.sent[k] = time.perf_counter()
            await ws.send(message)
        deadline = time.perf_counter() + 30
        while len(self.ack_ms) + len(self.refused) < len(self.messages) and time.perf_counter() < deadline:
            await asyncio.sleep(0.05)
        receiver.cancel()
        await ws.close()

    async def _receive(self, ws) -> None:
        async for raw in ws:
            now = time.perf_counter()
            reply = orjson.loads(raw)
            if reply.get("type") == "ack":
                ms = 1000.0 * (now - self.sent[reply["seq"]])
                self.ack_ms.append(ms)
                self.acked += reply["count"]
                if reply["warnings"]:
                    self.warn_ms.append(ms)
            elif reply.get("type") == "error":
                self.refused.append(reply["message"])

    def result(self) -> dict:
        return {"sent": len(self.sent), "acked": self.acked, "ack_ms": self.ack_ms, "warn_ms": self.warn_ms,
                "refused": self.refused}


async def _crowd(url: str, phones: list[Phone], spread: float, barrier) -> float:
    """Connect every phone and start its ride, wait for the other client processes, then stream; the CPU seconds
    this process spent streaming."""
    sockets = [await p.connect(url) for p in phones]
    await asyncio.to_thread(barrier.wait)
    cpu = time.process_time()
    start = asyncio.get_running_loop().time() + 0.5
    await asyncio.gather(*(p.ride(ws, start + spread * k / len(phones))
                           for k, (p, ws) in enumerate(zip(phones, sockets))))
    return time.process_time() - cpu


def _client(url: str, jobs: list[tuple[str, np.ndarray, list[int]]], rate: float, spread: float, barrier,
            results) -> None:
    """One client process: its share of the phones on one event loop; their results onto ``results``."""
    phones = [Phone(token, rows, ends, rate) for token, rows, ends in jobs]
    cpu = asyncio.run(_crowd(url, phones, spread, barrier))
    results.put((cpu, [p.result() for p in phones]))


async def _enrolled(client: httpx.AsyncClient, operator: dict, name: str) -> str:
    """A device token, enrolled with a code the operator issued."""
    code = (await client.post("/api/enrolments", json={}, headers=operator)).json()["code"]
    return (await client.post("/api/devices", json={"name": name, "code": code})).json()["token"]


async def _warm_up(client: httpx.AsyncClient, rows: np.ndarray, operator: dict) -> None:
    """One ride of 100 samples first, so that compiling and first-call costs are not counted."""
    token = await _enrolled(client, operator, "warm-up")
    headers = {"Authorization": f"Bearer {token}"}
    ride = (await client.post("/api/rides", json={"vehicle": "v", "rider_id": "r"}, headers=headers)).json()
    for k in range(0, 100, 5):
        samples = {name: [None if math.isnan(v) else float(v) for v in rows[k:k + 5, j]]
                   for j, name in enumerate(SAMPLE_COLUMNS)}
        (await client.post(f"/api/rides/{ride['ride_id']}/samples", json={"samples": samples},
                           headers=headers)).raise_for_status()
    await client.post(f"/api/rides/{ride['ride_id']}/end", headers=headers)


async def _devices(url: str, phones: int, rows: np.ndarray, folder: Path) -> list[str]:
    token_file = folder / "rides.db.operator-token"  # written by spotfree serve (none for the floor server)
    operator = {"Authorization": f"Bearer {token_file.read_text().strip()}"} if token_file.exists() else {}
    async with httpx.AsyncClient(base_url=url) as client:
        await _warm_up(client, rows, operator)
        return [await _enrolled(client, operator, f"load-{k}") for k in range(phones)]


def _cpu_seconds(pid: int) -> float:
    """User + system CPU seconds so far of a process and its child processes (the server's ride workers)."""
    children = [int(c) for task in Path(f"/proc/{pid}/task").iterdir()
                for c in (task / "children").read_text().split()]
    fields = Path(f"/proc/{pid}/stat").read_text().rpartition(")")[2].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK") + sum(_cpu_seconds(c) for c in children)


def _stream(url: str, server_pid: int, tokens: list[str], seconds: float, batch: float, rows: np.ndarray,
            rate: float, clients: int, model: DictionaryModel) -> tuple[list[dict], float, float, float]:
    """Run the phones in ``clients`` processes; their results, and the CPU seconds of the server and of the
    clients over the streaming, and its wall-clock seconds."""
    rng = np.random.default_rng(0)
    span = int(seconds * rate)
    per_batch = round(batch * rate)
    jobs, classifier = [], dictionary_classifier(model, causal=True)
    for token in tokens:
        offset = int(rng.integers(0, len(rows) - span))
        part = rows[offset:offset + span].copy()
        part[:, 0] -= part[0, 0]
        jobs.append((token, part, batch_ends(span, per_batch, _warning_samples(model, part, classifier))))
    context = multiprocessing.get_context("spawn")
    barrier, results = context.Barrier(clients + 1), context.Queue()
    workers = [context.Process(target=_client, args=(url, jobs[c::clients], rate, batch, barrier, results))
               for c in range(clients)]
    for w in workers:
        w.start()
    barrier.wait()
    cpu0, wall0 = _cpu_seconds(server_pid), time.perf_counter()
    client_cpu, out = 0.0, []
    for _ in workers:
        cpu, phones = results.get()
        client_cpu, out = client_cpu + cpu, out + phones
    server_cpu, wall = _cpu_seconds(server_pid) - cpu0, time.perf_counter() - wall0
    for w in workers:
        w.join()
    return out, server_cpu, client_cpu, wall


def run(phones: int, seconds: float, batch: float, rows: np.ndarray, rate: float, model: Path,
        sync: str = "full", clients: int = 1, workers: int = 0, floor: bool = False,
        interference: str | None = None) -> dict:
    """One N: ``interference`` None, ``"hostile"`` or ``"busy"`` (see the module docstring)."""
    with tempfile.TemporaryDirectory() as folder:
        server, url = _start_server(Path(folder), model, sync, workers, floor)
        other = _Interference(interference, url)
        try:
            tokens = asyncio.run(_devices(url, phones, rows, Path(folder)))
            other.start()
            crowd, server_cpu, client_cpu, wall = _stream(url, server.pid, tokens, seconds, batch, rows, rate,
                                                          clients, DictionaryModel.load(model))
        finally:
            hostile = other.stop()
            server.send_signal(signal.SIGINT)
            try:
                server.wait(120)  # a server behind on its batches commits them all before it stops
            except subprocess.TimeoutExpired:
                server.kill()
                print((Path(folder) / "server.log").read_text()[-2000:], file=sys.stderr)
                raise
        if floor:  # nothing is stored: count what was acknowledged
            stored = None
        else:
            with RideStore(Path(folder) / "rides.db") as store:  # less the warm-up ride's 100 samples
                stored = sum(len(store.samples(ride.ride_id)["time"]) for ride in store.rides()) - 100
    ack = np.concatenate([p["ack_ms"] for p in crowd])
    warn = np.concatenate([p["warn_ms"] for p in crowd])
    return {"phones": phones, "batches": sum(p["sent"] for p in crowd), "acked": len(ack),
            "refused": sum(len(p["refused"]) for p in crowd),
            "p50": float(np.percentile(ack, 50)), "p99": float(np.percentile(ack, 99)), "max": float(ack.max()),
            "warnings": len(warn), "warn_p50": float(np.percentile(warn, 50)) if len(warn) else math.nan,
            "warn_p99": float(np.percentile(warn, 99)) if len(warn) else math.nan,
            "acked_samples": sum(p["acked"] for p in crowd),
            "stored": sum(p["acked"] for p in crowd) if stored is None else stored,
            "server_cores": server_cpu / wall, "client_cores": client_cpu / wall,
            "server_ms": 1000.0 * server_cpu / max(len(ack), 1), "hostile": hostile}


_INTERFERENCE = {None: "no other client or job of ours",
                 "hostile": f"a hostile client posts {HOSTILE_BYTES / 1e6:g} MB to /push with a made-up token every "
                            f"{HOSTILE_PERIOD:g} s",
                 "busy": "a process of ours keeps one core busy"}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--phones", default="10,25,50,100,200,500")
    parser.add_argument("--seconds", type=float, default=15.0)
    parser.add_argument("--batch", type=float, default=1.0, help="s of samples per batch (the page sends 1)")
    parser.add_argument("--sync", default="full", choices=("full", "normal"), help="spotfree serve --sync")
    parser.add_argument("--clients", type=int, default=2, help="client processes the phones are spread over")
    parser.add_argument("--workers", type=int, default=0, help="spotfree serve --workers (ride worker processes)")
    parser.add_argument("--floor", action="store_true",
                        help="run the phones against benchmarks/serve_floor.py (the web stack alone) instead")
    parser.add_argument("--hostile", action="store_true",
                        help="a client posts a 4 MB /push with a made-up token every second meanwhile")
    parser.add_argument("--busy-core", action="store_true", help="a process keeps one core busy meanwhile")
    args = parser.parse_args()
    if args.hostile and args.busy_core:
        parser.error("--hostile and --busy-core: give one of them (each is its own run)")
    interference = "hostile" if args.hostile else "busy" if args.busy_core else None
    name = "serve_load" + (f"_{interference}" if interference else "") + ("_floor" if args.floor else "")
    with results_file(name, "The ride service under load: " + _INTERFERENCE[interference], preformatted=True,
                      packages=("numpy", "fastapi", "uvicorn", "websockets")):
        _measure(args, interference)


def _measure(args, interference) -> None:
    """The table of :func:`main`: one row per number of phones, until one fails."""
    raw = rides(seed=1, repeats=2)
    rows = recording_rows(raw.select_experiment(2))
    rate = raw.rate
    print(f"# serve_load: {platform.node()} {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC")
    print(f"# {args.seconds:g} s per N, {rate:g} Hz, batches of {args.batch:g} s, SQLite synchronous={args.sync.upper()}, "
          f"{'the web stack alone (benchmarks/serve_floor.py)' if args.floor else f'spotfree serve --workers {args.workers}'}, phones in {args.clients} client process(es); "
          f"{_INTERFERENCE[interference]}; latency in ms from sending a batch to its acknowledgement "
          "(warn: from taking the sample that warns, whose batch is sent at once); "
          "server and client CPU in cores (CPU s per s of streaming); load avg: 1-minute, after the run")
    print("| phones | load avg | server CPU | server ms/batch | client CPU | batches sent | acked | refused | p50 | p99 | max | warnings "
          "| warn p50 | warn p99 | samples acked | rows stored |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    best = best_warn = 0
    with tempfile.TemporaryDirectory() as folder:
        model = Path(folder) / "model.npz"
        truth_model(raw.select_experiment(1)).save(model)
        for phones in (int(n) for n in args.phones.split(",")):
            r = run(phones, args.seconds, args.batch, rows, rate, model, args.sync, args.clients, args.workers,
                    args.floor, interference)
            print(f"| {r['phones']} | {os.getloadavg()[0]:.1f} | {r['server_cores']:.2f} | {r['server_ms']:.2f} | {r['client_cores']:.2f} "
                  f"| {r['batches']} | {r['acked']} | {r['refused']} | {r['p50']:.1f} | {r['p99']:.1f} "
                  f"| {r['max']:.0f} | {r['warnings']} | {r['warn_p50']:.1f} | {r['warn_p99']:.1f} "
                  f"| {r['acked_samples']} | {r['stored']} |", flush=True)
            if interference == "hostile":
                statuses = {}
                for status, _ in r["hostile"]:
                    statuses[status] = statuses.get(status, 0) + 1
                ms = np.array([m for _, m in r["hostile"]]) if r["hostile"] else np.array([math.nan])
                print(f"#   hostile posts at N={phones}: {len(r['hostile'])}, answers "
                      f"{', '.join(f'{n} x {s!r}' for s, n in statuses.items())}; ms to the answer p50 "
                      f"{np.median(ms):.1f}, max {ms.max():.1f}", flush=True)
            whole = r["acked"] == r["batches"] and r["stored"] == r["acked_samples"]
            if whole and r["p99"] < LIMIT_MS:
                best = phones
            if whole and r["warn_p99"] < LIMIT_MS:
                best_warn = phones
            if not whole or r["p99"] > 10 * LIMIT_MS:
                break
    print(f"# largest N with p99 < {LIMIT_MS:g} ms, every batch acknowledged and every acknowledged sample stored: "
          f"{best}; with p99 sample-to-warning < {LIMIT_MS:g} ms: {best_warn}")


if __name__ == "__main__":
    main()
