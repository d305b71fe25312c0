"""The live ride service: devices stream samples, every ride is classified, assisted and recorded.

:class:`RideService` is what the web API (:mod:`spotfree.ride.api`) calls. Per open ride it keeps a
:class:`~spotfree.ride.live.LiveRide` (features and labels per sample) and an assistant (warnings, speed, distance,
time to the destination). A batch of samples is taken in this order, so that a refused batch changes nothing: (1)
the token must be the one the ride was started with (:class:`~spotfree.ride.store.AccessError`); (2) the batch is
validated as the store validates it (:mod:`spotfree.ride.validation`, InputError); (3) features, labels and
assistant run; (4) samples, features, labels and the events that ended (with the ride's mount events:
:meth:`~spotfree.ride.live.LiveRide.pop_events`) are submitted to the store as one write, which its writer thread
commits together with the other writes pending (group commit, :mod:`spotfree.ride.commit`); (5) once committed, the
result is published to the views. The acknowledgement a device gets is sent after the commit: an acknowledged sample
is on disk. :meth:`RideService.ingest_async` runs (1)-(4) on the event loop and awaits the commit without holding a
thread. A commit that fails (a disk error) is reported to the device, but the ride's filters and assistant have
taken the batch: end that ride and start a new one. Ending a ride closes the assistant's open episodes and records
them.

Credentials (:meth:`RideService.identify`): the operator token (its hash in the store, issued by
:meth:`RideService.new_operator_token`) reads every ride and issues enrolment codes; a device token, got with
such a code (:meth:`RideService.enrol_device`), writes and reads only the rides it started, and a device's view
(:meth:`RideService.watch`) is sent only the messages of those rides.

Quotas per device: a device holds at most :data:`MAX_OPEN_RIDES` open rides (a further start is refused with 429
and what to do, :class:`~spotfree.ride.store.QuotaError`), and its rides share one bucket of ``BACKLOG_SECONDS *
rate`` samples (``rate`` the model's, Hz) refilled at ``RATE_FACTOR * rate`` samples/s; a batch of ``n`` samples
takes ``n`` from it or is refused whole (HTTP 429, with the seconds to wait). A phone streaming at ``rate`` keeps
the bucket full, so the backlog of a disconnect of up to ``BACKLOG_SECONDS`` goes through at once; a longer one is
taken at ``RATE_FACTOR`` times real time. A ride's filters and assistant are made at its first batch (or first
destination) and freed when it ends; a device's bucket is freed once full again.
"""

from __future__ import annotations

import asyncio
import functools
import hmac
import logging
import math
import threading
import time as clock
from time import time as clock_time
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future
from dataclasses import dataclass, field

import numpy as np

from spotfree.classify.batch import dictionary_classifier
from spotfree.errors import InputError, SpotfreeError
from spotfree.model import DictionaryModel
from spotfree.ride import validation
from spotfree.ride.assistant import RideAssistant
from spotfree.ride.live import LiveRide, pipeline_spec
from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS
from spotfree.ride.store import AccessError, DamagedRideError, ForbiddenError, RideStore
from spotfree.ride.tokens import token_hash

_log = logging.getLogger("spotfree.ride")
PLOT_CHANNELS = ("pitch", "pitch_rate", "acc_long")
"""Features sent to the operator view's live plot (rad, rad/s, m/s^2)."""
RATE_FACTOR = 4.0
"""Samples a device may send per second, sustained, in multiples of the model's rate."""
BACKLOG_SECONDS = 60.0
"""Seconds of samples (at the model's rate) a device may send at once: the backlog of a disconnect this long."""
IDLE_SECONDS = 3600.0
"""Seconds without a sample after which an open ride is closed (:meth:`RideService.close_idle_rides`): the
longest pause within a ride (:data:`spotfree.limits.MAX_STEP`)."""
OPERATOR_RECHECK_SECONDS = 5.0
"""Seconds a server trusts the operator token's hash it read from the store before reading it again."""
MAX_OPEN_RIDES = 8
"""Rides one device may hold open at once (a phone rides one at a time; a ride it left open closes after
:data:`IDLE_SECONDS`)."""
DANGEROUS_CLASSES = ("sudden-braking", "sharp-turn", "cobblestone")
"""Classes the rider is warned of when the model has them: a hard stop, a sharp turn, a surface to slow down on."""


class UnavailableError(SpotfreeError):
    """The service cannot take this call now (a ride worker stopped and is being replaced): send it again in
    ``retry_after`` s; nothing of it was acknowledged."""

    retry_after = 1.0


class RateError(InputError):
    """A device sends samples faster than the service takes them; ``retry_after`` s until this batch would fit."""

    def __init__(self, message: str, retry_after: float):
        super().__init__(message)
        self.retry_after = retry_after

    def __reduce__(self):
        return RateError, (str(self), self.retry_after)


class SampleBucket:
    """Token bucket of samples: holds at most ``capacity`` samples, refilled at ``refill`` samples/s, full at
    first (``level(now) = min(capacity, level + refill * (now - last))``)."""

    def __init__(self, capacity: float, refill: float):
        self.capacity, self.refill = capacity, refill
        self.level, self.last = capacity, clock.monotonic()

    def take(self, n: int, what: str) -> None:
        """Take ``n`` samples, or raise :class:`RateError` (InputError for more than ``capacity``: never taken)
        and take nothing."""
        if n > self.capacity:
            raise InputError(f"{what}: {n} samples in one batch; send at most {self.capacity:.0f} per batch")
        now = clock.monotonic()
        self.level, self.last = min(self.capacity, self.level + self.refill * (now - self.last)), now
        if n > self.level:
            wait = (n - self.level) / self.refill
            raise RateError(f"{what}: samples sent faster than {self.refill:g}/s; send this batch again in "
                            f"{wait:.2f} s", retry_after=wait)
        self.level -= n

    def give(self, n: int) -> None:
        """Give back ``n`` samples taken for a batch that was then refused for another reason."""
        self.level = min(self.capacity, self.level + n)

    def full(self, now: float) -> bool:
        """Whether the bucket is full again at ``now`` (``time.monotonic`` s): it holds nothing worth keeping."""
        return self.level + self.refill * (now - self.last) >= self.capacity


def assistant_factory(model: DictionaryModel) -> Callable[[], RideAssistant]:
    """Makes one :class:`RideAssistant` per ride, warning of the model's classes in :data:`DANGEROUS_CLASSES`
    (``sudden-braking`` when it has none)."""
    dangerous = tuple(c for c in DANGEROUS_CLASSES if c in model.classes) or DANGEROUS_CLASSES[:1]
    return functools.partial(RideAssistant, dangerous=dangerous)


OPERATOR, DEVICE = "operator", "device"


@dataclass(frozen=True)
class Identity:
    """Who sent a request: ``role`` :data:`OPERATOR` (reads every ride, issues enrolment codes) or
    :data:`DEVICE` (``device_id``: writes and reads only its own rides); ``token_hash`` of the credential."""

    role: str
    device_id: str | None
    token_hash: str


@dataclass
class _OpenRide:
    """An open ride held by this process: its filters and assistant are made when first used."""

    ride_id: str
    token_hash: str
    new_live: Callable[[], LiveRide]
    new_assistant: Callable[[], RideAssistant]
    last_time: float | None = None
    lock: threading.Lock = field(default_factory=threading.Lock)
    _live: LiveRide | None = None
    _assistant: RideAssistant | None = None

    @property
    def live(self) -> LiveRide:
        if self._live is None:
            self._live = self.new_live()
        return self._live

    @property
    def assistant(self) -> RideAssistant:
        if self._assistant is None:
            self._assistant = self.new_assistant()
        return self._assistant


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
        Makes the :class:`~spotfree.ride.assistant.RideAssistant` of each ride (default
        :func:`assistant_factory` of the model).

    ``spec`` is what the page runs: the pipeline (:func:`~spotfree.ride.live.pipeline_spec`) and, under
    ``warnings``, the assistant's warning rule (``dangerous``, ``min_duration`` and ``refractory`` s).
    """

    def __init__(self, model: DictionaryModel, store: RideStore, model_name: str = "default",
                 assistant: Callable[[], RideAssistant] | None = None):
        self.model = model
        self.assistant = assistant or assistant_factory(model)
        self.store = store
        self.model_name = model_name
        self.classifier = dictionary_classifier(model, causal=True)
        rule = self.assistant()
        self.spec = {**pipeline_spec(model, self.classifier),
                     "warnings": {"dangerous": list(rule.dangerous), "min_duration": rule.min_duration,
                                  "refractory": rule.refractory}}
        self._open: dict[str, _OpenRide] = {}
        self._lock = threading.Lock()
        self._watchers: set[tuple[asyncio.AbstractEventLoop, asyncio.Queue, str | None, str | None]] = set()
        self._owners: dict[str, str] = {}
        self._devices: dict[str, str] = {}
        self._operator_hash = store.operator_token_hash()
        self._operator_read = clock.monotonic()
        self._restoring = threading.Lock()
        self._stopping = threading.Event()
        self._end_listeners: list[Callable[[str], None]] = []
        self._buckets: dict[str, SampleBucket] = {}
        self._buckets_swept = clock.monotonic()

    # ------------------------------------------------------------ credentials

    def identify(self, token: object) -> Identity:
        """Who holds ``token``: the operator, or a device (:class:`AccessError` for no token or an unknown one).
        A device's token, once found in the store, is remembered (device tokens are never revoked while serving);
        the operator token's hash is read from the store again every :data:`OPERATOR_RECHECK_SECONDS`, so that a
        token rotated by another process or server replaces the old one here too."""
        if not isinstance(token, str) or not token:
            raise AccessError("no credential; send 'Authorization: Bearer <token>' (a device's token, or the "
                              "operator token)")
        digest = token_hash(token)
        now = clock.monotonic()
        if now - self._operator_read > OPERATOR_RECHECK_SECONDS:  # rotated by another process or server
            self._operator_hash, self._operator_read = self.store.operator_token_hash(), now
        operator = self._operator_hash
        if operator is not None and hmac.compare_digest(digest, operator):
            return Identity(OPERATOR, None, digest)
        device_id = self._devices.get(digest)
        if device_id is None:
            try:
                device_id = self.store.authenticate(token)
            except AccessError:
                raise AccessError("unknown token; enrol the device with an enrolment code from the operator, "
                                  "or use the operator token") from None
            self._devices[digest] = device_id
        return Identity(DEVICE, device_id, digest)

    def require_operator(self, token: object) -> Identity:
        """:meth:`identify`, refused (:class:`ForbiddenError`) unless the token is the operator's."""
        who = self.identify(token)
        if who.role != OPERATOR:
            raise ForbiddenError("this view needs the operator token; a device token reads only its own rides")
        return who

    def new_operator_token(self) -> str:
        """Issue a new operator token (the previous one stops working at once); shown only now."""
        token = self.store.new_operator_token()
        self._operator_hash = token_hash(token)
        return token

    def issue_enrolment(self, uses: int = 1, ttl: float = 3600.0) -> tuple[str, float]:
        """A new enrolment code (:meth:`~spotfree.ride.store.RideStore.issue_enrolment`)."""
        return self.store.issue_enrolment(uses, ttl)

    def enrol_device(self, code: str, name: str = "") -> tuple[str, str]:
        """``(device_id, token)`` of a new device that gave a valid enrolment code (ForbiddenError otherwise)."""
        return self.store.enrol_device(code, name)

    def readable(self, who: Identity, ride_id: str):
        """The ride's metadata if ``who`` may read it (the operator any ride, a device its own):
        NotFoundError, ForbiddenError otherwise."""
        ride = self.store.ride(ride_id)
        if who.role != OPERATOR and ride.device_id != who.device_id:
            raise ForbiddenError(f"ride {ride_id} belongs to another device; a device token reads only its own "
                                 "rides")
        return ride

    # ------------------------------------------------------------ devices and rides

    def register_device(self, name: str = "") -> tuple[str, str]:
        """``(device_id, token)`` of a new device, without an enrolment code: for code running in the server's
        process (replays, simulations), never for a request."""
        return self.store.register_device(name)

    def start_ride(self, token: str, vehicle: str, rider_id: str, **meta) -> str:
        """Open a ride for the token's device; ``meta``: ``age_band``, ``gender``, ``skill``, ``started`` and
        ``continues_from`` (the id of this device's earlier ride that could not go on:
        :meth:`~spotfree.ride.store.RideStore.start_ride`)."""
        ride_id = self._open_ride(token, vehicle, rider_id, meta)
        with self._lock:
            self._owners[ride_id] = token_hash(token)
        self._publish({"type": "ride", "ride_id": ride_id, "vehicle": vehicle, "rider_id": rider_id}, ride_id)
        return ride_id

    def _open_ride(self, token: str, vehicle: str, rider_id: str, meta: dict) -> str:
        ride_id = self.store.start_ride(token, vehicle, rider_id, model=self.model_name, max_open=MAX_OPEN_RIDES,
                                        **meta)
        with self._lock:
            self._open[ride_id] = self._new_ride(ride_id, token_hash(token))
        return ride_id

    def _new_ride(self, ride_id: str, owner: str) -> _OpenRide:
        return _OpenRide(ride_id, owner, functools.partial(LiveRide, self.model, self.classifier), self.assistant)

    def _take(self, owner: str, n: int, what: str) -> SampleBucket:
        """Take ``n`` samples from the bucket of the device whose token hash is ``owner`` (:class:`RateError`
        when they do not fit); the bucket, for :meth:`SampleBucket.give`. Buckets full again are freed, checked
        at most every ``BACKLOG_SECONDS``."""
        now = clock.monotonic()
        with self._lock:
            if now - self._buckets_swept > BACKLOG_SECONDS:
                self._buckets_swept = now
                self._buckets = {k: b for k, b in self._buckets.items() if not b.full(now)}
            bucket = self._buckets.get(owner)
            if bucket is None:
                bucket = self._buckets[owner] = SampleBucket(BACKLOG_SECONDS * self.model.rate,
                                                             RATE_FACTOR * self.model.rate)
            bucket.take(n, what)
        return bucket

    def on_end(self, listener: Callable[[str], None]) -> None:
        """Call ``listener(ride_id)`` once a ride of this process's service has ended (:meth:`end_ride`) or was
        closed idle (:meth:`close_idle_rides`), in the thread that ended it; it must not raise or block."""
        self._end_listeners.append(listener)

    def _ended(self, ride_id: str, events: list[dict]) -> None:
        """Tell the views and the end listeners that ``ride_id`` ended with ``events``."""
        self._publish({"type": "end", "ride_id": ride_id, "events": events}, ride_id)
        with self._lock:
            self._owners.pop(ride_id, None)
        for listener in self._end_listeners:
            listener(ride_id)

    def set_destination(self, token: str, ride_id: str, lat: float, lon: float) -> None:
        """The rider's destination (WGS-84 degrees) for the time-to-arrival; kept in the store, so that a ride
        rebuilt after a restart (:meth:`_replay`) goes on with it."""
        ride = self._own(token, ride_id)
        for name, value, bound in (("lat", lat, 90), ("lon", lon, 180)):
            if isinstance(value, bool) or not (isinstance(value, (int, float)) and math.isfinite(value)
                                               and abs(value) <= bound):
                raise InputError(f"destination: field {name!r} must be degrees within +-{bound}")
        with ride.lock:
            self.store.set_destination(token, ride_id, float(lat), float(lon))
            ride.assistant.set_destination(float(lat), float(lon))

    def resume(self, token: str, ride_id: str) -> float | None:
        """Check that ``token`` may write to the open ride ``ride_id`` (a device that reconnects); returns the time
        of the last sample recorded (None before the first), after which the device sends on."""
        return self._own(token, ride_id).last_time

    def end_ride(self, token: str, ride_id: str) -> None:
        """Close the ride: its open episodes become events, and the store refuses later samples."""
        self._ended(ride_id, self._close_ride(token, ride_id))

    def _close_ride(self, token: str, ride_id: str) -> list[dict]:
        ride = self._own(token, ride_id)
        with ride.lock:
            ride.assistant.finish()
            events = ride.assistant.pop_events()
            for event in events:
                self.store.add_event(token, ride_id, event)
            self.store.end_ride(token, ride_id)
            with self._lock:
                self._open.pop(ride_id, None)
        return [vars(e) for e in events]

    def keep_tidy(self, every: float = IDLE_SECONDS / 6) -> None:
        """Close idle rides now (:meth:`close_idle_rides`) and then every ``every`` s in a daemon thread, until
        :meth:`close`; a round that fails is logged (``spotfree.ride``) and the thread goes on."""
        self.close_idle_rides()

        def loop() -> None:
            while not self._stopping.wait(every):
                try:
                    self.close_idle_rides()
                except SpotfreeError:  # a store error now: tried again next round
                    pass
                except Exception:  # noqa: BLE001 - any other fault is logged; the next round runs all the same
                    _log.exception("closing idle rides failed; tried again in %g s", every)
        threading.Thread(target=loop, name="spotfree-idle-rides", daemon=True).start()

    def close(self) -> None:
        """Close the store (after committing what is queued)."""
        self._stopping.set()
        self.store.close()

    def open_rides(self) -> list[str]:
        with self._lock:
            return list(self._open)

    def open_rides_for(self, who: Identity) -> list[str]:
        """The open rides ``who`` may know of: every one for the operator, for a device those its token started."""
        rides = self.open_rides()
        if who.role == OPERATOR:
            return rides
        with self._lock:
            return [r for r in rides if self._owners.get(r) == who.token_hash]

    def health(self) -> dict:
        """``status`` (``"ok"``, or ``"degraded"`` while a ride worker is down), ``open_rides`` and, with worker
        processes, one ``{"index", "alive", "rides"}`` per worker and the ``restarts`` so far."""
        return {"status": "ok", "open_rides": len(self.open_rides()), "workers": [], "restarts": 0}

    # ------------------------------------------------------------ samples

    def ingest(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]],
               check_rate: bool = True) -> dict:
        """Take one batch (columns of :data:`SAMPLE_COLUMNS`, see the module docstring); returns the
        acknowledgement once the batch is committed: ``count``, ``labels`` (one per sample), ``state`` (the
        assistant's figures after the last sample: :meth:`~spotfree.ride.assistant.Status.figures`),
        ``warnings`` (raised in this batch: ``kind``, ``onset``, ``time`` s) and ``events`` (ended in this batch:
        ``kind``, ``start``, ``end`` s, ``detail``; kinds ``mount``, ``unusual-mount``, ``uncertain-mount``
        for what the ride found of its mount).
        ``check_rate=False`` skips the rate limit (for in-process sources only)."""
        ack, message = self._submit(token, ride_id, samples, check_rate, bool(self._watchers)).result()
        return self._acknowledge(ack, message, ride_id)

    async def ingest_async(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]]) -> dict:
        """:meth:`ingest` on the event loop: the batch is classified at once, and the commit is awaited without
        holding a thread, so that many devices' batches share one commit (:mod:`spotfree.ride.commit`). A ride
        this process does not hold yet (after a restart) is rebuilt from the store in a thread first."""
        if not self._holds(ride_id):  # rebuilt from the store in a thread, not on the loop
            await asyncio.to_thread(self._own, token, ride_id)
        ack, message = await asyncio.wrap_future(self._submit(token, ride_id, samples, True, bool(self._watchers)))
        return self._acknowledge(ack, message, ride_id)

    def _submit(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]], check_rate: bool,
                describe: bool) -> Future:
        """Check, classify and assist one batch (refusals raise here), and submit it to the store; a future of
        ``(ack, message for the views)`` (the message None unless ``describe``), resolved once committed. Under
        the ride's lock, so its batches reach the store in order."""
        ride = self._own(token, ride_id)
        with ride.lock:
            table = validation.sample_batch(samples, ride.last_time, f"ride {ride_id}")
            if check_rate:
                self._take(ride.token_hash, len(table), f"ride {ride_id} (its device's rides together)")
            n = len(table)
            feats, labels = ride.live.update_block(table)
            warnings = [vars(w) for w in ride.assistant.update_block(table[:, _ASSISTED].tolist(), labels)]
            events = ride.live.pop_events() + ride.assistant.pop_events()
            committed = self.store.submit_samples(token, ride_id, table, features=feats,
                                                  labels={self.model_name: labels}, events=events)
            ride.last_time = float(table[-1, 0])
            state = ride.assistant.state()
        ended = [vars(e) for e in events]
        ack = {"count": n, "labels": labels, "state": state, "warnings": warnings, "events": ended}
        message = None
        if describe:
            plot = {name: _json_floats(feats[:, FEATURE_COLUMNS.index(name)]) for name in PLOT_CHANNELS}
            message = {"type": "samples", "ride_id": ride_id, "time": _json_floats(table[:, 0]),
                       "lat": _json_floats(table[:, 7]), "lon": _json_floats(table[:, 8]), **plot, **ack}
        done: Future = Future()

        def settle(commit: Future) -> None:
            failure = commit.exception()
            if failure is not None:
                done.set_exception(failure)
            else:
                done.set_result((ack, message))
        committed.add_done_callback(settle)
        return done

    def _acknowledge(self, ack: dict, message: dict | None, ride_id: str) -> dict:
        """``ack`` after its batch committed, published to the views first."""
        if message is not None:
            self._publish(message, ride_id)
        return ack

    def _holds(self, ride_id: str) -> bool:
        """Whether a call on ``ride_id`` finds its state here at once (else :meth:`_own` rebuilds it)."""
        with self._lock:
            return ride_id in self._open

    def _own(self, token: str, ride_id: str) -> _OpenRide:
        with self._lock:
            ride = self._open.get(ride_id)
        if ride is None:
            ride = self._restore(token, ride_id)
        if not isinstance(token, str) or token_hash(token) != ride.token_hash:
            raise AccessError(f"this device token may not write to ride {ride_id}; use the token that started it")
        return ride

    def _restore(self, token: str, ride_id: str) -> _OpenRide:
        """An open ride of the store that this process does not hold (the server restarted, or the worker that
        held it died), rebuilt by replaying its stored samples; refused (NotFoundError, ForbiddenError) for an
        unknown ride, one that has ended, or a token not its device's."""
        record = self.store.ride(ride_id)  # NotFoundError for an unknown id
        if record.ended is not None:
            raise ForbiddenError(f"ride {ride_id} is not open (it has ended); start a new ride")
        if self.identify(token).device_id != record.device_id:
            raise AccessError(f"this device token may not write to ride {ride_id}; use the token that started it")
        with self._restoring:
            with self._lock:
                ride = self._open.get(ride_id)
            if ride is None:
                ride = self._replay(ride_id, token_hash(token))
                with self._lock:
                    self._open[ride_id] = ride
                    self._owners[ride_id] = ride.token_hash
        return ride

    def _replay(self, ride_id: str, owner: str) -> _OpenRide:
        """The state of an open ride rebuilt from the store: its stored samples run through a new
        :class:`LiveRide` and assistant in blocks (the same mount, labels and episodes as when they came, since
        blocks and single samples give the same results); the events that ended then are already stored and are
        dropped. The device's rate bucket is the service's; the destination kept in the store is set again."""
        columns = self.store.samples(ride_id)
        table = np.column_stack([np.asarray(columns[c], dtype=float) for c in SAMPLE_COLUMNS])
        ride = self._new_ride(ride_id, owner)
        for start in range(0, len(table), _REPLAY_BLOCK):
            block = table[start:start + _REPLAY_BLOCK]
            _, labels = ride.live.update_block(block)
            ride.assistant.update_block(block[:, _ASSISTED].tolist(), labels)
            ride.live.pop_events()
            ride.assistant.pop_events()
        ride.last_time = float(table[-1, 0]) if len(table) else None
        destination = self.store.destination(ride_id)
        if destination is not None:
            ride.assistant.set_destination(*destination)
        return ride

    def close_idle_rides(self, idle: float = IDLE_SECONDS, now: float | None = None) -> list[str]:
        """Close every open ride with no sample for more than ``idle`` s (:data:`IDLE_SECONDS`; UNIX ``now``):
        its open episodes become events, ``ended`` is the time of its last sample, and the views are told. Returns
        their ids. :meth:`keep_tidy` runs this while serving, for the rides this process holds and for those only
        the store holds (left open by an earlier run); a :class:`~spotfree.ride.pool.RideServicePool` has each
        worker close its own."""
        now = clock_time() if now is None else now
        stale = [(ride_id, last) for ride_id, last in self.store.open_ride_activity() if now - last > idle]
        closed = self._close_stale(stale)
        for ride_id, events in closed.items():
            self._ended(ride_id, events)
        return list(closed)

    def _close_stale(self, stale: list[tuple[str, float]]) -> dict[str, list[dict]]:
        """Close the rides of ``(ride_id, UNIX s of its last activity)`` in this process (each rebuilt from the
        store when not held): ``{ride_id: its events as dicts}`` of those that were still open."""
        closed = {}
        for ride_id, last in stale:
            with self._lock:
                ride = self._open.pop(ride_id, None)
            if ride is None:
                try:
                    ride = self._replay(ride_id, "")
                except DamagedRideError as exc:  # closed as it is, without the episodes a replay would end
                    _log.warning("closing idle ride %s without replaying it: %s", ride_id, exc)
                    if self.store.close_idle_ride(ride_id, max(last, self.store.ride(ride_id).started), []):
                        closed[ride_id] = []
                    continue
            with ride.lock:
                ride.assistant.finish()
                events = ride.assistant.pop_events()
                if self.store.close_idle_ride(ride_id, max(last, self.store.ride(ride_id).started), events):
                    closed[ride_id] = [vars(e) for e in events]
        return closed

    # ------------------------------------------------------------ views

    def watch(self, ride_id: str | None = None, who: Identity | None = None) -> asyncio.Queue:
        """A queue of the messages published for ``ride_id`` (all rides when None), on the calling loop; for a
        device (``who``), only those of the rides its token started."""
        queue: asyncio.Queue = asyncio.Queue(maxsize=1000)
        owner = who.token_hash if who is not None and who.role == DEVICE else None
        self._watchers.add((asyncio.get_running_loop(), queue, ride_id, owner))
        return queue

    def unwatch(self, queue: asyncio.Queue) -> None:
        self._watchers = {w for w in self._watchers if w[1] is not queue}

    def _publish(self, message: dict, ride_id: str) -> None:
        owner = self._owners.get(ride_id)
        for loop, queue, wanted, device in list(self._watchers):
            if (wanted is None or wanted == ride_id) and (device is None or device == owner):
                loop.call_soon_threadsafe(_offer, queue, message)


_REPLAY_BLOCK = 256
"""Rows per block when a ride is rebuilt: short enough that the thread rebuilding it lets the event loop run
between blocks (each block holds the interpreter while it is classified)."""
_ASSISTED = [SAMPLE_COLUMNS.index(c) for c in ("time", "lat", "lon", "speed")]
"""The sample columns the assistant takes."""


def _offer(queue: asyncio.Queue, message: dict) -> None:
    """Put ``message`` on a view's queue; a view too slow to keep up loses its oldest message."""
    if queue.full():
        queue.get_nowait()
    queue.put_nowait(message)


def _json_floats(values: np.ndarray) -> list[float | None]:
    """Floats for JSON, None for NaN."""
    return [None if not math.isfinite(v) else round(float(v), 6) for v in values]
