"""Mount detection: the rotation from the device frame to the vehicle frame, estimated from a ride.

Device frame as Android's (x right, y up along the screen, z out of the screen); vehicle frame x forward, y left,
z up. A mount is the matrix ``M`` with ``v_vehicle = M @ v_device``; its rows are the vehicle's forward, left and
up axes written in device coordinates.

* **Up** is the mean direction of the specific force over the quiet samples (rotation rate below
  :data:`QUIET_RATE` and specific-force magnitude within :data:`QUIET_FORCE` of g): at rest or cruising the
  accelerometer reads gravity only.
* **Forward** comes from the GPS speed. A change of speed ``dv/dt`` goes with (a) a horizontal specific force along
  the direction of travel and (b), on a self-balancing vehicle, a lean about the vehicle's left axis (it leans
  into the acceleration, which is what keeps the specific force near its body axis). Both are regressed on
  ``dv/dt`` at the GPS fixes: (a) the specific force perpendicular to up, (b) the leaky integral of the rotation
  rate perpendicular to up (:func:`~spotfree.signal.features.leaky_lean` on each axis). Each gives a direction
  and a correlation with ``dv/dt``; the more correlated one is kept. Without GPS speed (or with too little
  change of speed), forward is taken as the top edge of the phone, or its back when it stands upright (the
  horizontal part of ``y - z``): the phone faces the rider, top edge forward or up.

The estimate is *usual* when it is within :data:`USUAL_ANGLE` of the nominal mount (:data:`~spotfree.signal.frame.MOUNT`,
flat on the handlebar, top edge forward); then the nominal mount is used and the attitude filter takes up the small
difference, as it always did. Otherwise the estimate is used and a warning says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.signal import lfilter

from spotfree.errors import InputError
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS, Recording
from spotfree.signal.frame import GRAVITY, MOUNT

QUIET_RATE = 0.3
"""Rotation-rate magnitude (rad/s) below which a sample may count as at rest or cruising."""

QUIET_FORCE = 1.0
"""Largest difference (m/s^2) between the specific-force magnitude and g of a quiet sample."""

MIN_QUIET = 0.05
"""Fewest quiet samples, as a fraction of the log, for a trusted vertical."""

MIN_CORRELATION = 0.5
"""Least correlation with the GPS speed change for a forward direction from the data."""

MIN_SPEED_CHANGE = 0.1
"""Least standard deviation of ``dv/dt`` (m/s^2) at the fixes for a forward direction from the data."""

USUAL_ANGLE = np.deg2rad(15.0)
"""An estimate within this angle of the nominal mount is usual: the nominal mount is used."""

LEAN_TIME_CONSTANT = 2.0
"""Time constant (s) of the leaky integral that turns rotation rate into lean."""

PRESETS = {
    "flat": MOUNT,
    "upright": np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
}
"""Named mounts for ``--mount``: flat on the handlebar, top edge forward (the nominal mount); standing upright in a
holder, portrait, screen towards the rider (forward is the phone's back, up its top edge)."""


@dataclass
class MountEstimate:
    """A device-to-vehicle rotation and how it was found.

    ``matrix`` (3, 3): ``v_vehicle = matrix @ v_device``; ``estimated`` the rotation the data give, ``used`` the
    one features use (the nominal mount when the estimate is usual, or the ``--mount`` choice); ``source`` says
    where forward came from; ``quiet`` the fraction of quiet samples; ``correlation`` of the forward cue with the
    GPS speed change (NaN without one); ``warnings`` one line each; ``choice`` the ``--mount`` choice."""

    estimated: np.ndarray
    used: np.ndarray
    source: str
    quiet: float
    correlation: float
    warnings: list[str] = field(default_factory=list)
    choice: str = "auto"

    @property
    def angle_from_nominal(self) -> float:
        """Angle (rad) of the rotation from the nominal mount to the estimate."""
        return rotation_angle(self.estimated @ MOUNT.T)

    def describe(self) -> str:
        """One line: the estimate as the phone's tilt and turn relative to the nominal mount, and what is used."""
        up = self.estimated[2]
        tilt = np.degrees(np.arccos(np.clip(up[2], -1, 1)))
        forward = self.estimated[0]
        return (f"mount: up is {_axes(up)}, forward is {_axes(forward)} (device frame; {tilt:.0f} deg from "
                f"screen-up), {np.degrees(self.angle_from_nominal):.0f} deg from flat with the top edge forward; "
                f"forward from {self.source}; "
                + (f"using the --mount {self.choice} choice" if self.choice != "auto" else
                   "using the nominal mount" if np.allclose(self.used, MOUNT) else "using the estimate"))


def _axes(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{c:+.2f}" for c in v) + ")"


def rotation_angle(r: np.ndarray) -> float:
    """Angle (rad) of the rotation matrix ``r``."""
    return float(np.arccos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)))


def estimate_mount(rec: Recording, choice: str = "auto") -> MountEstimate:
    """The device-to-vehicle rotation of ``rec`` (raw IMU in the device frame; GPS ``speed`` used when present).

    ``choice``: ``auto`` (the nominal mount when the estimate is usual, else the estimate), ``estimate`` (always
    the estimate), or a name of :data:`PRESETS`. See the module docstring for the method."""
    if choice not in ("auto", "estimate", *PRESETS):
        raise InputError(f"--mount {choice!r} is not known; give auto, estimate, {', '.join(PRESETS)}")
    rec.require_imu("mount detection")
    acc, gyr = rec.array(ACC_CHANNELS), rec.array(GYRO_CHANNELS)
    valid = np.all(np.isfinite(acc), axis=1) & np.all(np.isfinite(gyr), axis=1)
    warnings = []
    quiet = valid & (np.linalg.norm(gyr, axis=1) < QUIET_RATE) & \
        (np.abs(np.linalg.norm(acc, axis=1) - GRAVITY) < QUIET_FORCE)
    fraction = float(quiet.sum() / max(valid.sum(), 1))
    if fraction < MIN_QUIET:
        warnings.append(f"{rec.source}: only {100 * fraction:.0f} % of the samples are at rest or cruising; the "
                        f"vertical is the mean over the whole log and may be off")
        quiet = valid
    up = _unit(acc[quiet].mean(axis=0))
    forward, source, correlation = _forward_from_speed(rec, acc, gyr, valid, up)
    if forward is None:
        forward = _unit(_horizontal(np.array([0.0, 1.0, -1.0]), up))
        source = "the phone's top edge (or back, when upright): no GPS speed change to tell"
        if rec.channels.get("speed") is not None:
            warnings.append(f"{rec.source}: the GPS speed changes too little to tell the direction of travel; "
                            f"assumed the phone's top edge (or back) points forward")
    left = np.cross(up, forward)
    estimated = np.vstack([forward, left, up])
    used = {"auto": None, "estimate": estimated, **PRESETS}[choice]
    result = MountEstimate(estimated, estimated, source, fraction, correlation, warnings, choice)
    if used is None:
        unusual = result.angle_from_nominal > USUAL_ANGLE
        used = estimated if unusual else MOUNT
        if unusual:
            warnings.append(f"{rec.source}: the phone is mounted {np.degrees(result.angle_from_nominal):.0f} deg "
                            f"from flat with its top edge forward; features use the estimated mount (override "
                            f"with --mount flat|upright|estimate)")
    result.used = np.asarray(used, dtype=float)
    return result


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _horizontal(v: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The part of ``(..., 3)`` vectors perpendicular to the unit vector ``up``."""
    return v - np.outer(v @ up, up).reshape(np.shape(v)) if np.ndim(v) > 1 else v - (v @ up) * up


def _forward_from_speed(rec, acc, gyr, valid, up):
    """``(forward, source, correlation)`` from the GPS speed changes, or ``(None, '', nan)``."""
    speed = rec.channels.get("speed")
    if speed is None:
        return None, "", float("nan")
    fixes = np.flatnonzero(np.isfinite(speed) & valid)
    if len(fixes) < 8:
        return None, "", float("nan")
    t, v = rec.time[fixes], speed[fixes]
    dvdt = np.gradient(v, t)
    if np.std(dvdt) < MIN_SPEED_CHANGE:
        return None, "", float("nan")
    fill = np.where(valid[:, None], acc, np.nan)
    force = _horizontal(np.where(np.isfinite(fill), fill, up * GRAVITY), up)
    rate = np.where(valid[:, None], gyr, 0.0)
    c = np.exp(-1.0 / (LEAN_TIME_CONSTANT * rec.rate))
    lean = lfilter([1.0 / rec.rate], [1.0, -c], _horizontal(rate, up), axis=0)
    span = max(1, int(round(rec.rate)))
    smooth = np.ones(span) / span
    cues = {
        "the specific force that goes with GPS speed changes":
            (lambda w: _unit(w), np.apply_along_axis(np.convolve, 0, force, smooth, mode="same")[fixes]),
        "the lean that goes with GPS speed changes":
            (lambda w: _unit(np.cross(w, up)), lean[fixes]),
    }
    best = (None, "", -np.inf)
    for name, (direction, x) in cues.items():
        x = x - x.mean(axis=0)
        d = dvdt - dvdt.mean()
        w = x.T @ d / (d @ d)
        fitted = x @ _unit(w)
        r = float(np.corrcoef(fitted, d)[0, 1]) if np.std(fitted) > 0 else 0.0
        if r > best[2]:
            best = (direction(w), name, r)
    if best[2] < MIN_CORRELATION:
        return None, "", best[2]
    return best
