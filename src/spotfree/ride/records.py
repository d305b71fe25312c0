"""What the ride store holds: ride metadata, events, and the column names of samples and features.

Times inside a ride are seconds since the ride's ``started`` instant (UNIX epoch seconds), so a sample at
``time`` happened at ``started + time``. Units are SI (m/s^2, rad/s, m/s); ``lat``/``lon`` are WGS-84 degrees.
"""

from __future__ import annotations

from dataclasses import dataclass

from spotfree.io.recording import IMU_CHANNELS
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS

GPS_COLUMNS = ("lat", "lon", "speed")
"""Per-sample GPS: degrees, degrees, m/s; NaN on samples without a fix."""

SAMPLE_COLUMNS = ("time", *IMU_CHANNELS, *GPS_COLUMNS)
"""A raw sample: time (s since the ride started), ``ax ay az`` (m/s^2, gravity included) and ``gx gy gz``
(rad/s) in the device frame (Android: x right, y up, z out of the screen), then the GPS columns."""

FEATURE_COLUMNS = (*FEATURE_CHANNELS, *DERIVED_CHANNELS)
"""Ride features as :class:`~spotfree.signal.features.FeatureStream` produces them (vehicle frame x forward,
y left, z up; rad, rad/s, m/s^2)."""

RIDER_FIELDS = ("age_band", "gender", "skill")
"""Optional rider descriptors kept for comparisons between groups of riders (free text, e.g. ``65-74``)."""


@dataclass(frozen=True)
class Ride:
    """One recorded ride: who rode what, when, and with which model.

    ``started`` and ``ended`` are UNIX epoch seconds (``ended`` is None while the ride is open);
    ``continues_from`` the id of the same device's earlier ride that this one continues (None for a first piece).
    """

    ride_id: str
    device_id: str
    vehicle: str
    rider_id: str
    started: float
    ended: float | None = None
    model: str | None = None
    age_band: str | None = None
    gender: str | None = None
    skill: str | None = None
    continues_from: str | None = None


@dataclass(frozen=True)
class Event:
    """Something that happened during a ride from ``start`` to ``end`` (s since the ride started).

    ``kind`` names it (a class such as ``sudden-braking`` for a dangerous manoeuvre the rider was warned of);
    ``detail`` is free text (e.g. the peak deceleration).
    """

    kind: str
    start: float
    end: float
    detail: str = ""
