"""The ride store: every ride's metadata, raw samples, features, labels and events, in SQLite or PostgreSQL.

``RideStore("rides.db")`` opens (or creates) a single SQLite file; ``RideStore("postgresql://user@host/db")``
uses a PostgreSQL server through psycopg 3 (:mod:`spotfree.ride.postgres`). Both hold the same tables:

* ``devices``: ``device_id``, ``name``, ``token_hash`` (SHA-256 of the device's token, :mod:`.tokens`), ``created``;
* ``rides``: :class:`~spotfree.ride.records.Ride` (ids, vehicle, rider, optional rider descriptors, start and end
  in UNIX seconds, model);
* ``sample_blocks``: a row per batch of raw samples (:data:`~spotfree.ride.records.SAMPLE_COLUMNS`) with their
  features (:data:`~spotfree.ride.records.FEATURE_COLUMNS`), ``label_blocks``: a row per batch of one model's
  labels, read back as one column per model name (the layout: :mod:`.blocks`);
* ``events``: :class:`~spotfree.ride.records.Event` rows, one per ``(ride, kind, start)``;
* ``enrolments``: the SHA-256 of each enrolment code an operator issued, when it expires (UNIX s) and how many
  more devices it may enrol; ``meta`` holds the SHA-256 of the operator token (``operator_token_hash``).

Enrolment: a device gets its token from :meth:`RideStore.enrol_device` only with a code that
:meth:`RideStore.issue_enrolment` gave the operator (:meth:`RideStore.register_device` is for code that runs in
the server's own process: replays, simulations, imports).

Writing needs the device's token: a device writes only to the rides it started, and only while they are open.
Every write is one transaction: a batch is validated as a whole first (:mod:`.validation`), and a batch that
fails any check changes nothing.

Writes go through one writer thread that commits every write pending in one transaction (group commit,
:mod:`.commit`), each write inside its own savepoint: concurrent writers share an fsync, and a write that fails
alone changes nothing. ``submit_samples`` queues a batch and returns a future instead of waiting, for callers that
wait on many batches at once (the live service).

Durability: a write method returns (a submitted future resolves) only after the transaction holding it has
committed. SQLite runs in WAL mode with
``synchronous=FULL``, so a commit is on disk (fsync of the WAL) before the method returns: an acknowledged
sample survives the process being killed and the machine losing power; ``synchronous="normal"`` survives the
process being killed only (the WAL is written but fsync'd at checkpoints), for several times the commit rate.
PostgreSQL commits are durable under its default ``synchronous_commit=on``.

One store object may be shared between threads: its calls are serialised on one connection.
"""

from __future__ import annotations

import contextlib
import os
import sqlite3
import threading
import time as clock
import uuid
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Future
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from spotfree.errors import InputError, SpotfreeError
from spotfree.ride import blocks, validation
from spotfree.ride.commit import GroupCommit
from spotfree.ride.redact import redact_location
from spotfree.ride.records import FEATURE_COLUMNS, RIDER_FIELDS, SAMPLE_COLUMNS, Event, Ride
from spotfree.ride.tokens import new_token, token_hash

MAX_ENROLMENT_USES = 1000
"""Devices one enrolment code may enrol at most."""
MAX_ENROLMENT_TTL = 7 * 86400.0
"""Seconds an enrolment code may stay valid at most."""
ENROLMENT_CODE_BYTES = 9
"""Random bytes of an enrolment code (12 characters to type; it is short-lived and limited in uses)."""
_OPERATOR_KEY = "operator_token_hash"
_RIDE_FIELDS = ("ride_id", "device_id", "vehicle", "rider_id", "started", "ended", "model", *RIDER_FIELDS,
                "continues_from")


class AccessError(SpotfreeError, PermissionError):
    """A token that belongs to no device, or a device writing to a ride that is not its own."""


class ForbiddenError(AccessError):
    """A known credential asking for what it may not have: another device's ride, an operator's view, or an
    enrolment code that is unknown, used up or expired."""


class NotFoundError(InputError, LookupError):
    """A ride id that the store does not hold."""


class DamagedRideError(InputError):
    """A ride whose stored blocks cannot be decoded (a damaged or hand-edited store): that ride is unreadable,
    the others are not."""


class QuotaError(InputError):
    """A device asking for more than its share: more open rides than it may hold at once."""


class RideStore:
    """Record rides and read them back (see the module docstring).

    Parameters
    ----------
    location : str or Path
        A SQLite file path (created when missing) or a ``postgresql://`` URL. ``name`` is the location as it may
        be shown (its password hidden, :func:`~spotfree.ride.redact.redact_location`); messages name only that.
    synchronous : str
        SQLite only: ``"full"`` (default: a commit survives a power loss) or ``"normal"`` (a commit survives the
        process being killed, not the machine going down).
    lock : lock, optional
        Held around each write transaction, e.g. a ``multiprocessing.Lock`` shared by processes that write one
        SQLite file: they then queue on it instead of polling SQLite's busy lock (which sleeps 1, 2, 5, 10 ... ms
        between tries).
    """

    def __init__(self, location: str | Path, synchronous: str = "full", lock=None):
        self.location = str(location)
        self.name = redact_location(self.location)
        if synchronous not in ("full", "normal"):
            raise InputError(f"synchronous={synchronous!r}: use 'full' or 'normal'")
        self.synchronous = synchronous
        if self.location.startswith(("postgresql://", "postgres://")):
            from spotfree.ride.postgres import PostgresConnection

            self._db = PostgresConnection(self.location)
        else:
            self._db = SQLiteConnection(self.location, synchronous)
        self._lock = threading.RLock()
        self._process_lock = lock if lock is not None else contextlib.nullcontext()
        self._writer = GroupCommit(self._transaction)
        with self._transaction() as db:
            self._feature_set = _open_schema(db)
        version = self._query("SELECT value FROM meta WHERE key = ?", ("schema_version",))[0][0]
        if int(version) != blocks.SCHEMA_VERSION:
            raise InputError(f"{self.name}: ride store schema version {version}, this spotfree reads "
                             f"{blocks.SCHEMA_VERSION}; open it with a matching spotfree version")

    def close(self) -> None:
        """Commit the writes still queued, then close the connection (SQLite: after a checkpoint that folds the
        WAL into the database file)."""
        self._writer.close()
        with self._lock:
            self._db.close()

    def __enter__(self) -> "RideStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------ devices

    def register_device(self, name: str = "") -> tuple[str, str]:
        """A new device: ``(device_id, token)``. The token is shown only now; the store keeps its hash."""
        name = validation.text(name, "device", "name", required=False) or ""
        device_id, token = uuid.uuid4().hex, new_token()
        self._write(lambda db: db.execute(
            "INSERT INTO devices (device_id, name, token_hash, created) VALUES (?, ?, ?, ?)",
            (device_id, name, token_hash(token), clock.time())))
        return device_id, token

    def enrol_device(self, code: str, name: str = "") -> tuple[str, str]:
        """:meth:`register_device` for the holder of an enrolment code (:meth:`issue_enrolment`), which then has
        one use fewer; :class:`ForbiddenError` for a code unknown, used up or expired (nothing is written)."""
        if not isinstance(code, str) or not 0 < len(code) <= validation.MAX_TEXT:
            raise ForbiddenError("no enrolment code; ask the operator for one (operator view, 'New enrolment code')")
        name = validation.text(name, "device", "name", required=False) or ""
        device_id, token = uuid.uuid4().hex, new_token()

        def write(db) -> None:
            row = db.execute("SELECT expires, uses FROM enrolments WHERE code_hash = ?",
                             (token_hash(code),)).fetchone()
            if row is None or row[0] < clock.time() or row[1] < 1:
                raise ForbiddenError("enrolment code unknown, used up or expired; ask the operator for a new one")
            db.execute("UPDATE enrolments SET uses = uses - 1 WHERE code_hash = ?", (token_hash(code),))
            db.execute("INSERT INTO devices (device_id, name, token_hash, created) VALUES (?, ?, ?, ?)",
                       (device_id, name, token_hash(token), clock.time()))
        self._write(write)
        return device_id, token

    def issue_enrolment(self, uses: int = 1, ttl: float = 3600.0) -> tuple[str, float]:
        """A new enrolment code for ``uses`` devices (1 to :data:`MAX_ENROLMENT_USES`) within ``ttl`` s (1 s to
        :data:`MAX_ENROLMENT_TTL`): ``(code, expires)`` with ``expires`` in UNIX s. The code is shown only now;
        the store keeps its hash. Expired codes are deleted."""
        if isinstance(uses, bool) or not isinstance(uses, int) or not 1 <= uses <= MAX_ENROLMENT_USES:
            raise InputError(f"enrolment: field 'uses' must be a whole number from 1 to {MAX_ENROLMENT_USES}")
        if isinstance(ttl, bool) or not isinstance(ttl, (int, float)) or not 1 <= ttl <= MAX_ENROLMENT_TTL:
            raise InputError(f"enrolment: field 'ttl' must be seconds from 1 to {MAX_ENROLMENT_TTL:g}")
        code, now = new_token(ENROLMENT_CODE_BYTES), clock.time()
        expires = now + float(ttl)

        def write(db) -> None:
            db.execute("DELETE FROM enrolments WHERE expires < ?", (now,))
            db.execute("INSERT INTO enrolments (code_hash, expires, uses) VALUES (?, ?, ?)",
                       (token_hash(code), expires, uses))
        self._write(write)
        return code, expires

    def new_operator_token(self) -> str:
        """A new operator token (any earlier one stops working); shown only now, the store keeps its hash."""
        token = new_token()
        self._write(lambda db: db.execute(
            "INSERT INTO meta (key, value) VALUES (?, ?) ON CONFLICT (key) DO UPDATE SET value = excluded.value",
            (_OPERATOR_KEY, token_hash(token))))
        return token

    def operator_token_hash(self) -> str | None:
        """The SHA-256 of the operator token (None before :meth:`new_operator_token` was first called)."""
        rows = self._query("SELECT value FROM meta WHERE key = ?", (_OPERATOR_KEY,))
        return rows[0][0] if rows else None

    def authenticate(self, token: str) -> str:
        """The id of the device that holds ``token``; :class:`AccessError` when none does."""
        if not isinstance(token, str) or not token:
            raise AccessError("no device token; send the token given when the device was registered")
        rows = self._query("SELECT device_id FROM devices WHERE token_hash = ?", (token_hash(token),))
        if not rows:
            raise AccessError("unknown device token; register the device to get a valid token")
        return rows[0][0]

    # ------------------------------------------------------------ writing

    def start_ride(self, token: str, vehicle: str, rider_id: str, *, model: str | None = None,
                   age_band: str | None = None, gender: str | None = None, skill: str | None = None,
                   started: float | None = None, continues_from: str | None = None,
                   max_open: int | None = None) -> str:
        """Open a ride for the token's device; returns its id. ``started`` is UNIX seconds (now by default);
        ``continues_from`` the id of this device's earlier ride that this one continues (one that could not go
        on: ended, or closed while the device was away), so that the pieces of a ride can be joined
        (:meth:`continuation`); NotFoundError for an unknown ride, ForbiddenError for another device's.
        ``max_open``: refuse (:class:`QuotaError`) when the device already has that many open rides (counted in
        the same transaction as the insert)."""
        device_id = self.authenticate(token)
        where = "new ride"
        previous = validation.text(continues_from, where, "continues_from", required=False)
        fields = {
            "vehicle": validation.text(vehicle, where, "vehicle"),
            "rider_id": validation.text(rider_id, where, "rider_id"),
            "model": validation.text(model, where, "model", required=False),
            **{k: validation.text(v, where, k, required=False)
               for k, v in zip(RIDER_FIELDS, (age_band, gender, skill))},
        }
        started = clock.time() if started is None else _epoch(started, where, "started")
        ride_id = uuid.uuid4().hex
        names = ("ride_id", "device_id", "started", "continues_from", *fields)

        def write(db) -> None:
            if max_open is not None:
                (held,) = db.execute("SELECT COUNT(*) FROM rides WHERE device_id = ? AND ended IS NULL",
                                     (device_id,)).fetchone()
                if held >= max_open:
                    raise QuotaError(f"{where}: this device has {held} open rides, the most it may hold; end one "
                                     "(POST /api/rides/{id}/end, or the 'end' message) before starting another "
                                     "(a ride without samples for an hour is closed)")
            if previous is not None:
                row = db.execute("SELECT device_id FROM rides WHERE ride_id = ?", (previous,)).fetchone()
                if row is None:
                    raise NotFoundError(f"{where}: field 'continues_from': ride {previous!r} is not in the ride "
                                        "store; give the id of this device's earlier ride")
                if row[0] != device_id:
                    raise ForbiddenError(f"{where}: field 'continues_from': ride {previous!r} belongs to another "
                                         "device; a ride continues only a ride of the same device")
            db.execute(f"INSERT INTO rides ({', '.join(names)}) VALUES ({', '.join('?' * len(names))})",
                       (ride_id, device_id, started, previous, *fields.values()))
        self._write(write)
        return ride_id

    def set_destination(self, token: str, ride_id: str, lat: float, lon: float) -> None:
        """Keep the rider's destination of an open ride of the token's device (WGS-84 degrees, checked by the
        caller), replacing an earlier one, so that it outlives the process serving the ride."""
        def write(db) -> None:
            self._own_open_ride(db, token, ride_id)
            db.execute("UPDATE rides SET dest_lat = ?, dest_lon = ? WHERE ride_id = ?",
                       (float(lat), float(lon), ride_id))
        self._write(write)

    def destination(self, ride_id: str) -> tuple[float, float] | None:
        """The destination kept for the ride, ``(lat, lon)`` degrees, or None when none was set."""
        self.ride(ride_id)
        lat, lon = self._query("SELECT dest_lat, dest_lon FROM rides WHERE ride_id = ?", (ride_id,))[0]
        return None if lat is None or lon is None else (float(lat), float(lon))

    def continuation(self, ride_id: str) -> list[str]:
        """The pieces of the ride that ``ride_id`` belongs to, in order: from the first ride (one that continues
        no other) through each ride that continues the one before (the newest when a ride was continued twice)."""
        self.ride(ride_id)
        chain = [ride_id]
        while True:  # back to the first piece
            row = self._query("SELECT continues_from FROM rides WHERE ride_id = ?", (chain[0],))
            if not row or row[0][0] is None or row[0][0] in chain:
                break
            chain.insert(0, row[0][0])
        while True:  # on to the last piece
            row = self._query("SELECT ride_id FROM rides WHERE continues_from = ? ORDER BY started DESC, ride_id "
                              "LIMIT 1", (chain[-1],))
            if not row or row[0][0] in chain:
                break
            chain.append(row[0][0])
        return chain

    def end_ride(self, token: str, ride_id: str, ended: float | None = None) -> None:
        """Close the ride (``ended`` UNIX seconds, now by default); later writes to it are refused."""
        def write(db):
            started = self._own_open_ride(db, token, ride_id, "r.started")
            end = clock.time() if ended is None else _epoch(ended, f"ride {ride_id}", "ended")
            if end < started:
                raise InputError(f"ride {ride_id}: field 'ended' is before the ride started; send a later time")
            db.execute("UPDATE rides SET ended = ? WHERE ride_id = ?", (end, ride_id))
        self._write(write)

    def close_idle_ride(self, ride_id: str, ended: float, events: Iterable[Event] = ()) -> bool:
        """Close an open ride that its device left (no token: for the server's own housekeeping, never for a
        request): record ``events`` and set ``ended`` (UNIX s); False when it had already ended."""
        rows = [_event_row(ride_id, event) for event in events]
        end = _epoch(ended, f"ride {ride_id}", "ended")

        def write(db) -> bool:
            row = db.execute("SELECT ended FROM rides WHERE ride_id = ?", (ride_id,)).fetchone()
            if row is None or row[0] is not None:
                return False
            if rows:
                db.executemany(_EVENT_SQL, rows)
            db.execute("UPDATE rides SET ended = ? WHERE ride_id = ?", (end, ride_id))
            return True
        return self._write(write)

    def open_ride_activity(self) -> list[tuple[str, float]]:
        """``(ride_id, last activity)`` of every open ride: UNIX s of its last stored sample (its start when it
        has none), the start plus that sample's time since the start."""
        rows = self._query(f"SELECT r.ride_id, r.started, {blocks.LAST_TIME} FROM rides r WHERE r.ended IS NULL")
        return [(ride_id, float(started) + float(last or 0.0)) for ride_id, started, last in rows]

    def append_samples(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]],
                       features: Mapping[str, Sequence[float]] | None = None,
                       labels: Mapping[str, Sequence[str | None]] | None = None,
                       events: Iterable[Event] = ()) -> int:
        """Record a batch of raw samples (and, optionally, their features, labels and the events that ended with
        it) in one write.

        ``samples`` maps :data:`SAMPLE_COLUMNS` to equal-length lists (``lat lon speed`` optional, None or NaN
        where there is no fix), or is an ``(n, len(SAMPLE_COLUMNS))`` array in that order; ``features`` maps
        :data:`FEATURE_COLUMNS` to lists of the same length, or is an ``(n, len(FEATURE_COLUMNS))`` array;
        ``labels`` maps model names to one label per sample (None where there is none yet); ``events`` are
        recorded as by :meth:`add_event`. Returns the number of samples recorded, once committed (see
        Durability in the module docstring); a batch that fails any check (:mod:`.validation`) raises
        InputError and records nothing.
        """
        return self.submit_samples(token, ride_id, samples, features, labels, events).result()

    def submit_samples(self, token: str, ride_id: str, samples: Mapping[str, Sequence[float]],
                       features: Mapping[str, Sequence[float]] | None = None,
                       labels: Mapping[str, Sequence[str | None]] | None = None,
                       events: Iterable[Event] = ()) -> Future:
        """:meth:`append_samples` without waiting: the batch is checked now (InputError), the checks that need
        the store (token, open ride, time after the last stored sample) and the write run in the writer thread.
        Returns a future of the number of samples, resolved once committed. Batches of one ride submitted in
        turn are written in that order."""
        where = f"ride {ride_id}"
        table = validation.sample_batch(samples, None, where)
        t = table[:, 0]
        feature_rows = None if features is None else validation.feature_batch(features, len(t), where)
        label_rows = {validation.text(m, where, "model"): validation.label_batch(v, len(t), where, m)
                      for m, v in (labels or {}).items()}
        event_rows = [_event_row(ride_id, event) for event in events]

        write = _SampleWrite(self, token, token_hash(token) if isinstance(token, str) else "", ride_id, t,
                             blocks.sample_row(ride_id, table, self._feature_set, feature_rows),
                             [blocks.label_row(ride_id, model, t, values) for model, values in label_rows.items()],
                             event_rows)
        return self._writer.submit(write, _write_together)

    def append_labels(self, token: str, ride_id: str, model: str, time: Sequence[float],
                      labels: Sequence[str | None]) -> int:
        """Record the labels of ``model`` at sample times ``time`` (s since the ride started), e.g. from a
        second classifier; times must increase and come after the model's last stored label."""
        where = f"ride {ride_id}"
        model = validation.text(model, where, "model")
        t = np.asarray(time, dtype=float)
        if t.ndim != 1 or not 1 <= len(t) <= validation.MAX_BATCH:
            raise InputError(f"{where}: labels need 1 to {validation.MAX_BATCH} times in a flat list")
        values = validation.label_batch(labels, len(t), where, model)

        row = blocks.label_row(ride_id, model, t, values)

        def write(db) -> int:
            last = self._own_open_ride(db, token, ride_id, blocks.LAST_LABEL_TIME, (model,))
            validation.check_times(t, last, where)
            db.execute(blocks.INSERT_LABELS, row)
            return len(t)
        return self._write(write)

    def add_event(self, token: str, ride_id: str, event: Event) -> None:
        """Record ``event``; an event of the same kind and start replaces the earlier one (its end may grow)."""
        row = _event_row(ride_id, event)

        def write(db) -> None:
            self._own_open_ride(db, token, ride_id)
            db.execute(_EVENT_SQL, row)
        self._write(write)

    # ------------------------------------------------------------ reading

    def rides(self, device_id: str | None = None) -> list[Ride]:
        """All rides (or the device's), oldest first."""
        sql = f"SELECT {', '.join(_RIDE_FIELDS)} FROM rides"
        rows = self._query(sql + " WHERE device_id = ? ORDER BY started, ride_id", (device_id,)) if device_id \
            else self._query(sql + " ORDER BY started, ride_id")
        return [Ride(*row) for row in rows]

    def ride(self, ride_id: str) -> Ride:
        """The ride's metadata; :class:`NotFoundError` for an unknown id."""
        rows = self._query(f"SELECT {', '.join(_RIDE_FIELDS)} FROM rides WHERE ride_id = ?", (ride_id,))
        if not rows:
            raise NotFoundError(f"ride {ride_id!r} is not in the ride store; list the rides to find its id")
        return Ride(*rows[0])

    def samples(self, ride_id: str, since: float | None = None) -> dict[str, np.ndarray]:
        """The ride's raw samples, column by column (:data:`SAMPLE_COLUMNS`; NaN where no GPS fix); only those
        after ``since`` (s) when given, e.g. for a view that polls a live ride."""
        self.ride(ride_id)
        rows = self._blocks("n, samples", ride_id, since)
        with _decoding(ride_id, "samples"):
            table = blocks.samples_table(rows)
        if since is not None:
            table = table[table[:, 0] > since]
        return dict(zip(SAMPLE_COLUMNS, table.T))

    def features(self, ride_id: str) -> dict[str, np.ndarray]:
        """The ride's features: ``time`` and :data:`FEATURE_COLUMNS` (NaN where none was recorded)."""
        self.ride(ride_id)
        sets = dict(self._query("SELECT set_id, columns FROM feature_sets"))
        rows = self._blocks("n, samples, feature_set, features", ride_id)
        with _decoding(ride_id, "features"):
            table = blocks.features_table(rows, sets)
        return dict(zip(("time", *FEATURE_COLUMNS), table.T))

    def labels(self, ride_id: str) -> dict[str, np.ndarray]:
        """The ride's labels, one column per model name beside ``time`` (the union of all models' times; an
        object array per model holding None where that model has no label)."""
        self.ride(ride_id)
        rows = self._query("SELECT model, n, times, labels FROM label_blocks WHERE ride_id = ? ORDER BY model, t0",
                           (ride_id,))
        with _decoding(ride_id, "labels"):
            per_model = {model: blocks.label_lists([r[1:] for r in rows if r[0] == model])
                         for model in dict.fromkeys(r[0] for r in rows)}
        times = np.unique(np.concatenate([t for t, _ in per_model.values()])) if per_model else np.empty(0)
        columns: dict[str, np.ndarray] = {"time": times}
        for model, (t, values) in per_model.items():
            columns[model] = np.full(len(times), None, dtype=object)
            columns[model][np.searchsorted(times, t)] = values
        return columns

    def events(self, ride_id: str) -> list[Event]:
        """The ride's events in order of start."""
        self.ride(ride_id)
        rows = self._query("SELECT kind, start_time, end_time, detail FROM events WHERE ride_id = ? "
                           "ORDER BY start_time, kind", (ride_id,))
        return [Event(*row) for row in rows]

    # ------------------------------------------------------------ internals

    def _write(self, write: Callable):
        """Run ``write(cursor)`` in the writer's next transaction; its value once committed."""
        return self._writer.submit(write).result()

    @contextmanager
    def _transaction(self) -> Iterator:
        with self._lock, self._process_lock, self._db.transaction() as cursor:
            yield cursor

    def _query(self, sql: str, params: tuple = ()) -> list[tuple]:
        with self._lock:
            return self._db.query(sql, params)

    def _blocks(self, columns: str, ride_id: str, since: float | None = None) -> list[tuple]:
        """``columns`` of the ride's sample blocks in order of time (those ending after ``since`` when given)."""
        sql = f"SELECT {columns} FROM sample_blocks WHERE ride_id = ?"
        if since is None:
            return self._query(sql + " ORDER BY t0", (ride_id,))
        return self._query(sql + " AND t1 > ? ORDER BY t0", (ride_id, since))

    def _own_open_ride(self, db, token: str, ride_id: str, value: str = "NULL", params: tuple = ()):
        """Check in one query that the token's device started the ride and that it is still open; returns the SQL
        expression ``value`` over the ride's row ``r`` (``params`` its placeholders), e.g. its last stored time."""
        row = db.execute(f"SELECT r.device_id, r.ended, d.device_id, {value} FROM rides r "
                         "LEFT JOIN devices d ON d.token_hash = ? WHERE r.ride_id = ?",
                         (*params, token_hash(token) if isinstance(token, str) else "", ride_id)).fetchone()
        if row is None or row[2] is None:
            self.authenticate(token)  # AccessError for a token of no device
            raise NotFoundError(f"ride {ride_id!r} does not exist; start a ride first")
        owner, ended, device_id, result = row
        if owner != device_id:
            raise AccessError(f"ride {ride_id!r} belongs to another device; write only to rides this device started")
        if ended is not None:
            raise InputError(f"ride {ride_id!r} has ended; start a new ride")
        return result


@dataclass(slots=True)
class _SampleWrite:
    """A batch of samples for the writer thread (:meth:`RideStore.submit_samples`): checked but for what needs the
    store (the token's ride, still open, times after its last stored sample); its rows ready to insert."""

    store: RideStore
    token: str
    token_hash: str
    ride_id: str
    t: np.ndarray
    sample_row: tuple
    label_rows: list[tuple]
    event_rows: list[tuple]

    def __call__(self, db) -> int:
        """Write this batch alone: InputError, AccessError or NotFoundError name what is wrong."""
        last = self.store._own_open_ride(db, self.token, self.ride_id, blocks.LAST_TIME)
        validation.check_times(self.t, last, f"ride {self.ride_id}")
        _insert(db, [self])
        return len(self.t)


@contextmanager
def _decoding(ride_id: str, what: str) -> Iterator[None]:
    """A block of ride ``ride_id`` that does not decode as :mod:`spotfree.ride.blocks` wrote it raises
    :class:`DamagedRideError` (one line) instead of the decoder's own error."""
    try:
        yield
    except (ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
        raise DamagedRideError(f"ride {ride_id}: its stored {what} are damaged ({type(exc).__name__}: "
                               f"{' '.join(str(exc).split())[:80]}); this ride cannot be read, the others can") \
            from None


def _insert(db, writes: list[_SampleWrite]) -> None:
    """The rows of ``writes`` (checked): one multi-row insert per table, events upserted in order."""
    blocks.insert_rows(db, blocks.INSERT_SAMPLES, [w.sample_row for w in writes])
    blocks.insert_rows(db, blocks.INSERT_LABELS, [row for w in writes for row in w.label_rows])
    events = [row for w in writes for row in w.event_rows]
    if events:
        db.executemany(_EVENT_SQL, events)


class _Unclear(Exception):
    """A write of a group that only running it alone can judge (an unknown, ended or foreign ride)."""


def _write_together(db, writes: list[_SampleWrite]) -> list[tuple[bool, object]]:
    """Write several rides' batches in a few statements: one query finds every ride's owner, state and last time,
    the times are checked here, then one multi-row insert per table. A batch whose times are refused changes
    nothing; any other refusal raises :class:`_Unclear`, and the group commit then runs each batch alone."""
    rides = list(dict.fromkeys(w.ride_id for w in writes))
    known: dict[str, list] = {}
    for start in range(0, len(rides), blocks.ROWS_PER_INSERT):
        part = rides[start:start + blocks.ROWS_PER_INSERT]
        rows = db.execute(f"SELECT r.ride_id, r.ended, d.token_hash, {blocks.LAST_TIME} FROM rides r "
                          f"JOIN devices d ON d.device_id = r.device_id WHERE r.ride_id IN "
                          f"({', '.join('?' * len(part))})", part).fetchall()
        known.update((ride_id, [ended, owner, last]) for ride_id, ended, owner, last in rows)
    outcomes, accepted = [], []
    for write in writes:
        ended, owner, last = known.get(write.ride_id, (None, None, None))
        if owner is None or owner != write.token_hash or ended is not None:
            raise _Unclear(write.ride_id)
        try:
            validation.check_times(write.t, last, f"ride {write.ride_id}")
        except InputError as exc:
            outcomes.append((False, exc))
            continue
        known[write.ride_id][2] = float(write.t[-1])
        accepted.append(write)
        outcomes.append((True, len(write.t)))
    _insert(db, accepted)
    return outcomes


class SQLiteConnection:
    """One SQLite connection in WAL mode; :meth:`transaction` is ``BEGIN IMMEDIATE`` ... ``COMMIT``. A new file is
    created readable and writable by its owner only (mode 0600: GPS tracks and riders' descriptors), and SQLite
    gives its ``-wal`` and ``-shm`` files the same mode."""

    def __init__(self, path: str, synchronous: str):
        self.path = path
        if path != ":memory:" and not path.startswith("file:"):
            with contextlib.suppress(OSError):  # an existing file keeps its mode; SQLite names any other failure
                os.close(os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
        try:
            self._connection = sqlite3.connect(path, isolation_level=None, check_same_thread=False, timeout=30.0)
            self._connection.execute("PRAGMA journal_mode = WAL")
            self._connection.execute(f"PRAGMA synchronous = {synchronous.upper()}")
            self._connection.execute("PRAGMA foreign_keys = ON")
        except sqlite3.DatabaseError as exc:
            raise InputError(f"{path}: not a usable SQLite ride store ({exc}); give a new file name") from None

    @contextmanager
    def transaction(self) -> Iterator[sqlite3.Cursor]:
        cursor = self._connection.cursor()
        cursor.execute("BEGIN IMMEDIATE")
        try:
            yield cursor
        except BaseException:
            cursor.execute("ROLLBACK")
            raise
        cursor.execute("COMMIT")

    def query(self, sql: str, params: tuple) -> list[tuple]:
        return self._connection.execute(sql, params).fetchall()

    def close(self) -> None:
        self._connection.execute("PRAGMA wal_checkpoint(TRUNCATE)")
        self._connection.close()


def _open_schema(db) -> int | None:
    """Create the tables of a new store, or bring a version-1 store (rewritten into blocks, :mod:`.blocks`) or a
    version-2 store (rides without continuation and destination) to this version; the id of today's feature
    columns. A store of another version is left untouched (None)."""
    db.execute(blocks.SCHEMA[0])
    row = db.execute("SELECT value FROM meta WHERE key = ?", ("schema_version",)).fetchone()
    if row is not None and row[0] not in ("1", "2", str(blocks.SCHEMA_VERSION)):
        return None
    for statement in blocks.SCHEMA[1:]:
        db.execute(statement)
    if row is None:
        db.execute("INSERT INTO meta (key, value) VALUES (?, ?)", ("schema_version", str(blocks.SCHEMA_VERSION)))
    elif row[0] != str(blocks.SCHEMA_VERSION):
        if row[0] == "1":
            blocks.upgrade_from_v1(db)
        blocks.upgrade_to_v3(db)
        db.execute("UPDATE meta SET value = ? WHERE key = ?", (str(blocks.SCHEMA_VERSION), "schema_version"))
    db.execute(blocks.CONTINUATION_INDEX)
    return blocks.feature_set(db, FEATURE_COLUMNS)


_EVENT_SQL = ("INSERT INTO events (ride_id, kind, start_time, end_time, detail) VALUES (?, ?, ?, ?, ?) "
              "ON CONFLICT (ride_id, kind, start_time) DO UPDATE "
              "SET end_time = excluded.end_time, detail = excluded.detail")


def _event_row(ride_id: str, event: Event) -> tuple:
    """The ``events`` row of ``event``, checked: InputError for bad text or times."""
    where = f"ride {ride_id}"
    kind = validation.text(event.kind, where, "kind")
    detail = "" if not event.detail else validation.text(event.detail, where, "detail")
    start, end = float(event.start), float(event.end)
    if not (np.isfinite(start) and np.isfinite(end) and 0 <= start <= end):
        raise InputError(f"{where}: event {kind!r} from {start!r} to {end!r} s; send 0 <= start <= end")
    return ride_id, kind, start, end, detail


def _epoch(value: float, where: str, field: str) -> float:
    """UNIX seconds between 2000 and 2200, or InputError (catches milliseconds and relative times)."""
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{where}: field {field!r} must be UNIX seconds") from None
    if not 946684800.0 <= value <= 7258118400.0:
        raise InputError(f"{where}: field {field!r} = {value!r} is not UNIX seconds between 2000 and 2200")
    return value
