"""Exports of a stored ride: the spotfree CSV, GPX and GeoJSON.

* CSV (:func:`~spotfree.io.csvlog.write_csv`): ``time`` (s since the ride started), ``ax ay az gx gy gz``
  (device frame, m/s^2 and rad/s), ``lat lon speed`` (empty without a fix), ``label`` (the labels of one model:
  the ride's own by default) and ``event`` (the kinds of the events spanning the sample, ``;``-joined).
* GPX (:func:`~spotfree.io.gpx.write_gpx`): one track point per fix, timed ``started + time``.
* GeoJSON (RFC 7946): a FeatureCollection of a LineString of the fixes (``[lon, lat]``, WGS-84 degrees, as the
  RFC orders them) carrying the ride's metadata, and one Point per event at the last fix at or before its
  start (``null`` geometry when the ride had no fix by then) with ``kind``, ``start``, ``end`` (s since the
  ride started) and ``detail``.
"""

from __future__ import annotations

import datetime as dt
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.csvlog import write_csv
from spotfree.io.gpx import write_gpx
from spotfree.io.recording import Recording
from spotfree.ride.records import Ride
from spotfree.ride.store import RideStore

FORMATS = {".csv": "csv", ".gpx": "gpx", ".geojson": "geojson", ".json": "geojson"}
"""File suffix -> export format."""


def ride_recording(store: RideStore, ride_id: str, model: str | None = None) -> Recording:
    """The ride's raw samples as a Recording, with ``truth['label']`` from ``model`` (the ride's model by
    default, or its only one) and ``truth['event']``; ``meta['start_epoch']`` is the ride's start."""
    ride = store.ride(ride_id)
    samples = store.samples(ride_id)
    time = samples.pop("time")
    if len(time) == 0:
        raise InputError(f"ride {ride_id}: no samples recorded; nothing to export")
    steps = np.diff(time)
    rate = 1.0 / float(np.median(steps)) if len(steps) else 1.0
    truth = {"label": _labels(store, ride, time, model), "event": _events(store, ride_id, time)}
    return Recording(time, samples, rate, source=f"ride {ride_id}", truth=truth,
                     meta={"start_epoch": ride.started, "ride": ride})


def export_csv(store: RideStore, ride_id: str, path: str | Path, model: str | None = None) -> None:
    """Write the ride as a spotfree CSV (columns in the module docstring)."""
    write_csv(ride_recording(store, ride_id, model), path)


def export_gpx(store: RideStore, ride_id: str, path: str | Path) -> None:
    """Write the ride's GPS fixes as a GPX track."""
    write_gpx(ride_recording(store, ride_id), path)


def ride_geojson(store: RideStore, ride_id: str) -> dict:
    """The ride as an RFC 7946 FeatureCollection (see the module docstring)."""
    ride = store.ride(ride_id)
    samples = store.samples(ride_id)
    fix = np.isfinite(samples["lat"]) & np.isfinite(samples["lon"])
    time, lat, lon = samples["time"][fix], samples["lat"][fix], samples["lon"][fix]
    positions = [[float(x), float(y)] for x, y in zip(lon, lat)]
    track = {"type": "LineString", "coordinates": positions} if len(positions) > 1 else \
        {"type": "Point", "coordinates": positions[0]} if positions else None
    properties = {"kind": "track", **asdict(ride), "started": _iso(ride.started),
                  "ended": None if ride.ended is None else _iso(ride.ended)}
    features = [{"type": "Feature", "geometry": track, "properties": properties}]
    for event in store.events(ride_id):
        k = int(np.searchsorted(time, event.start, side="right")) - 1
        point = {"type": "Point", "coordinates": positions[k]} if k >= 0 else None
        features.append({"type": "Feature", "geometry": point, "properties": {
            "kind": event.kind, "start": event.start, "end": event.end, "detail": event.detail}})
    return {"type": "FeatureCollection", "features": features}


def export_geojson(store: RideStore, ride_id: str, path: str | Path) -> None:
    """Write :func:`ride_geojson` as UTF-8 JSON."""
    checks.write_text(Path(path), json.dumps(ride_geojson(store, ride_id), ensure_ascii=False, indent=1) + "\n")


def export_ride(store: RideStore, ride_id: str, path: str | Path) -> None:
    """Write the ride in the format of ``path``'s suffix (:data:`FORMATS`)."""
    kind = FORMATS.get(Path(path).suffix.lower())
    if kind is None:
        raise InputError(f"{path}: unknown export format; name the file .csv, .gpx, .geojson or .json")
    {"csv": export_csv, "gpx": export_gpx, "geojson": export_geojson}[kind](store, ride_id, path)


def _labels(store: RideStore, ride: Ride, time: np.ndarray, model: str | None) -> np.ndarray:
    """One label per sample ('' where the model gave none)."""
    labels = store.labels(ride.ride_id)
    models = [m for m in labels if m != "time"]
    if model is None and not models:
        return np.full(len(time), "", dtype=object)
    if model is None:
        if ride.model not in models and len(models) > 1:
            raise InputError(f"ride {ride.ride_id}: labels of several models ({', '.join(models)}); choose one")
        model = ride.model if ride.model in models else models[0]
    elif model not in models:
        raise InputError(f"ride {ride.ride_id}: no labels of model {model!r}; its models: "
                         f"{', '.join(models) or 'none'}")
    out = np.full(len(time), "", dtype=object)
    index = np.searchsorted(time, labels["time"])
    inside = index < len(time)
    match = inside & (time[np.minimum(index, len(time) - 1)] == labels["time"])
    values = labels[model][match]
    out[index[match]] = np.where(values == None, "", values)  # noqa: E711 (element-wise)
    return out


def _events(store: RideStore, ride_id: str, time: np.ndarray) -> np.ndarray:
    """The ``;``-joined kinds of the events spanning each sample ('' elsewhere)."""
    out = np.full(len(time), "", dtype=object)
    for event in store.events(ride_id):
        inside = (time >= event.start) & (time <= event.end)
        out[inside] = np.where(out[inside] == "", event.kind, out[inside] + ";" + event.kind)
    return out


def _iso(epoch: float) -> str:
    return dt.datetime.fromtimestamp(epoch, tz=dt.timezone.utc).isoformat()
