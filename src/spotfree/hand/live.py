"""Live client of the hand-tracking service's WebSocket stream (Leap Motion ``leapd``, Ultraleap's WebSocket server).
It needs ``websockets``, of the ``serve`` extra.

Protocol (leapjs ``PROTOCOL.md`` and ``lib/connection/base.js``): the client opens ``ws://127.0.0.1:6437/v6.json``
(the digit selects the protocol version); the service answers with a header ``{"serviceVersion": ..., "version":
6}``, or closes with code 1001 when it does not speak that version. The client then says ``{"background": true}``
(frames even while another application has the input focus; the user may have to allow background applications in
the service's control panel) and ``{"optimizeHMD": false}`` (the sensor lies face up, not on a headset). From then
on every message is a frame or an event ``{"event": {...}}``. The service's own gestures (circle, swipe, taps) stay
off, as they are unless a client sends ``{"enableGestures": true}``.

>>> for frame in live_frames():            # doctest: +SKIP
...     print(frame.time, len(frame.hands))
"""

from __future__ import annotations

import json
from contextlib import closing
from pathlib import Path
from typing import Iterator

from websockets.exceptions import ConnectionClosed, InvalidHandshake, InvalidURI
from websockets.sync.client import connect

from spotfree.errors import SpotfreeError
from spotfree.hand.frames import HandFrame, is_frame, parse_frame

DEFAULT_URL = "ws://127.0.0.1:6437/v6.json"
PROTOCOL_VERSION = 6
TIMEOUT = 5.0
"""s to wait for the header or a frame before giving up."""


class TrackingServiceError(SpotfreeError, ConnectionError):
    """The tracking service cannot be reached, does not speak the protocol, or sends nothing."""


def live_messages(url: str = DEFAULT_URL, background: bool = True, timeout: float = TIMEOUT) -> Iterator[str]:
    """Every message of the service after the handshake, as the JSON text it sent (frames and events).

    The connection closes when the iterator is closed or exhausted; the iterator ends when the service closes the
    connection normally. A connection that cannot be opened, a refused protocol version, or ``timeout`` s without
    a message raise :class:`TrackingServiceError`.
    """
    try:
        socket = connect(url, open_timeout=timeout, close_timeout=1.0, proxy=None, compression=None)
    except (OSError, InvalidHandshake, InvalidURI, TimeoutError) as exc:
        raise TrackingServiceError(
            f"{url}: cannot connect ({exc}); start the hand-tracking service or check the address"
        ) from None
    with socket:
        _handshake(socket, url, background, timeout)
        while True:
            try:
                text = socket.recv(timeout=timeout)
            except TimeoutError:
                raise TrackingServiceError(
                    f"{url}: no message for {timeout:g} s; is the sensor plugged in (and background frames allowed)?"
                ) from None
            except ConnectionClosed as exc:
                if exc.rcvd is not None and exc.rcvd.code in (1000, 1001):
                    return
                raise TrackingServiceError(f"{url}: the connection broke ({exc})") from None
            yield text if isinstance(text, str) else text.decode("utf-8", errors="replace")


def live_frames(url: str = DEFAULT_URL, background: bool = True, timeout: float = TIMEOUT) -> Iterator[HandFrame]:
    """The service's frames as :class:`~spotfree.hand.frames.HandFrame` objects, as they arrive (events skipped)."""
    with closing(live_messages(url, background, timeout)) as messages:
        for k, text in enumerate(messages, start=1):
            message = _decode(text, url)
            if not isinstance(message, dict) or is_frame(message):
                yield parse_frame(message, f"{url}, message {k}")


def record_live(
    path: str | Path, url: str = DEFAULT_URL, frames: int | None = None, seconds: float | None = None,
    background: bool = True, timeout: float = TIMEOUT,
) -> int:
    """Write the service's messages to ``path`` as JSON lines, as sent, until ``frames`` frames or ``seconds`` s of
    frame time (whichever comes first; neither: until the service closes). Returns the number of frames written.
    Each line is flushed, so a log cut by a crash loses at most its last line."""
    count, start = 0, None
    with open(path, "w", encoding="utf-8") as log, closing(live_messages(url, background, timeout)) as messages:
        for k, text in enumerate(messages, start=1):
            message = _decode(text, url)
            log.write(text.strip() + "\n")
            log.flush()
            if not isinstance(message, dict) or is_frame(message):
                count += 1
                stamp = parse_frame(message, f"{url}, message {k}").time
                start = stamp if start is None else start
                if (frames is not None and count >= frames) or (seconds is not None and stamp - start >= seconds):
                    break
    return count


def _handshake(socket, url: str, background: bool, timeout: float) -> None:
    """Check the service's version header, then ask for background frames in desktop mode."""
    try:
        header = _decode(socket.recv(timeout=timeout), url)
    except TimeoutError:
        raise TrackingServiceError(
            f"{url}: no version header within {timeout:g} s; is this the hand-tracking service?"
        ) from None
    except ConnectionClosed as exc:
        refused = exc.rcvd is not None and exc.rcvd.code == 1001
        hint = f"; the service does not speak protocol {PROTOCOL_VERSION}" if refused else ""
        raise TrackingServiceError(f"{url}: closed before the version header ({exc}){hint}") from None
    if not isinstance(header, dict) or header.get("version") != PROTOCOL_VERSION:
        raise TrackingServiceError(
            f"{url}: the service answered {header!r} instead of a protocol {PROTOCOL_VERSION} header; "
            f"connect to a /v{PROTOCOL_VERSION}.json address of a Leap Motion or Ultraleap service"
        )
    socket.send(json.dumps({"background": background}))
    socket.send(json.dumps({"optimizeHMD": False}))


def _decode(text: str | bytes, url: str) -> object:
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise TrackingServiceError(f"{url}: the service sent a message that is not JSON ({exc.msg})") from None
