"""The live client against a fake tracking service: a real WebSocket server on the loopback interface that speaks
the service's protocol (version header, background request, frames, events, close codes)."""

import json
import queue
import socket
import threading
from contextlib import contextmanager

import numpy as np
import pytest
from websockets.sync.server import serve

from spotfree.hand.frames import frame_message
from spotfree.hand.live import TrackingServiceError, live_frames, record_live
from spotfree.hand.log import read_hand_log
from spotfree.sim.hand import simulate_hands

HEADER = {"serviceVersion": "2.3.1+33747", "version": 6}


@pytest.fixture(scope="module")
def served():
    return simulate_hands(people=1, seed=8, rounds=1)[:600]


@contextmanager
def fake_service(frames, header=HEADER, refuse=False, send_frames=True):
    """A tracking service on 127.0.0.1 (free port) that streams ``frames`` to a client once it asked for
    background frames, like leapd does for a client without focus; yields (url, messages received)."""
    received: queue.Queue = queue.Queue()

    def handler(connection):
        if refuse or connection.request.path != "/v6.json":
            connection.close(1001, "unsupported protocol version")
            return
        connection.send(json.dumps(header))
        while True:
            message = json.loads(connection.recv(timeout=5))
            received.put(message)
            if "background" in message:
                break
        if not message["background"] or not send_frames:
            for _ in connection:  # no frames for a client in the foreground only, or while no sensor is plugged in
                pass
            return
        connection.send(json.dumps({"event": {"type": "deviceConnect", "state": True}}))
        for frame in frames:
            connection.send(json.dumps(frame_message(frame)))
        connection.close(1000)

    with serve(handler, "127.0.0.1", 0, compression=None) as server:
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        port = server.socket.getsockname()[1]
        try:
            yield f"ws://127.0.0.1:{port}/v6.json", received
        finally:
            server.shutdown()
            thread.join(timeout=5)


def test_the_client_asks_for_background_frames_and_yields_every_frame(served):
    with fake_service(served) as (url, received):
        got = list(live_frames(url, timeout=5))
    assert received.get_nowait() == {"background": True}
    assert len(got) == len(served)
    assert [f.timestamp for f in got] == [f.timestamp for f in served]
    assert [f.truth for f in got] == [f.truth for f in served]
    for a, b in zip(got, served):
        assert len(a.hands) == len(b.hands)
        if b.hands:
            np.testing.assert_allclose(a.hands[0].vector(), b.hands[0].vector(), atol=1e-6)


def test_a_recorded_stream_reads_back_as_a_log(served, tmp_path):
    path = tmp_path / "live.jsonl"
    with fake_service(served) as (url, _):
        count = record_live(path, url, frames=400, timeout=5)
    assert count == 400
    lines = path.read_text().splitlines()
    assert json.loads(lines[0]).get("event")  # written as sent, events included
    rec = read_hand_log(path)
    assert rec.meta["frames"] == 400
    assert rec.time[-1] <= served[399].time + 1e-9


def test_stopping_after_seconds_of_frame_time(served, tmp_path):
    with fake_service(served) as (url, _):
        count = record_live(tmp_path / "short.jsonl", url, seconds=1.0, timeout=5)
    times = np.array([f.time for f in served])
    assert count == np.searchsorted(times, times[0] + 1.0) + 1


def test_a_service_that_refuses_protocol_6_is_named(served):
    with fake_service(served, refuse=True) as (url, _):
        with pytest.raises(TrackingServiceError, match="does not speak protocol 6"):
            next(live_frames(url, timeout=5))


def test_a_server_that_is_not_the_tracking_service_is_named(served):
    with fake_service(served, header={"hello": "world"}) as (url, _):
        with pytest.raises(TrackingServiceError, match="instead of a protocol 6 header"):
            next(live_frames(url, timeout=5))


def test_silence_times_out_with_a_hint(served):
    with fake_service(served, send_frames=False) as (url, _):
        with pytest.raises(TrackingServiceError, match="no message for 0.3 s; is the sensor plugged in"):
            next(live_frames(url, timeout=0.3))


def test_no_service_listening_is_named():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    with pytest.raises(TrackingServiceError, match="cannot connect.*start the hand-tracking service"):
        next(live_frames(f"ws://127.0.0.1:{port}/v6.json", timeout=2))
