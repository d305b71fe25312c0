"""The ride store's row layout: one row per batch of samples, not one per sample.

A batch of ``n`` samples is one ``sample_blocks`` row: its first and last time ``t0``, ``t1`` (s since the ride
started), ``n``, the ``(n, len(SAMPLE_COLUMNS))`` raw samples and, when recorded, the ``(n, k)`` features as
little-endian float64 bytes in row order (NaN where a value is missing, e.g. no GPS fix), with ``feature_set``
naming the ``k`` feature columns (``feature_sets``, so that a store written before a channel existed still reads).
The labels of one model over a batch are one ``label_blocks`` row: the times as float64 bytes and the labels as a
JSON list (null where there is none). Times increase within a block and from one block of a ride to the next, so
a ride's last time is the ``t1`` of its block with the largest ``t0`` (a primary-key lookup).

Writing a batch is then two inserts whatever its size, where a row per sample cost an insert per sample and table.

Schema version 1 held a row per sample; :func:`upgrade_from_v1` rewrites such a store in place, in the
transaction that opens it, into blocks of at most :data:`UPGRADE_BLOCK` samples.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import orjson

from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS

SCHEMA_VERSION = 3
UPGRADE_BLOCK = 1000
"""Samples per block when a version-1 store is rewritten."""

_REAL = "DOUBLE PRECISION"
_BYTES = "BYTEA"  # PostgreSQL's byte string; SQLite stores the bytes as given (a blob)
_FLOAT = np.dtype("<f8")

SCHEMA = (
    "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
    "CREATE TABLE IF NOT EXISTS devices (device_id TEXT PRIMARY KEY, name TEXT NOT NULL, "
    f"token_hash TEXT NOT NULL UNIQUE, created {_REAL} NOT NULL)",
    "CREATE TABLE IF NOT EXISTS rides (ride_id TEXT PRIMARY KEY, "
    "device_id TEXT NOT NULL REFERENCES devices (device_id), vehicle TEXT NOT NULL, rider_id TEXT NOT NULL, "
    f"started {_REAL} NOT NULL, ended {_REAL}, model TEXT, age_band TEXT, gender TEXT, skill TEXT, "
    f"continues_from TEXT REFERENCES rides (ride_id), dest_lat {_REAL}, dest_lon {_REAL})",
    "CREATE INDEX IF NOT EXISTS rides_by_device ON rides (device_id)",
    "CREATE TABLE IF NOT EXISTS feature_sets (set_id INTEGER PRIMARY KEY, columns TEXT NOT NULL UNIQUE)",
    "CREATE TABLE IF NOT EXISTS sample_blocks (ride_id TEXT NOT NULL REFERENCES rides (ride_id), "
    f"t0 {_REAL} NOT NULL, t1 {_REAL} NOT NULL, n INTEGER NOT NULL, samples {_BYTES} NOT NULL, "
    f"feature_set INTEGER REFERENCES feature_sets (set_id), features {_BYTES}, PRIMARY KEY (ride_id, t0))",
    "CREATE TABLE IF NOT EXISTS label_blocks (ride_id TEXT NOT NULL REFERENCES rides (ride_id), "
    f"model TEXT NOT NULL, t0 {_REAL} NOT NULL, t1 {_REAL} NOT NULL, n INTEGER NOT NULL, times {_BYTES} NOT NULL, "
    "labels TEXT NOT NULL, PRIMARY KEY (ride_id, model, t0))",
    "CREATE TABLE IF NOT EXISTS events (ride_id TEXT NOT NULL REFERENCES rides (ride_id), kind TEXT NOT NULL, "
    f"start_time {_REAL} NOT NULL, end_time {_REAL} NOT NULL, detail TEXT NOT NULL, "
    "PRIMARY KEY (ride_id, kind, start_time))",
    f"CREATE TABLE IF NOT EXISTS enrolments (code_hash TEXT PRIMARY KEY, expires {_REAL} NOT NULL, "
    "uses INTEGER NOT NULL)",
)

INSERT_SAMPLES = ("INSERT INTO sample_blocks (ride_id, t0, t1, n, samples, feature_set, features) "
                  "VALUES (?, ?, ?, ?, ?, ?, ?)")
INSERT_LABELS = "INSERT INTO label_blocks (ride_id, model, t0, t1, n, times, labels) VALUES (?, ?, ?, ?, ?, ?, ?)"
LAST_TIME = "(SELECT b.t1 FROM sample_blocks b WHERE b.ride_id = r.ride_id ORDER BY b.t0 DESC LIMIT 1)"
"""The last sample time of the ride ``r`` (SQL expression over a row ``r`` of ``rides``)."""
LAST_LABEL_TIME = ("(SELECT b.t1 FROM label_blocks b WHERE b.ride_id = r.ride_id AND b.model = ? "
                   "ORDER BY b.t0 DESC LIMIT 1)")
"""A model's last label time on the ride ``r`` (SQL expression; parameter: the model)."""
ROWS_PER_INSERT = 64
"""Rows per multi-row INSERT in :func:`insert_rows` (fewer distinct statements for the statement cache)."""


def insert_rows(db, sql: str, rows: Sequence[tuple]) -> None:
    """Run the one-row ``INSERT ... VALUES (?, ...)`` ``sql`` for all ``rows`` as multi-row INSERTs of at most
    :data:`ROWS_PER_INSERT` rows: one statement (one step of the database) per chunk instead of per row."""
    head, _, values = sql.partition(" VALUES ")
    for start in range(0, len(rows), ROWS_PER_INSERT):
        chunk = rows[start:start + ROWS_PER_INSERT]
        db.execute(f"{head} VALUES {', '.join([values] * len(chunk))}", [v for row in chunk for v in row])


def feature_set(db, columns: Sequence[str]) -> int:
    """The id of the feature set ``columns`` (registered when new)."""
    text = ",".join(columns)
    db.execute("INSERT INTO feature_sets (set_id, columns) SELECT coalesce(max(set_id), 0) + 1, ? "
               "FROM feature_sets WHERE true ON CONFLICT (columns) DO NOTHING", (text,))
    return db.execute("SELECT set_id FROM feature_sets WHERE columns = ?", (text,)).fetchone()[0]


def sample_row(ride_id: str, table: np.ndarray, set_id: int | None, features: np.ndarray | None) -> tuple:
    """The ``sample_blocks`` row of a batch: ``table`` in :data:`SAMPLE_COLUMNS` order, ``features`` (or None)
    in the columns of feature set ``set_id``."""
    t = table[:, 0]
    return (ride_id, float(t[0]), float(t[-1]), len(t), _bytes(table),
            None if features is None else set_id, None if features is None else _bytes(features))


def label_row(ride_id: str, model: str, t: np.ndarray, labels: Sequence[str | None]) -> tuple:
    """The ``label_blocks`` row of one model's labels at times ``t``."""
    return ride_id, model, float(t[0]), float(t[-1]), len(t), _bytes(t), orjson.dumps(list(labels)).decode()


def samples_table(rows: list[tuple]) -> np.ndarray:
    """``(n, len(SAMPLE_COLUMNS))`` samples of ``(n, samples)`` block rows."""
    return _stack([(n, data) for n, data in rows], len(SAMPLE_COLUMNS))


def features_table(rows: list[tuple], sets: dict[int, str]) -> np.ndarray:
    """``(n, 1 + len(FEATURE_COLUMNS))`` time and features of ``(n, samples, set_id, features)`` block rows
    that hold features; a column their set lacks is NaN."""
    parts = []
    for n, samples, set_id, data in rows:
        if data is None:
            continue
        stored = sets[set_id].split(",")
        values = np.frombuffer(data, _FLOAT).reshape(n, len(stored))
        out = np.full((n, 1 + len(FEATURE_COLUMNS)), np.nan)
        out[:, 0] = np.frombuffer(samples, _FLOAT).reshape(n, len(SAMPLE_COLUMNS))[:, 0]
        for j, name in enumerate(stored):
            if name in FEATURE_COLUMNS:
                out[:, 1 + FEATURE_COLUMNS.index(name)] = values[:, j]
        parts.append(out)
    return np.concatenate(parts) if parts else np.empty((0, 1 + len(FEATURE_COLUMNS)))


def label_lists(rows: list[tuple]) -> tuple[np.ndarray, list]:
    """Times and labels of ``(n, times, labels)`` label block rows."""
    times = _stack([(n, data) for n, data, _ in rows], 1)[:, 0]
    labels = [label for _, _, text in rows for label in orjson.loads(text)]
    return times, labels


def upgrade_from_v1(db) -> None:
    """Rewrite a version-1 store (``samples``, ``features``, ``labels``: a row per sample) into blocks, then drop
    those tables; run inside the transaction that creates :data:`SCHEMA`, so that it happens whole or not at
    all. Feature rows go with the sample of the same time."""
    stored = [c[0] for c in db.execute("SELECT * FROM features LIMIT 0").description][2:]
    set_id = feature_set(db, stored)
    sample_names = ("t", *SAMPLE_COLUMNS[1:])
    columns = ", ".join([f"s.{c}" for c in sample_names] + [f"f.{c}" for c in stored] + ["f.t"])
    for (ride_id,) in db.execute("SELECT ride_id FROM rides ORDER BY ride_id").fetchall():
        rows = db.execute(f"SELECT {columns} FROM samples s LEFT JOIN features f ON f.ride_id = s.ride_id "
                          "AND f.t = s.t WHERE s.ride_id = ? ORDER BY s.t", (ride_id,)).fetchall()
        table = np.array(rows, dtype=float).reshape(len(rows), len(sample_names) + len(stored) + 1)
        for block in np.array_split(table, range(UPGRADE_BLOCK, len(table), UPGRADE_BLOCK)):
            has = ~np.isnan(block[:, -1])
            db.execute(INSERT_SAMPLES, sample_row(ride_id, block[:, :len(sample_names)], set_id,
                                                  block[:, len(sample_names):-1] if has.any() else None))
        models = db.execute("SELECT DISTINCT model FROM labels WHERE ride_id = ? ORDER BY model", (ride_id,))
        for (model,) in models.fetchall():
            rows = db.execute("SELECT t, label FROM labels WHERE ride_id = ? AND model = ? ORDER BY t",
                              (ride_id, model)).fetchall()
            for start in range(0, len(rows), UPGRADE_BLOCK):
                part = rows[start:start + UPGRADE_BLOCK]
                db.execute(INSERT_LABELS, label_row(ride_id, model, np.array([r[0] for r in part]),
                                                    [r[1] for r in part]))
    for table in ("samples", "features", "labels"):
        db.execute(f"DROP TABLE {table}")


RIDE_COLUMNS_V3 = (("continues_from", "TEXT REFERENCES rides (ride_id)"), ("dest_lat", _REAL), ("dest_lon", _REAL))
"""The ``rides`` columns that version 3 added: the ride this one continues (the same device's earlier ride, which
could not go on) and the rider's destination (degrees, NULL until set)."""


CONTINUATION_INDEX = "CREATE INDEX IF NOT EXISTS rides_by_continuation ON rides (continues_from)"
"""Run after :data:`SCHEMA` and :func:`upgrade_to_v3` (the column is new in version 3)."""


def upgrade_to_v3(db) -> None:
    """Add the columns of :data:`RIDE_COLUMNS_V3` to the ``rides`` table of a version-1 or -2 store (NULL in every
    existing ride), inside the transaction that opens it."""
    for name, kind in RIDE_COLUMNS_V3:
        db.execute(f"ALTER TABLE rides ADD COLUMN {name} {kind}")


def _bytes(values: np.ndarray) -> bytes:
    return np.ascontiguousarray(values, dtype=_FLOAT).tobytes()


def _stack(rows: list[tuple[int, bytes]], width: int) -> np.ndarray:
    if not rows:
        return np.empty((0, width))
    return np.frombuffer(b"".join(data for _, data in rows), _FLOAT).reshape(-1, width).copy()
