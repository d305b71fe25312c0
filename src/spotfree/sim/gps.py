"""GPS: the route on the map and the phone's 1 Hz fixes.

The ride's local East/North track (m) is placed at a start point near the origin and turned into latitude and
longitude with the WGS-84 radii of curvature at the origin's latitude::

    lat = lat0 + north / M,   lon = lon0 + east / (N cos(lat0)),
    M = a (1 - e^2) / (1 - e^2 sin^2 lat0)^(3/2),   N = a / sqrt(1 - e^2 sin^2 lat0)

A fix is taken every ``period`` seconds (at a random phase) and arrives ``latency`` seconds later, on the first
output sample at or after that instant; every other sample is NaN. Its position error is a first-order
Gauss-Markov process per axis (standard deviation ``position_sigma``, correlation time ``correlation_time``), the
slowly wandering error of a phone receiver; its speed is the true ground speed plus white noise, never negative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

WGS84_A = 6378137.0
"""Semi-major axis, m."""
WGS84_E2 = 6.69437999014e-3
"""First eccentricity squared."""


@dataclass(frozen=True)
class GpsSpec:
    """Receiver parameters (SI units, degrees for the origin)."""

    origin: tuple[float, float] = (36.0827, 140.1114)
    """(lat, lon) in degrees: central Tsukuba, Japan, where the paper's robotic zone is."""
    spread: float = 300.0
    """Rides start within this many metres of the origin (east and north)."""
    period: float = 1.0
    """s between fixes."""
    latency: float = 0.2
    """s from a fix's epoch to its arrival."""
    position_sigma: float = 2.0
    """m per axis: about 4.9 m horizontal at 95 % (2.45 sigma)."""
    correlation_time: float = 30.0
    """s"""
    speed_sigma: float = 0.15
    """m/s"""


def local_to_geodetic(east: np.ndarray, north: np.ndarray,
                      origin: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    """Latitude and longitude (degrees) of points ``east``, ``north`` metres from ``origin`` (lat, lon degrees)."""
    lat0 = np.deg2rad(origin[0])
    w = 1.0 - WGS84_E2 * np.sin(lat0) ** 2
    meridian = WGS84_A * (1.0 - WGS84_E2) / w**1.5
    normal = WGS84_A / np.sqrt(w)
    return origin[0] + np.rad2deg(north / meridian), origin[1] + np.rad2deg(east / (normal * np.cos(lat0)))


def gps_fixes(
    time: np.ndarray,
    east: np.ndarray,
    north: np.ndarray,
    speed: np.ndarray,
    rate: float,
    n_out: int,
    rng: np.random.Generator,
    spec: GpsSpec = GpsSpec(),
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sparse ``lat``, ``lon`` (degrees) and ``speed`` (m/s) on the ``n_out``-sample output grid at ``rate`` Hz.

    ``time``, ``east``, ``north`` (m) and ``speed`` (m/s) are the ride's truth on the internal grid.
    """
    start = rng.uniform(-spec.spread, spec.spread, 2)
    epochs = np.arange(rng.uniform(0.0, spec.period), time[-1], spec.period)
    samples = np.ceil(np.round((epochs + spec.latency) * rate, 9)).astype(int)
    keep = samples < n_out
    epochs, samples = epochs[keep], samples[keep]
    samples, first = np.unique(samples, return_index=True)
    epochs = epochs[first]

    rho = np.exp(-spec.period / spec.correlation_time)
    innovations = rng.normal(0.0, spec.position_sigma, (len(epochs), 2))
    innovations[1:] *= np.sqrt(1.0 - rho * rho)
    error = lfilter([1.0], [1.0, -rho], innovations, axis=0)  # e_j = rho e_(j-1) + innovation_j
    fix_east = np.interp(epochs, time, east) + start[0] + error[:, 0]
    fix_north = np.interp(epochs, time, north) + start[1] + error[:, 1]
    lat_fix, lon_fix = local_to_geodetic(fix_east, fix_north, spec.origin)
    speed_fix = np.abs(np.interp(epochs, time, speed)) + rng.normal(0.0, spec.speed_sigma, len(epochs))

    lat, lon, gps_speed = (np.full(n_out, np.nan) for _ in range(3))
    lat[samples], lon[samples], gps_speed[samples] = lat_fix, lon_fix, np.maximum(speed_fix, 0.0)
    return lat, lon, gps_speed
