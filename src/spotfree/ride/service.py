"""The live ride service: devices stream samples, every ride is classified, assisted and recorded.

:class:`RideService` is what the web API (:mod:`spotfree.ride.api`) calls. Per open ride it keeps a
:class:`~spotfree.ride.live.LiveRide` (features and labels per sample) and an assistant (warnings, speed,
distance, time to the destination). A batch of samples is taken in this order, so that a refused batch changes
nothing: (1) the token must be the one the ride was started with (:class:`~spotfree.ride.store.AccessError`);
(2) the batch is validated as the store validates it (:mod:`spotfree.ride.validation`, InputError); (3) features,
labels and assistant run; (4) samples, features, labels and events are committed to the store; (5) the result is
published to the views. The acknowledgement a device gets is sent after (4): an acknowledged sample is on disk.
"""

from __future__ import annotations

import asyncio
import math
import threading
import time as clock
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from spotfree.classify.batch import dictionary_classifier
from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.ride import validation
from spotfree.ride.live import LiveRide, pipeline_spec
from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS
from spotfree.ride.store import AccessError, RideStore
from spotfree.ride.tokens import token_hash

PLOT_CHANNELS = ("pitch", "pitch_rate", "acc_long")
"""Features sent to the operator view's live plot (rad, rad/s, m/s^2)."""
MAX_BATCHES_PER_SECOND = 50.0
"""A device sending batches faster than this (averaged over a second) is refused (HTTP 429)."""


class RateError(InputError):
    """A device sends batches faster than :data:`MAX_BATCHES_PER_SECOND`."""


@dataclass
class _OpenRide:
    ride_id: str
    token_hash: str
    live: LiveRide
    assistant: object | None
    last_time: float | None = None
    speed: float | None = None
    batches: list[float] = field(default_factory=list)
    lock: threading.Lock = field(default_factory=threading.Lock)


class RideService:
    """Live rides of one model over one store (see the module docstring).

    Parameters
    ----------
    model : DictionaryModel
        A model of ride features (CRC_RLS is run on it, on the server and in the page).
    store : RideStore
    model_name : str
        The name the labels are stored under.
    assistant : callable, optional
        Makes one assistant per ride: an object with ``update(t, label, lat, lon, speed) -> [warning, ...]``
        (a warning has ``kind``, ``time``, ``detail``), ``set_destination(lat, lon)``, ``state() -> dict``
        (``speed`` m/s, ``distance`` m, ``eta`` s) and ``pop_events() -> [Event, ...]``. Without one the
        acknowledgement's state holds the last GPS speed only and no warning is raised.
    """

    def __init__(self, model: DictionaryModel, store: RideStore, model_name: str = "default", assistant=None):
        self.model = model
        self.assistant = assistant
        self.store = store
        self.model_name = model_name
        self.classifier = dictionary_classifier(model, "crc")
        self.spec = pipeline_spec(model, self.classifier)
        self._open: dict[str, _OpenRide] = {}
        self._lock = threading.Lock()
        self._watchers: set[tuple[asyncio.AbstractEventLoop, asyncio.Queue, str | None]] = set()

    # ------------------------------------------------------------ devices and rides

    def register_device(self, name: str = "") -> tuple[str, str]:
        """``(device_id, token)`` of a new device."""
        return self.store.register_device(name)

    def start_ride(self, token: str, vehicle: str, rider_id: str, **meta) -> str:
        """Open a ride for the token's device; ``meta``: ``age_band``, ``gender``, ``skill``, ``started``."""
        ride_id = self.store.start_ride(token, vehicle, rider_id, model=self.model_name, **meta)
        with self._lock:
            self._open[ride_id] = _OpenRide(ride_id, token_hash(token), LiveRide(self.model, self.classifier),
                                            self.assistant() if self.assistant else None)
        self._publish({"type": "ride", "ride_id": ride_id, "vehicle": vehicle, "rider_id": rider_id}, ride_id)
        return ride_id

    def set_destination(self, token: str, ride_id: str, lat: float, lon: float) -> None:
        """The rider's destination (degrees) for the time-to-arrival."""
        ride = self._own(token, ride_id)
        for name, value, bound in (("lat", lat, 90), ("lon", lon, 180)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and abs(value) <= bound):
                raise InputError(f"destination: field {name!r} must be degrees within +-{bound}")
        if ride.assistant is None:
            raise InputError("destination: this server runs without an assistant; no time to arrival")
        ride.assistant.set_destination(float(lat), float(lon))

    def resume(self, token: str, ride_id: str) -> float | None:
        """Check that ``token`` may write to the open ride ``ride_id`` (a device that reconnects); returns the time
        of the last sample recorded (None before the first), after which the device sends on."""
        return self._own(token, ride_id).last_time

    def end_ride(self, token: str, ride_id: str) -> None:
        """Close the ride: the store refuses later samples."""
        self._own(token, ride_id)
        self.store.end_ride(token, ride_id)
        with self._lock:
            self._open.pop(ride_id, None)
        self._publish({"type": "end", "ride_id": ride_id}, ride_id)

    def open_rides(self) -> list[str]:
        with self._lock:
            return list(self._open)

    # ------------------------------------------------------------ samples

    def ingest(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]]) -> dict:
        """Take one batch (columns of :data:`SAMPLE_COLUMNS`, see the module docstring); returns the
        acknowledgement: ``count``, ``labels`` (one per sample), ``state`` (the assistant's figures after the
        last sample) and ``warnings`` (warnings raised in this batch)."""
        ride = self._own(token, ride_id)
        with ride.lock:
            self._check_rate(ride)
            table = validation.sample_batch(samples, ride.last_time, f"ride {ride_id}")
            n = len(table)
            feats = np.empty((n, len(FEATURE_COLUMNS)))
            labels: list[str | None] = []
            warnings = []
            for k, row in enumerate(table):
                t, acc, gyr, (lat, lon, speed) = row[0], row[1:4], row[4:7], row[7:10]
                feats[k], label = ride.live.update(t, acc, gyr, speed)
                labels.append(label)
                if ride.assistant is not None:
                    warnings += ride.assistant.update(t, label, lat, lon, speed)
                elif math.isfinite(speed):
                    ride.speed = float(speed)
            columns = {name: table[:, j] for j, name in enumerate(SAMPLE_COLUMNS)}
            self.store.append_samples(token, ride_id, columns, features=dict(zip(FEATURE_COLUMNS, feats.T)),
                                      labels={self.model_name: labels})
            for event in ride.assistant.pop_events() if ride.assistant is not None else []:
                self.store.add_event(token, ride_id, event)
            ride.last_time = float(table[-1, 0])
        state = ride.assistant.state() if ride.assistant is not None else {"speed": ride.speed}
        warned = [vars(w) for w in warnings]
        plot = {name: _json_floats(feats[:, FEATURE_COLUMNS.index(name)]) for name in PLOT_CHANNELS}
        self._publish({"type": "samples", "ride_id": ride_id, "time": _json_floats(table[:, 0]),
                       "lat": _json_floats(table[:, 7]), "lon": _json_floats(table[:, 8]), **plot,
                       "labels": labels, "state": state, "warnings": warned}, ride_id)
        return {"count": n, "labels": labels, "state": state, "warnings": warned}

    def _own(self, token: str, ride_id: str) -> _OpenRide:
        with self._lock:
            ride = self._open.get(ride_id)
        if ride is None:
            self.store.ride(ride_id)  # NotFoundError for an unknown id
            raise AccessError(f"ride {ride_id} is not open on this server; start a new ride")
        if not isinstance(token, str) or token_hash(token) != ride.token_hash:
            raise AccessError(f"this device token may not write to ride {ride_id}; use the token that started it")
        return ride

    @staticmethod
    def _check_rate(ride: _OpenRide) -> None:
        now = clock.monotonic()
        ride.batches = [s for s in ride.batches if now - s < 1.0]
        if len(ride.batches) >= MAX_BATCHES_PER_SECOND:
            raise RateError(f"ride {ride.ride_id}: more than {MAX_BATCHES_PER_SECOND:g} batches in one second; "
                            "send larger batches less often")
        ride.batches.append(now)

    # ------------------------------------------------------------ views

    def watch(self, ride_id: str | None = None) -> asyncio.Queue:
        """A queue of the messages published for ``ride_id`` (all rides when None), on the calling loop."""
        queue: asyncio.Queue = asyncio.Queue(maxsize=1000)
        self._watchers.add((asyncio.get_running_loop(), queue, ride_id))
        return queue

    def unwatch(self, queue: asyncio.Queue) -> None:
        self._watchers = {w for w in self._watchers if w[1] is not queue}

    def _publish(self, message: dict, ride_id: str) -> None:
        for loop, queue, wanted in list(self._watchers):
            if wanted is None or wanted == ride_id:
                loop.call_soon_threadsafe(_offer, queue, message)


def _offer(queue: asyncio.Queue, message: dict) -> None:
    """Put ``message`` on a view's queue; a view too slow to keep up loses its oldest message."""
    if queue.full():
        queue.get_nowait()
    queue.put_nowait(message)


def _json_floats(values: np.ndarray) -> list[float | None]:
    """Floats for JSON, None for NaN."""
    return [None if not math.isfinite(v) else round(float(v), 6) for v in values]
