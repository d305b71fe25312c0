"""One stored ride processed: features, labels of every model, braking events, and the rows written for it.

:func:`process_ride` takes a ride's metadata and raw samples (as :meth:`RideStore.samples` gives them) and
returns three tables:

* ``ride``: one row: the ride's metadata (vehicle, rider and its descriptors), ``date`` (UTC day it started),
  ``place`` (:func:`place_cell` of its first fix), ``duration_s`` (measured samples / rate), ``distance_m``
  (the ride assistant's GPS distance), ``samples``, ``braking_events``, ``sudden_stops``, ``mean_speed`` (m/s,
  over samples moving faster than :data:`MOVING` m/s) and the ``config`` digest of the models that made it;
* ``samples``: one row per measured sample: ``time`` (s since the ride started), ``speed`` (m/s, the
  assistant's: last fix, NaN after 5 s without one), ``decel`` (m/s^2, ``-acc_long``: the vehicle-frame
  forward acceleration of the ride features, x forward, positive when slowing down) and ``label_<model>`` for
  each model;
* ``events``: ``braking`` episodes (a label of :data:`BRAKING` classes) and ``sudden-braking`` episodes, each
  debounced as the rider's warnings are (:class:`~spotfree.ride.assistant.RideAssistant`), with
  ``peak_decel`` (m/s^2, the largest ``decel`` inside the episode) and ``onset_speed`` (m/s).

A sudden stop is also a braking episode (its lean passes through normal braking), so the sudden-stop rate is
``sudden_stops / braking_events``.
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd

from spotfree.classify.batch import classify_recording, dictionary_classifier, model_features
from spotfree.errors import InputError
from spotfree.io.recording import IMU_CHANNELS, Recording
from spotfree.model import DictionaryModel
from spotfree.ride.assistant import RideAssistant
from spotfree.ride.records import RIDER_FIELDS, Ride

BRAKING_MODEL = "braking"
"""The model whose labels make the braking events (its classes as the simulator names them)."""
BRAKING = ("normal-braking", "sudden-braking")
SUDDEN = "sudden-braking"
MOVING = 0.5
"""m/s: a sample is moving above this speed (for ``mean_speed``)."""
EVENT_TYPES = {"kind": str, "start": float, "end": float, "peak_decel": float, "onset_speed": float}
"""Columns of the events table after ``ride_id``."""
PLACE_STEP = 0.1
"""degrees: size of the latitude/longitude cell that names a ride's place (about 11 km north-south)."""


def place_cell(lat: float, lon: float) -> str:
    """The cell of ``PLACE_STEP`` degrees holding (lat, lon), named by its south-west corner, e.g. ``35.6N139.7E``;
    ``unknown`` without a fix."""
    if not (math.isfinite(lat) and math.isfinite(lon)):
        return "unknown"
    south = math.floor(lat / PLACE_STEP + 1e-9) * PLACE_STEP
    west = math.floor(lon / PLACE_STEP + 1e-9) * PLACE_STEP
    return f"{abs(south):.1f}{'N' if south >= 0 else 'S'}{abs(west):.1f}{'E' if west >= 0 else 'W'}"


def gridded(samples: dict[str, np.ndarray], source: str) -> Recording:
    """Stored samples on their uniform grid (``rate`` from the median step), NaN on the samples not stored."""
    time = np.asarray(samples["time"], dtype=float)
    if len(time) < 2:
        raise InputError(f"{source}: {len(time)} samples stored; a ride needs at least two to be processed")
    rate = float(np.round(1.0 / np.median(np.diff(time)), 6))
    index = np.rint((time - time[0]) * rate).astype(int)
    keep = np.r_[True, np.diff(index) > 0]
    grid = np.full(index[-1] + 1, np.nan)
    channels = {}
    for name, column in samples.items():
        if name != "time":
            channels[name] = grid.copy()
            channels[name][index[keep]] = np.asarray(column, dtype=float)[keep]
    return Recording(time[0] + np.arange(len(grid)) / rate, channels, rate, source=source)


def process_ride(ride: Ride, samples: dict[str, np.ndarray], models: dict[str, DictionaryModel],
                 config: str, classifiers: dict | None = None) -> dict[str, pd.DataFrame]:
    """The ``ride``, ``samples`` and ``events`` tables of one ride (see the module docstring).

    ``models`` maps names to models and must hold :data:`BRAKING_MODEL`; ``classifiers`` may hold classifiers
    already fitted by :func:`dictionary_classifier` under the same names (fitted here otherwise).
    """
    if BRAKING_MODEL not in models:
        raise InputError(f"fleet process: no '{BRAKING_MODEL}' model given; name one '{BRAKING_MODEL}=PATH'")
    classifiers = classifiers if classifiers is not None else {}
    rec = gridded(samples, f"ride {ride.ride_id}")
    feats = model_features(models[BRAKING_MODEL], rec)
    measured = rec.valid() & np.all(np.isfinite(rec.array(list(IMU_CHANNELS))), axis=1)
    labels = {}
    for name, model in models.items():
        clf = classifiers.get(name) or dictionary_classifier(model, causal=True)
        labels[name] = classify_recording(model, feats if name == BRAKING_MODEL else rec, classifier=clf).label
    decel = -feats.channels["acc_long"]
    speed, distance, events = _assist(rec, labels[BRAKING_MODEL], decel, measured)
    table = pd.DataFrame({"ride_id": ride.ride_id, "time": rec.time, "speed": speed, "decel": decel,
                          **{f"label_{n}": np.where(v == "", None, v) for n, v in labels.items()}})[measured]
    lat, lon = rec.channels.get("lat", np.array([])), rec.channels.get("lon", np.array([]))
    fix = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon))
    moving = table["speed"] > MOVING
    row = {
        "ride_id": ride.ride_id, "rider_id": ride.rider_id, "vehicle": ride.vehicle,
        **{k: getattr(ride, k) for k in RIDER_FIELDS},
        "date": dt.datetime.fromtimestamp(ride.started, tz=dt.timezone.utc).date().isoformat(),
        "place": place_cell(lat[fix[0]], lon[fix[0]]) if len(fix) else "unknown",
        "started": ride.started, "duration_s": float(measured.sum() / rec.rate), "distance_m": distance,
        "samples": int(measured.sum()),
        "braking_events": int((events["kind"] == "braking").sum()),
        "sudden_stops": int((events["kind"] == SUDDEN).sum()),
        "mean_speed": float(table["speed"][moving].mean()) if moving.any() else math.nan,
        "config": config,
    }
    events.insert(0, "ride_id", ride.ride_id)
    return {"ride": pd.DataFrame([row]), "samples": table.reset_index(drop=True), "events": events}


def _assist(rec: Recording, label: np.ndarray, decel: np.ndarray,
            measured: np.ndarray) -> tuple[np.ndarray, float, pd.DataFrame]:
    """Per-sample speed, the ride's distance (m) and its braking and sudden-braking events."""
    braking = RideAssistant(dangerous=("braking",))
    sudden = RideAssistant(dangerous=(SUDDEN,))
    nan = np.full(len(rec), np.nan)
    lat, lon, gps_speed = (rec.channels.get(c, nan) for c in ("lat", "lon", "speed"))
    speed = np.full(len(rec), np.nan)
    distance = 0.0
    for k in np.flatnonzero(measured):
        name = label[k] or None
        braking.update(rec.time[k], "braking" if name in BRAKING else name)
        status = sudden.update(rec.time[k], name, lat[k], lon[k], gps_speed[k])
        speed[k], distance = status.speed, status.distance
    rows = []
    for event in [*braking.finish(), *sudden.finish()]:
        inside = (rec.time >= event.start) & (rec.time <= event.end) & measured
        onset = int(np.searchsorted(rec.time, event.start))
        rows.append({"kind": event.kind, "start": event.start, "end": event.end,
                     "peak_decel": float(np.nanmax(decel[inside])) if inside.any() else math.nan,
                     "onset_speed": float(speed[onset])})
    events = pd.DataFrame(rows, columns=list(EVENT_TYPES)).astype(EVENT_TYPES)
    return speed, float(distance), events.sort_values(["start", "kind"], ignore_index=True)
