"""Shared by the ride tests: a throw-away PostgreSQL server on loopback, stores on both back ends, sample batches.

The server comes from Debian's package (``scripts/ensure_postgres.sh`` installs it when missing): ``initdb`` into
a temporary folder, ``pg_ctl start`` on a free loopback port with its socket in that folder, one fresh schema
per test. As root the server runs as the ``postgres`` user, since PostgreSQL refuses to run as root.
"""

from __future__ import annotations

import glob
import os
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest

from spotfree.ride.store import RideStore

ROOT = Path(__file__).resolve().parents[1]


def batch(start: float, n: int, rate: float = 20.0, fix_every: int = 20) -> dict[str, np.ndarray]:
    """``n`` samples from ``start`` s at ``rate`` Hz: a tablet lying flat, a GPS fix every ``fix_every`` samples."""
    t = start + np.arange(n) / rate
    fix = (np.arange(n) % fix_every) == 0
    return {
        "time": t, "ax": 0.1 * np.sin(t), "ay": np.zeros(n), "az": np.full(n, 9.81),
        "gx": np.zeros(n), "gy": 0.01 * np.cos(t), "gz": np.zeros(n),
        "lat": np.where(fix, 36.08 + 1e-5 * t, np.nan), "lon": np.where(fix, 140.11, np.nan),
        "speed": np.where(fix, 3.0, np.nan),
    }


def _binary(name: str) -> str:
    versions = sorted(glob.glob(f"/usr/lib/postgresql/*/bin/{name}"), key=lambda p: int(Path(p).parts[4]))
    found = versions[-1] if versions else shutil.which(name)
    if found is None:
        pytest.fail(f"{name} not found after scripts/ensure_postgres.sh")
    return found


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _run(*args: str) -> None:
    done = subprocess.run(args, capture_output=True, text=True)
    assert done.returncode == 0, f"{' '.join(args)} failed: {(done.stderr or done.stdout).strip()[-2000:]}"


@pytest.fixture(scope="session")
def postgres_server():
    """URL prefix ``postgresql://spotfree@127.0.0.1:PORT`` of a running server, stopped after the session."""
    done = subprocess.run(["bash", str(ROOT / "scripts" / "ensure_postgres.sh")], capture_output=True, text=True)
    if done.returncode == 3:
        pytest.skip(done.stderr.strip())
    assert done.returncode == 0, f"scripts/ensure_postgres.sh failed: {done.stderr.strip()[-2000:]}"
    folder = Path(tempfile.mkdtemp(prefix="spotfree-postgres-"))  # outside pytest's root-only folders
    as_user = ("runuser", "-u", "postgres", "--") if os.geteuid() == 0 else ()
    if as_user:
        shutil.chown(folder, "postgres")
    data, port = folder / "data", _free_port()
    _run(*as_user, _binary("initdb"), "-D", str(data), "-U", "spotfree", "--auth=trust", "-E", "UTF8")
    options = f"-c listen_addresses=127.0.0.1 -p {port} -k {folder}"
    _run(*as_user, _binary("pg_ctl"), "-D", str(data), "-o", options, "-l", str(folder / "log"), "-w", "start")
    try:
        yield f"postgresql://spotfree@127.0.0.1:{port}"
    finally:
        _run(*as_user, _binary("pg_ctl"), "-D", str(data), "-m", "immediate", "-w", "stop")
        shutil.rmtree(folder, ignore_errors=True)


def postgres_database(server: str) -> str:
    """URL of a new, empty schema on ``server`` (a schema, not a database: creating one is instant)."""
    import psycopg

    name = f"rides_{uuid.uuid4().hex[:12]}"
    with psycopg.connect(f"{server}/postgres", autocommit=True) as connection:
        connection.execute(f"CREATE SCHEMA {name}")
    return f"{server}/postgres?options=-csearch_path%3D{name}"


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.postgres)])
def store(request, tmp_path):
    """A new, empty RideStore on each back end."""
    if request.param == "sqlite":
        location = tmp_path / "rides.db"
    else:
        location = postgres_database(request.getfixturevalue("postgres_server"))
    with RideStore(location) as opened:
        yield opened
