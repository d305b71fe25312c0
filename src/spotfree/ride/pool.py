"""The live service over several processes: each open ride lives in one worker process, which classifies its
batches and commits them; the web server's process only parses, routes and answers.

:class:`RideServicePool` is a :class:`~spotfree.ride.service.RideService` (same methods, same refusals, same
acknowledgements, the views fed in the server's process) whose rides are opened in ``processes`` worker processes,
each with its own :class:`~spotfree.ride.service.RideService` and its own connection to the same store. SQLite
takes one writer at a time: the workers' group commits take turns on one lock (:class:`WriteLock`, a blocking
wait, where SQLite's own busy handler would poll with sleeps of up to 100 ms); PostgreSQL takes them together.
A new ride goes to the worker with the fewest open rides and stays there; every later call on it is sent to that
worker over a pipe, and the answer comes back once the worker has committed (an acknowledged sample is in the
store, as in one process). Python runs one thread at a time per process, so this is how the service uses more
than one core.

The server's process keeps its own store connection for device registration and for the views' reads. Rides
left without samples for :data:`~spotfree.ride.service.IDLE_SECONDS` are closed while serving
(:meth:`~spotfree.ride.service.RideService.keep_tidy`), each by the worker that holds it.
"""

from __future__ import annotations

import fcntl
import itertools
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future

from spotfree.model import DictionaryModel
from spotfree.ride import collector
from spotfree.ride.assistant import RideAssistant
from spotfree.ride.live import LiveRide
from spotfree.ride.service import RideService, UnavailableError
from spotfree.ride.store import ForbiddenError, RideStore
from spotfree.ride.tokens import token_hash
from spotfree.units import GRAVITY


class WriteLock:
    """The turn of one process at writing a SQLite file, between processes: an exclusive ``flock`` on a lock file
    beside it, which the operating system releases when its holder dies (a ``multiprocessing.Lock`` held by a
    worker killed in mid-commit stayed taken, and every other worker waited on it for good). A context manager,
    picklable (each process opens the file itself); threads of one process take turns on a thread lock first,
    since ``flock`` is held per open file."""

    def __init__(self, path: str):
        self.path = path
        self._fd: int | None = None
        self._threads = threading.Lock()

    def __getstate__(self) -> dict:
        return {"path": self.path}

    def __setstate__(self, state: dict) -> None:
        self.__init__(state["path"])

    def __enter__(self) -> "WriteLock":
        self._threads.acquire()
        try:
            if self._fd is None:
                self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o600)
            fcntl.flock(self._fd, fcntl.LOCK_EX)
        except BaseException:
            self._threads.release()
            raise
        return self

    def __exit__(self, *exc) -> None:
        fcntl.flock(self._fd, fcntl.LOCK_UN)
        self._threads.release()


class WorkerError(UnavailableError):
    """A worker process stopped or failed in a way its answer could not carry (send the call again: its
    replacement takes the ride over from the store)."""


class RideServicePool(RideService):
    """:class:`~spotfree.ride.service.RideService` with rides in ``processes`` worker processes (module docstring).

    Parameters are those of :class:`~spotfree.ride.service.RideService`, and ``processes``: worker processes
    (at least 1). Call :meth:`close` to stop them.
    """

    def __init__(self, model: DictionaryModel, store: RideStore, model_name: str = "default",
                 assistant: Callable[[], RideAssistant] | None = None, processes: int = 2):
        super().__init__(model, store, model_name, assistant)
        if processes < 1:
            raise ValueError(f"processes={processes}: give at least 1 worker process")
        self._context = multiprocessing.get_context("spawn")
        # the workers take turns at the SQLite file's write lock
        lock = None if "://" in store.location else WriteLock(store.location + ".write-lock")
        self._service_args = (model, store.location, store.synchronous, lock, model_name, assistant)
        self._closing = False
        self.restarts = 0
        self._home: dict[str, _Worker] = {}
        self._workers = [self._start_worker(k) for k in range(processes)]
        for worker in self._workers:
            worker.ready()

    def _start_worker(self, index: int) -> "_Worker":
        return _Worker(self._context, index, self._service_args, on_stop=self._replace)

    def _replace(self, dead: "_Worker") -> None:
        """Supervision: a worker that stopped while serving is replaced by a new process at its index; its rides
        are no longer homed, so the next call on each goes to a live worker, which rebuilds it from the store.
        The new process is started and waited for outside the lock every call takes (starting one sends it the
        model and takes seconds); until it is ready the dead worker keeps its place, so :meth:`health` says
        ``degraded`` and new or unhomed rides go to the live workers only."""
        with self._lock:
            if self._closing or self._workers[dead.index] is not dead:
                return
            for ride_id in [r for r, w in self._home.items() if w is dead]:
                del self._home[ride_id]
            dead.rides = 0
        fresh = self._start_worker(dead.index)
        try:
            fresh.ready()
        except Exception:  # noqa: BLE001 - the replacement's own failure ends it, and _replace runs again for it
            pass
        with self._lock:
            closing = self._closing
            if not closing:
                self._workers[dead.index] = fresh
                self.restarts += 1
        if closing:
            fresh.stop()

    def _live_worker(self) -> "_Worker":
        """The live worker with the fewest open rides (under the lock); UnavailableError while none is alive."""
        alive = [w for w in self._workers if w.alive()]
        if not alive:
            raise WorkerError("every ride worker is being replaced; send again in a second")
        return min(alive, key=lambda w: w.rides)

    def close(self) -> None:
        """Stop the workers (each commits what it holds first), then close the server's store."""
        with self._lock:
            self._closing = True
        self._stopping.set()
        for worker in self._workers:
            worker.stop()
        super().close()

    def health(self) -> dict:
        with self._lock:
            workers = [{"index": w.index, "alive": w.alive(), "rides": w.rides} for w in self._workers]
            restarts = self.restarts
        status = "ok" if all(w["alive"] for w in workers) else "degraded"
        return {"status": status, "open_rides": len(self.open_rides()), "workers": workers, "restarts": restarts}

    def _close_stale(self, stale: list[tuple[str, float]]) -> dict[str, list[dict]]:
        """Each worker closes the stale rides it holds (their state is there); the rides no worker holds are
        closed in this process. A worker that stopped meanwhile leaves its rides to the next round."""
        with self._lock:
            by_worker: dict[_Worker | None, list[tuple[str, float]]] = {}
            for ride_id, last in stale:
                by_worker.setdefault(self._home.get(ride_id), []).append((ride_id, last))
        closed = super()._close_stale(by_worker.pop(None, []))
        for worker, rides in by_worker.items():
            try:
                done = worker.call("close_stale", rides).result()
            except WorkerError:
                continue
            closed.update(done)
            with self._lock:
                for ride_id, _ in rides:
                    if self._home.get(ride_id) is worker:
                        del self._home[ride_id]
                        worker.rides -= 1
        return closed

    def _open_ride(self, token: str, vehicle: str, rider_id: str, meta: dict) -> str:
        with self._lock:
            worker = self._live_worker()
            worker.rides += 1
        try:
            ride_id = worker.call("open", token, vehicle, rider_id, meta).result()
        except BaseException:
            with self._lock:
                worker.rides -= 1
            raise
        with self._lock:
            self._home[ride_id] = worker
        return ride_id

    def _close_ride(self, token: str, ride_id: str) -> list[dict]:
        worker = self._worker(ride_id)
        events = worker.call("close", token, ride_id).result()
        with self._lock:
            if self._home.pop(ride_id, None) is not None:
                worker.rides -= 1
        return events

    def set_destination(self, token: str, ride_id: str, lat: float, lon: float) -> None:
        self._worker(ride_id).call("destination", token, ride_id, lat, lon).result()
        self._claim(token, ride_id)

    def resume(self, token: str, ride_id: str) -> float | None:
        last = self._worker(ride_id).call("resume", token, ride_id).result()
        self._claim(token, ride_id)
        return last

    def _claim(self, token: str, ride_id: str) -> None:
        """Once a worker took a call of ``token`` on ``ride_id`` (so the token is the ride's), the views know the
        ride's owner, also for a ride started before this server process (a restart): a device's views get its
        messages."""
        with self._lock:
            self._owners.setdefault(ride_id, token_hash(token))

    def open_rides(self) -> list[str]:
        with self._lock:
            return list(self._home)

    def _submit(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]], check_rate: bool,
                describe: bool) -> Future:
        """The batch goes to the ride's worker; the device's rate bucket is this process's (a device's rides may
        live in different workers), its samples given back when the worker refuses the batch."""
        worker = self._worker(ride_id)
        rows = samples.get("time") if isinstance(samples, Mapping) else None
        if not (check_rate and isinstance(token, str) and isinstance(rows, Sequence)):
            return worker.call("submit", token, ride_id, samples, check_rate, describe)
        n = len(rows)
        bucket = self._take(token_hash(token), n, f"ride {ride_id} (its device's rides together)")
        try:
            answer = worker.call("submit", token, ride_id, samples, False, describe)
        except BaseException:
            bucket.give(n)
            raise

        def settled(done: Future) -> None:
            if done.exception() is not None:
                with self._lock:
                    bucket.give(n)
            else:
                self._claim(token, ride_id)
        answer.add_done_callback(settled)
        return answer

    def _holds(self, ride_id: str) -> bool:
        return True  # the workers rebuild rides; routing one costs this process one small store query

    def _worker(self, ride_id: str) -> "_Worker":
        """The worker holding ``ride_id``; an open ride of the store that no worker holds (after a restart, or
        its worker's death) is given to the least loaded one, which rebuilds it from the store on this call."""
        with self._lock:
            worker = self._home.get(ride_id)
        if worker is not None:
            return worker
        if self.store.ride(ride_id).ended is not None:  # NotFoundError for an unknown id
            raise ForbiddenError(f"ride {ride_id} is not open (it has ended); start a new ride")
        with self._lock:
            worker = self._home.get(ride_id)
            if worker is None:
                worker = self._live_worker()
                worker.rides += 1
                self._home[ride_id] = worker
        return worker


class _Worker:
    """The server's end of one worker process: calls go down a pipe, answers come back on a reader thread."""

    def __init__(self, context, index: int, service_args: tuple, on_stop=None):
        self.index = index
        self._on_stop = on_stop
        self.rides = 0
        self._pipe, child = context.Pipe()
        self._process = context.Process(target=_serve, args=(child, service_args), daemon=True,
                                        name=f"spotfree-rides-{index}")
        self._process.start()
        child.close()
        self._send_lock = threading.Lock()
        self._pending: dict[int, Future] = {}
        self._ids = itertools.count()
        self._stopped: WorkerError | None = None
        self._ready: Future = Future()
        self._pending[-1] = self._ready
        self._reader = threading.Thread(target=self._read, name=f"spotfree-rides-{index}-answers", daemon=True)
        self._reader.start()

    def ready(self) -> None:
        """Wait until the worker has loaded the model and opened the store (its failure raised here)."""
        self._ready.result()

    def call(self, name: str, *args) -> Future:
        """A future of the worker's answer to ``name(*args)`` (its exception when it refused)."""
        future: Future = Future()
        with self._send_lock:
            if self._stopped is not None:
                raise WorkerError(str(self._stopped))
            call_id = next(self._ids)
            self._pending[call_id] = future
            try:
                self._pipe.send((call_id, name, args))
            except (OSError, ValueError) as exc:
                self._pending.pop(call_id, None)
                raise WorkerError(f"ride worker {self.index} has stopped ({exc}); send again") from None
        return future

    def stop(self) -> None:
        with self._send_lock:
            try:
                self._pipe.send(None)
            except (OSError, ValueError):
                pass
        self._process.join(60)
        if self._process.is_alive():
            self._process.kill()
        self._reader.join(10)

    def _read(self) -> None:
        while True:
            try:
                call_id, ok, value = self._pipe.recv()
            except (EOFError, OSError):
                break
            future = self._pending.pop(call_id, None)
            if future is None:
                continue
            if ok:
                future.set_result(value)
            else:
                future.set_exception(value)
        self._process.join(5)
        with self._send_lock:
            self._stopped = WorkerError(f"ride worker {self.index} has stopped (exit code "
                                        f"{self._process.exitcode}); send again: its rides go on in its "
                                        "replacement")
            pending, self._pending = list(self._pending.values()), {}
        for future in pending:
            future.set_exception(WorkerError(str(self._stopped)))
        if self._on_stop is not None:
            self._on_stop(self)

    def alive(self) -> bool:
        """Whether the process runs and answers (False once its pipe closed)."""
        return self._stopped is None and self._process.is_alive()


def _warm_up(service: RideService) -> None:  # pragma: no cover - runs in the worker process
    """Run a resting phone through a throw-away ride pipeline, so that the compiled kernels are loaded before the
    worker says it is ready (else the first batches of its first rides wait for them)."""
    live = LiveRide(service.model, service.classifier)
    for k in range(2 * service.model.window):
        live.update(k / service.model.rate, (0.0, GRAVITY, 0.0), (0.0, 0.0, 0.0))


def _serve(pipe, service_args: tuple) -> None:  # pragma: no cover - runs in the worker process
    """A worker process: one :class:`RideService` answering the calls of :class:`_Worker` until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the server, which then stops its workers
    model, location, synchronous, lock, model_name, assistant = service_args
    sending = threading.Lock()

    def answer(call_id: int, ok: bool, value) -> None:
        with sending:
            try:
                pipe.send((call_id, ok, value))
            except Exception as exc:  # an exception that does not pickle travels as its message
                pipe.send((call_id, False, WorkerError(f"{type(value).__name__}: {value} ({exc})")))

    try:
        store = RideStore(location, synchronous=synchronous, lock=lock)
        service = RideService(model, store, model_name, assistant)
        _warm_up(service)
    except Exception as exc:
        answer(-1, False, exc)
        return
    collector.settle()
    answer(-1, True, None)
    methods = {"open": service._open_ride, "close": service._close_ride, "destination": service.set_destination,
               "resume": service.resume, "submit": service._submit, "close_stale": service._close_stale}
    while True:
        try:
            message = pipe.recv()
        except (EOFError, OSError):
            break
        if message is None:
            break
        call_id, name, args = message
        try:
            value = methods[name](*args)
        except Exception as exc:
            answer(call_id, False, exc)
            continue
        if isinstance(value, Future):
            value.add_done_callback(lambda done, call_id=call_id: answer(
                call_id, done.exception() is None, done.exception() or done.result()))
        else:
            answer(call_id, True, value)
    store.close()
