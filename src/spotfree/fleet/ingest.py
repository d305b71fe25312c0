"""Rides into the ride store: sensor logs of any supported format, or the rides of another store.

A ride is known by its natural key ``(vehicle, rider_id, started)``: one rider on one vehicle starts one ride at
a given second. Ingesting skips every ride whose key the store already holds, so re-running an ingest on the
same inputs changes nothing (no device is registered when nothing is new). A ride whose ingest was interrupted
stays open in the store (``ended`` empty); it is reported, never processed, and not ingested again.

Logs are read by :func:`spotfree.io.read_recording` (``PATH`` or ``PATH@K``). Samples inside gaps (NaN IMU) are
not stored; times stay seconds since the ride started. A log's start comes from its :class:`LogEntry` (the
manifest's ``started``, UNIX seconds) or from the log itself (``meta['start_epoch']``, e.g. Sensor Logger).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.errors import InputError
from spotfree.io import read_recording
from spotfree.io.recording import IMU_CHANNELS
from spotfree.ride.records import GPS_COLUMNS, RIDER_FIELDS, SAMPLE_COLUMNS, Ride
from spotfree.ride.store import DamagedRideError, RideStore
from spotfree.ride.validation import MAX_BATCH

DEVICE_NAME = "fleet ingest"


@dataclass(frozen=True)
class LogEntry:
    """One ride log and who rode it: ``path`` (``PATH`` or ``PATH@K``), ``started`` UNIX s (None: from the log)."""

    path: str
    vehicle: str
    rider_id: str
    started: float | None = None
    age_band: str | None = None
    gender: str | None = None
    skill: str | None = None


@dataclass
class IngestReport:
    """Ride ids added, rides skipped as already stored, and stored rides left open by an interrupted ingest."""

    added: list[str] = field(default_factory=list)
    skipped: int = 0
    open: list[str] = field(default_factory=list)
    damaged: list[str] = field(default_factory=list)
    """Rides of the source store whose blocks could not be read (left out)."""

    def __str__(self) -> str:
        text = f"{len(self.added)} rides added, {self.skipped} already stored"
        text += f", {len(self.open)} open (interrupted ingest or live)" if self.open else ""
        return text + (f", {len(self.damaged)} damaged in the source store and left out ({self.damaged[0]}"
                       f"{', ...' if len(self.damaged) > 1 else ''})" if self.damaged else "")


def read_manifest(manifest: str | Path, riders: str | Path | None = None) -> list[LogEntry]:
    """Log entries from a manifest CSV (``file, vehicle, rider_id`` and optional ``started``, rider fields),
    joined on ``rider_id`` with a riders CSV when given; ``file`` is relative to the manifest's folder."""
    manifest = Path(manifest)
    table = _table(manifest, ("file", "vehicle", "rider_id"))
    if riders is not None:
        people = _table(Path(riders), ("rider_id",))
        extra = [c for c in RIDER_FIELDS if c in people.columns]
        table = table.drop(columns=[c for c in extra if c in table.columns]).merge(
            people[["rider_id", *extra]], on="rider_id", how="left")
    entries = []
    for k, row in table.iterrows():
        started = row.get("started")
        if started is not None and not pd.isna(started):
            try:
                started = float(started)
            except ValueError:
                raise InputError(f"{manifest}: row {k + 2}, field 'started' = {started!r}; give UNIX seconds") from None
        else:
            started = None
        entries.append(LogEntry(str(manifest.parent / row["file"]), str(row["vehicle"]), str(row["rider_id"]),
                                started, **{c: _text(row.get(c)) for c in RIDER_FIELDS}))
    return entries


def ingest_logs(store: RideStore, entries: list[LogEntry]) -> IngestReport:
    """Store every log of ``entries`` whose ride is not stored yet (see the module docstring)."""
    report, known = IngestReport(), _keys(store)
    token = None
    for entry in entries:
        rec = read_recording(entry.path)
        if rec.experiment is not None and len(np.unique(rec.experiment)) > 1:
            raise InputError(f"{entry.path}: holds {len(np.unique(rec.experiment))} experiments; list each ride "
                             "as PATH@K")
        started = entry.started if entry.started is not None else rec.meta.get("start_epoch")
        if started is None:
            raise InputError(f"{entry.path}: the log carries no start time; give 'started' (UNIX s) in the "
                             "manifest or --started")
        if _seen(report, known, (entry.vehicle, entry.rider_id, float(started))):
            continue
        columns = {c: rec.channels[c] if c in rec.channels else np.full(len(rec), np.nan)
                   for c in SAMPLE_COLUMNS[1:]}
        missing = [c for c in IMU_CHANNELS if c not in rec.channels]
        if missing:
            raise InputError(f"{entry.path}: no column {', '.join(missing)}; a ride log needs ax ay az gx gy gz")
        keep = np.all(np.isfinite(np.column_stack([columns[c] for c in IMU_CHANNELS])), axis=1)
        samples = {"time": rec.time[keep], **{c: v[keep] for c, v in columns.items()}}
        token = token or store.register_device(DEVICE_NAME)[1]
        fields = {c: getattr(entry, c) for c in RIDER_FIELDS}
        report.added.append(_write(store, token, entry.vehicle, entry.rider_id, float(started), fields, samples,
                                   ended=float(started) + float(rec.time[-1]), where=entry.path))
    return report


def ingest_store(store: RideStore, source: RideStore) -> IngestReport:
    """Copy the ended rides of ``source`` (metadata and raw samples) that ``store`` does not hold yet."""
    report, known = IngestReport(), _keys(store)
    token = None
    for ride in source.rides():
        if ride.ended is None or _seen(report, known, (ride.vehicle, ride.rider_id, ride.started)):
            continue
        try:
            samples = source.samples(ride.ride_id)
        except DamagedRideError:
            report.damaged.append(ride.ride_id)
            continue
        if len(samples["time"]) == 0:
            continue
        token = token or store.register_device(DEVICE_NAME)[1]
        report.added.append(_write(store, token, ride.vehicle, ride.rider_id, ride.started,
                                   {c: getattr(ride, c) for c in RIDER_FIELDS}, samples, ride.ended,
                                   where=f"{source.name} ride {ride.ride_id}"))
    return report


def _keys(store: RideStore) -> dict[tuple[str, str, float], Ride]:
    return {(r.vehicle, r.rider_id, float(r.started)): r for r in store.rides()}


def _seen(report: IngestReport, known: dict, key: tuple[str, str, float]) -> bool:
    """Whether the store holds the ride of ``key`` (counted as skipped, or as open when never ended)."""
    if key not in known:
        return False
    report.skipped += 1
    if known[key].ended is None:
        report.open.append(known[key].ride_id)
    return True


def _write(store: RideStore, token: str, vehicle: str, rider_id: str, started: float, fields: dict,
           samples: dict[str, np.ndarray], ended: float, where: str) -> str:
    """Start the ride, append its samples in batches, end it; returns the ride id."""
    try:
        ride_id = store.start_ride(token, vehicle, rider_id, started=started, **fields)
        for first in range(0, len(samples["time"]), MAX_BATCH):
            part = {c: v[first:first + MAX_BATCH] for c, v in samples.items()}
            if all(np.isnan(part[c]).all() for c in GPS_COLUMNS):
                part = {c: v for c, v in part.items() if c not in GPS_COLUMNS}
            store.append_samples(token, ride_id, part)
        store.end_ride(token, ride_id, ended)
    except InputError as exc:
        raise InputError(f"{where}: {exc}") from None
    return ride_id


def _table(path: Path, required: tuple[str, ...]) -> pd.DataFrame:
    try:
        table = pd.read_csv(path, dtype={"rider_id": str, "vehicle": str})
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file; give the manifest as a UTF-8 CSV") from None
    except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        first = " ".join(str(exc).split())[:120]
        raise InputError(f"{path}: cannot read the CSV ({first}); give a readable CSV file") from None
    missing = [c for c in required if c not in table.columns]
    if missing:
        raise InputError(f"{path}: no column {', '.join(missing)}; add it (columns: {', '.join(required)})")
    return table


def _text(value) -> str | None:
    return None if value is None or pd.isna(value) else str(value)
