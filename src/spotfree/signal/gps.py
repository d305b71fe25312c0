"""GPS features: what a track without motion sensors gives (a GPX file, or a phone log with Location only).

Per sample of the Recording's grid, from its sparse GPS fixes (``lat``, ``lon`` in degrees, ``speed`` in m/s):

* ``speed`` (m/s): the fixes' ground speed (the great-circle distance between consecutive fixes over their time
  where a fix has none), linearly interpolated between fixes, NaN before the first and after the last fix of an
  experiment;
* ``distance`` (m): the great-circle distance travelled since the experiment's first fix (gpxpy's ``geo.distance``
  between consecutive fixes, summed), interpolated the same way;
* ``gps_acc_long`` (m/s^2, along the direction of travel, positive when speeding up): the slope of a straight line
  fitted to the speed of the fixes within :data:`SLOPE_SPAN` seconds either side of each fix, interpolated.

Attitude and accelerations need the accelerometer and gyroscope; these channels are all a track alone can give.
"""

from __future__ import annotations

import gpxpy.geo
import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import Recording

GPS_FEATURES = ("speed", "distance", "gps_acc_long")

SLOPE_SPAN = 2.0
"""Half-width (s) of the window of fixes whose speed is fitted by a line for ``gps_acc_long``."""


def has_gps(rec: Recording) -> bool:
    """True when ``rec`` has fixes with a position or a speed."""
    return any(c in rec.channels and np.isfinite(rec.channels[c]).any() for c in ("lat", "speed"))


def gps_features(rec: Recording) -> Recording:
    """The :data:`GPS_FEATURES` of ``rec`` on its grid (same experiments and truth); see the module docstring."""
    if not has_gps(rec):
        raise InputError(f"{rec.source}: no GPS fixes (lat, lon or speed); GPS features need a track")
    out = {name: np.full(len(rec), np.nan) for name in GPS_FEATURES}
    experiment = rec.experiment_numbers()
    for number in np.unique(experiment):
        rows = np.flatnonzero(experiment == number)
        fixes = rows[_fix_mask(rec, rows)]
        if len(fixes) < 2:
            continue
        t = rec.time[fixes]
        travelled = _distance(rec, fixes)
        speed = rec.channels["speed"][fixes] if "speed" in rec.channels else np.full(len(fixes), np.nan)
        derived = np.gradient(travelled, t)
        speed = np.where(np.isfinite(speed), speed, derived)
        inside = rows[(rec.time[rows] >= t[0]) & (rec.time[rows] <= t[-1])]
        for name, values in (("speed", speed), ("distance", travelled), ("gps_acc_long", _slopes(t, speed))):
            good = np.isfinite(values)
            if good.sum() >= 2:
                out[name][inside] = np.interp(rec.time[inside], t[good], values[good])
    feats = rec.with_channels(out)
    feats.meta.update(features="gps")
    return feats


def _fix_mask(rec: Recording, rows: np.ndarray) -> np.ndarray:
    """Which of ``rows`` hold a fix (a position, or a speed when the log has no positions)."""
    if "lat" in rec.channels and "lon" in rec.channels:
        return np.isfinite(rec.channels["lat"][rows]) & np.isfinite(rec.channels["lon"][rows])
    return np.isfinite(rec.channels["speed"][rows])


def _distance(rec: Recording, fixes: np.ndarray) -> np.ndarray:
    """Cumulative great-circle distance (m) along ``fixes``; from the speed's integral when there are no positions."""
    if "lat" not in rec.channels or "lon" not in rec.channels:
        speed = rec.channels["speed"][fixes]
        t = rec.time[fixes]
        return np.concatenate([[0.0], np.cumsum(np.diff(t) * (speed[1:] + speed[:-1]) / 2)])
    lat, lon = rec.channels["lat"][fixes], rec.channels["lon"][fixes]
    steps = [gpxpy.geo.distance(lat[i], lon[i], None, lat[i + 1], lon[i + 1], None) for i in range(len(fixes) - 1)]
    return np.concatenate([[0.0], np.cumsum(steps)])


def _slopes(t: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """Least-squares slope (m/s^2) of ``speed`` against ``t`` over the fixes within :data:`SLOPE_SPAN` of each."""
    out = np.full(len(t), np.nan)
    for i, centre in enumerate(t):
        near = (np.abs(t - centre) <= SLOPE_SPAN) & np.isfinite(speed)
        if near.sum() >= 2 and np.ptp(t[near]) > 0:
            out[i] = np.polyfit(t[near], speed[near], 1)[0]
    return out
