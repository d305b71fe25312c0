"""``spotfree serve``: the model, the store, the service and its web API under uvicorn, with the optional
replayed or simulated rider (:mod:`spotfree.ride.sources`) and a self-signed certificate (:mod:`spotfree.ride.tls`).

The operator credential: there is no default password. On the first start over a store (no operator token in
it yet), or with ``--new-operator-token``, a new operator token is issued and written to the file
:func:`operator_token_file` names (beside a SQLite store, ``<store>.operator-token``; in the working folder for
a PostgreSQL store), readable by its owner only; the banner names the file, never the token. The store keeps only
the token's hash, so a lost file is replaced by starting once with ``--new-operator-token``.
"""

from __future__ import annotations

import asyncio
import contextlib
import errno
import os
import signal
import socket
from pathlib import Path
from typing import Callable

from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.ride import collector
from spotfree.ride.api import MAX_BODY, create_app
from spotfree.ride.default_model import default_model
from spotfree.ride.redact import redact_location
from spotfree.ride.service import RideService
from spotfree.ride.store import RideStore


def _rider_rows(replay: str | None, simulate: str | None, seed: int):
    from spotfree.ride.sources import recording_rows

    if replay and simulate:
        raise InputError("--replay and --simulate: give one of them")
    if replay:
        from spotfree.io import read_recording

        return recording_rows(read_recording(replay)), f"replay {Path(replay).name}"
    from spotfree.sim.scenarios import simulate_scenario

    return recording_rows(simulate_scenario(simulate, repeats=1, seed=seed)), f"simulated {simulate}"


def build_service(database: str, model_path: Path | None, synchronous: str = "full", workers: int = 0) -> RideService:
    """The service over ``database`` with the model at ``model_path`` (the shipped default model when None);
    ``synchronous``: the SQLite durability of :class:`~spotfree.ride.store.RideStore`; ``workers``: rides in
    that many worker processes (:class:`~spotfree.ride.pool.RideServicePool`), 0 for the server's process."""
    if workers < 0:
        raise InputError(f"--workers {workers}: give 0 (rides in the server's process) or more")
    model = DictionaryModel.load(model_path) if model_path else default_model()
    store = RideStore(database, synchronous=synchronous)
    name = model_path.stem if model_path else "default"
    if workers:
        from spotfree.ride.pool import RideServicePool

        return RideServicePool(model, store, model_name=name, processes=workers)
    return RideService(model, store, model_name=name)


MAX_HEADER_BYTES = 16_384
"""Bytes of a request's line and headers that uvicorn buffers before answering 400 (h11's incomplete event)."""
KEEP_ALIVE_SECONDS = 5
"""Seconds an idle keep-alive HTTP connection stays open after its last answer."""
SPARE_DESCRIPTORS = 64
"""File descriptors kept out of the connection cap: the store, the ride workers' pipes, the certificate."""


def uvicorn_limits() -> dict:
    """uvicorn's own limits for the server: ``limit_concurrency`` (connections and requests at once; beyond it a new
    request is answered 503 rather than the process running out of file descriptors), ``timeout_keep_alive``,
    ``h11_max_incomplete_event_size`` and ``ws_max_size``; ``http="h11"``, the HTTP parser that bounds a request's
    headers (httptools buffers them without a limit). The soft limit of open files is raised to the hard one
    first, and the cap is that limit less :data:`SPARE_DESCRIPTORS`."""
    import resource

    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if hard == resource.RLIM_INFINITY or hard > soft:
        wanted = 65_536 if hard == resource.RLIM_INFINITY else min(hard, 65_536)
        if wanted > soft:
            with contextlib.suppress(ValueError, OSError):
                resource.setrlimit(resource.RLIMIT_NOFILE, (wanted, hard))
                soft = wanted
    return {"limit_concurrency": max(16, soft - SPARE_DESCRIPTORS), "timeout_keep_alive": KEEP_ALIVE_SECONDS,
            "h11_max_incomplete_event_size": MAX_HEADER_BYTES, "ws_max_size": MAX_BODY, "http": "h11"}


SHUTDOWN_SECONDS = 10
"""Seconds a SIGTERM or Ctrl-C waits for open requests and sockets before the server stops anyway (the store is
closed after them: every acknowledged sample is committed)."""


def operator_token_file(database: str) -> Path:
    """Where the operator token of the store at ``database`` is written: beside a SQLite file, or
    ``spotfree-operator-token`` in the working folder for a ``postgresql://`` URL."""
    if "://" in database:
        return Path("spotfree-operator-token")
    path = Path(database)
    return path.with_name(path.name + ".operator-token")


def provide_operator_token(service: RideService, path: Path, renew: bool, say: Callable[[str], None]) -> None:
    """Issue an operator token when the store has none (or ``renew``) and write it to ``path`` (mode 0600,
    replacing the file); say where it is, or how to get one when the file is gone."""
    if renew or service.store.operator_token_hash() is None:
        token = service.new_operator_token()
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        with os.fdopen(fd, "w") as file:
            file.write(token + "\n")
        os.chmod(path, 0o600)
        say(f"operator token: new, written to {path} (only you can read it); paste it into /operator")
    elif path.exists():
        say(f"operator token: in {path}; paste it into /operator")
    else:
        say(f"operator token: {path} is gone; start once with --new-operator-token to issue a new one")


def check_address(host: str, port: int) -> None:
    """Refuse (InputError, one line) an address this process cannot listen on, before anything is loaded: a port
    another program listens on, a port below 1024 without the privilege, a host that is not this machine's. Port 0
    (any free port) is not checked. The probe binds as uvicorn does (``SO_REUSEADDR``) and closes at once."""
    if port == 0:
        return
    try:
        family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
    except socket.gaierror as exc:
        raise InputError(f"--host {host}: not an address of this machine ({exc.strerror}); give an IP address, "
                         "e.g. 127.0.0.1 or 0.0.0.0") from None
    with socket.socket(family, socket.SOCK_STREAM) as probe:
        probe.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            probe.bind((host, port))
        except OSError as exc:
            if exc.errno == errno.EADDRINUSE:
                raise InputError(f"--port {port}: {host}:{port} is in use by another program; stop it or give "
                                 "another --port (0: any free port)") from None
            if exc.errno == errno.EACCES:
                raise InputError(f"--port {port}: ports below 1024 need administrator rights; give a port from "
                                 "1024") from None
            raise InputError(f"--host {host} --port {port}: cannot listen there ({exc.strerror}); give an "
                             "address of this machine") from None


def run_server(host: str, port: int, database: str, https: bool, replay: str | None, simulate: str | None,
               model_path: Path | None, speed: float, seed: int, say: Callable[[str], None],
               synchronous: str = "full", workers: int = 0, new_operator_token: bool = False,
               certificate: tuple[Path, Path] | None = None) -> None:
    """Serve until interrupted (see the module docstring); ``certificate``: the user's own ``(cert, key)`` PEM
    files for https (else ``https`` uses a self-signed one kept beside the store)."""
    import uvicorn

    if not 0 <= port <= 65535:
        raise InputError(f"--port {port}: give a port from 1 to 65535 (0: any free port)")
    check_address(host, port)
    if certificate is not None:
        from spotfree.ride.tls import user_certificate

        certificate = user_certificate(*certificate)  # refused before anything is loaded
    rows = _rider_rows(replay, simulate, seed) if (replay or simulate) else None
    service = build_service(database, model_path, synchronous, workers)
    provide_operator_token(service, operator_token_file(database), new_operator_token, say)
    service.keep_tidy()  # rides left open longer than IDLE_SECONDS are closed now, and checked again while serving
    app = create_app(service)
    if rows is not None:
        from spotfree.ride.sources import ride_live

        @contextlib.asynccontextmanager
        async def rider(_app):
            task = asyncio.create_task(ride_live(service, rows[0], rows[1], speed=speed, loop_forever=True))
            yield
            task.cancel()

        app.router.lifespan_context = rider
    tls = {}
    if certificate is not None:
        tls = {"ssl_certfile": str(certificate[0]), "ssl_keyfile": str(certificate[1])}
    elif https:
        from spotfree.ride.tls import kept_certificate, lan_addresses

        folder = Path(database).parent if "://" not in database else Path(".")
        cert, key = kept_certificate(folder / "spotfree-tls", [host, *lan_addresses()])
        tls = {"ssl_certfile": str(cert), "ssl_keyfile": str(key)}
    scheme = "https" if tls else "http"
    say(f"spotfree serve: {scheme}://{host}:{port}/ (phone), /rider, /operator; rides recorded in "
        f"{redact_location(database)}")
    collector.settle()  # no full garbage collection pauses while serving (spotfree.ride.collector)
    # a WebSocket message over MAX_BODY closes the socket (1009) as it arrives, before it is buffered whole;
    # no per-message compression: a batch or an acknowledgement is under a few kB, too small for deflating each
    # one to pay for its CPU under load
    # uvicorn shuts down gracefully on SIGTERM, then raises the signal again for the handler it found: this one
    # ends the run normally, so that the store and the ride workers are closed and the exit status is 0
    signal.signal(signal.SIGTERM, _stop)
    try:
        uvicorn.run(app, host=host, port=port, log_level="warning", ws_per_message_deflate=False,
                    timeout_graceful_shutdown=SHUTDOWN_SECONDS, **uvicorn_limits(), **tls)
    except _Stopped:
        pass
    finally:
        service.close()


class _Stopped(Exception):
    """SIGTERM reached the server after uvicorn's graceful shutdown."""


def _stop(signum, frame) -> None:
    raise _Stopped
