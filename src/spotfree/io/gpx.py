"""GPX tracks (GPS Exchange Format, read and written with gpxpy) as sparse GPS channels.

Reading: every track point (all tracks and segments; route points when the file has no track) is a fix with
``lat``, ``lon`` (degrees), ``alt`` (m, from ``<ele>``), ``speed`` (m/s) and ``heading`` (rad, from ``<course>``
in degrees). Speed is ``<speed>`` (GPX 1.0) or a ``speed`` extension element (e.g. Garmin's
TrackPointExtension); when the file has neither it is derived from consecutive fixes of a segment, great-circle
distance over elapsed time (gpxpy's great-circle ``geo.distance``), and that is logged in ``meta['repairs']``. The
Recording spans the first to the last fix on a ``rate`` Hz grid, each fix on its nearest sample and NaN
elsewhere; times are seconds since the first fix, ``meta['start_epoch']`` is that fix in UNIX seconds.

Writing: one track with one segment per experiment, a point for each sample with finite ``lat`` and ``lon``,
timed ``meta['start_epoch']`` (0 when unknown) plus ``time``; written as GPX 1.0, where ``<speed>`` and
``<course>`` are standard elements.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import gpxpy
import gpxpy.geo
import gpxpy.gpx
import numpy as np

from spotfree.errors import InputError
from spotfree.io import checks
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams

CHANNELS = ("lat", "lon", "alt", "speed", "heading")
"""Channels read from and written to GPX."""


def read_gpx(path: str | Path, rate: float = 20.0) -> Recording:
    """A GPX file's fixes as sparse GPS channels on a ``rate`` Hz grid (see the module docstring)."""
    source = str(path)
    text = checks.read_text(Path(path))
    try:
        document = gpxpy.parse(text)
    except (gpxpy.gpx.GPXException, ValueError, TypeError, AttributeError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{source}: not a readable GPX file ({first}); export the track again") from None
    segments = [s.points for t in document.tracks for s in t.segments] or [r.points for r in document.routes]
    segments = [points for points in segments if points]
    if not segments:
        raise InputError(f"{source}: no track or route points; export the GPS track with its points")
    repairs: list[str] = []
    rows, times = [], []
    derived = False
    for points in segments:
        for i, point in enumerate(points):
            if point.time is None:
                raise InputError(f"{source}: track point {len(rows) + 1} has no <time>; export the track with times")
            speed = _speed(point)
            if speed is None:
                derived = True
                pair = (points[i - 1], point) if i > 0 else (point, points[i + 1]) if len(points) > 1 else None
                speed = _speed_between(*pair) if pair else None
            course = getattr(point, "course", None)
            heading = np.deg2rad(course) if course is not None else np.nan
            rows.append([point.latitude, point.longitude, _float(point.elevation), _float(speed), heading])
            times.append(_epoch(point.time))
    if derived:
        repairs.append(f"{source}: speed derived from consecutive fixes where the file gives none")
    t = np.array(times)
    values = np.array(rows, dtype=float)
    keep = checks.order_and_deduplicate(t, values, source, "time", repairs)
    t, values = t[keep], values[keep]
    if len(t) < 2:
        raise InputError(f"{source}: fewer than two timed points; a track needs at least two")
    origin = float(t[0])
    rec = merge_streams({"gpx": Stream(t - origin, values, CHANNELS)}, rate=rate, source=source)
    advice = ("a GPX track holds GPS fixes only, no motion sensors; record the ride with a phone app that logs the "
              "accelerometer and gyroscope (Sensor Logger, phyphox)")
    rec.meta.update(repairs=repairs, warnings=[], start_epoch=origin, format="GPX track", sensors=["GPS"],
                    missing={"accelerometer": advice, "gyroscope": advice})
    return rec


def write_gpx(rec: Recording, path: str | Path) -> None:
    """Write the fixes of ``rec`` (samples with finite ``lat`` and ``lon``) as a GPX 1.0 track."""
    if not {"lat", "lon"} <= set(rec.channels):
        raise InputError(f"{rec.source}: no 'lat' and 'lon' channels to write as GPX; record GPS to export a track")
    if not (np.isfinite(rec.channels["lat"]) & np.isfinite(rec.channels["lon"])).any():
        raise InputError(f"{rec.source}: 'lat'/'lon' hold no fix; nothing to write as GPX")
    document = gpxpy.gpx.GPX()
    track = gpxpy.gpx.GPXTrack()
    document.tracks.append(track)
    start = float(rec.meta.get("start_epoch", 0.0))
    for _, part in rec.experiments():
        segment = gpxpy.gpx.GPXTrackSegment()
        mask = np.isfinite(part.channels["lat"]) & np.isfinite(part.channels["lon"])
        for k in np.flatnonzero(mask):
            value = {c: float(part.channels[c][k]) if c in part.channels else np.nan for c in CHANNELS}
            point = gpxpy.gpx.GPXTrackPoint(
                value["lat"], value["lon"],
                elevation=_optional(value["alt"]),
                time=dt.datetime.fromtimestamp(start + float(part.time[k]), tz=dt.timezone.utc),
                speed=_optional(value["speed"]),
            )
            point.course = _optional(np.rad2deg(value["heading"]))
            segment.points.append(point)
        track.segments.append(segment)
    checks.write_text(Path(path), document.to_xml(version="1.0"))


def _speed_between(earlier, later) -> float | None:
    """Ground speed (m/s) from two timed points: great-circle distance over elapsed time (None if no time passed)."""
    if earlier.time is None or later.time is None:
        return None
    seconds = (later.time - earlier.time).total_seconds()
    if seconds <= 0:
        return None
    return gpxpy.geo.distance(earlier.latitude, earlier.longitude, None, later.latitude, later.longitude, None) / seconds


def _speed(point: gpxpy.gpx.GPXTrackPoint) -> float | None:
    """``<speed>`` of the point, or the first extension element named ``speed`` (any namespace), in m/s.

    Route and way points (``<rtept>``, ``<wpt>``) have no ``<speed>`` in gpxpy; only their extensions are read.
    """
    if getattr(point, "speed", None) is not None:
        return point.speed
    for extension in point.extensions:
        for element in extension.iter():
            if str(element.tag).rsplit("}", 1)[-1].lower() == "speed" and element.text:
                try:
                    return float(element.text)
                except ValueError:
                    return None
    return None


def _epoch(time: dt.datetime) -> float:
    """A GPX time in UNIX seconds (a time without zone is UTC, as GPX specifies)."""
    return (time if time.tzinfo else time.replace(tzinfo=dt.timezone.utc)).timestamp()


def _float(value: float | None) -> float:
    return np.nan if value is None else float(value)


def _optional(value: float) -> float | None:
    return None if not np.isfinite(value) else value
