"""Shared by the tests of the ride service's web API: a simulated ride and a model trained on its first
experiment, sample columns as JSON sends them, and devices enrolled as a phone is."""

from __future__ import annotations

import contextlib
import itertools
import math
import socket
import threading
import time

import numpy as np
import pytest

from classify_fixtures import rides, truth_model
from spotfree.ride.records import SAMPLE_COLUMNS


@pytest.fixture(scope="module")
def raw():
    return rides(seed=1, repeats=2)


@pytest.fixture(scope="module")
def model(raw):
    return truth_model(raw.select_experiment(1))


def columns(rows) -> dict[str, list]:
    """Sample rows ``(n, len(SAMPLE_COLUMNS))`` as the JSON columns of a batch (None for NaN)."""
    return {name: [None if math.isnan(v) else float(v) for v in rows[:, j]] for j, name in enumerate(SAMPLE_COLUMNS)}


def sample_and_block_runs(one, blocks, rows, sizes):
    """Feed ``rows`` to the LiveRide ``one`` sample by sample and to ``blocks`` in blocks of the cycled ``sizes``:
    ``(want, features, labels)``, ``want`` the ``(features, label)`` pairs of ``one``."""
    want = [one.update(r[0], r[1:4], r[4:7], r[9]) for r in rows]
    got_features, got_labels, k = [], [], 0
    for size in itertools.cycle(sizes):
        if k >= len(rows):
            break
        feats, labels = blocks.update_block(rows[k:k + size])
        got_features.append(feats)
        got_labels += labels
        k += size
    return want, np.vstack(got_features), got_labels


def bearer(token: str) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def enrol(client, operator: dict, name: str = "phone") -> str:
    """A device token, enrolled through the API with a code the operator issued."""
    code = client.post("/api/enrolments", json={}, headers=operator).json()["code"]
    return client.post("/api/devices", json={"name": name, "code": code}).json()["token"]


@contextlib.contextmanager
def served(app):
    """``app`` under a real uvicorn server on a free loopback port, in a thread; yields its base URL."""
    import uvicorn

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    server = uvicorn.Server(uvicorn.Config(app, host="127.0.0.1", port=port, log_level="warning"))
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.05)
    try:
        yield f"http://127.0.0.1:{port}"
    finally:
        server.should_exit = True
        thread.join(5)
