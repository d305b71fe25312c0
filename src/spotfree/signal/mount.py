"""Mount detection: the rotation from the device frame to the vehicle frame, estimated from a ride.

Device frame as Android's (x right, y up along the screen, z out of the screen); vehicle frame x forward, y left,
z up. A mount is the matrix ``M`` with ``v_vehicle = M @ v_device``; its rows are the vehicle's forward, left and
up axes written in device coordinates.

* **Up** is the mean direction of the specific force over the quiet samples (rotation rate below
  :data:`QUIET_RATE` and specific-force magnitude within :data:`QUIET_FORCE` of g): at rest or cruising the
  accelerometer reads gravity only.
* **Forward** comes from the GPS speed. Between two fixes at least :data:`MIN_INTERVAL` s apart, the speed change
  ``d = (v_k - v_j) / (t_k - t_j)`` is the mean longitudinal acceleration, and goes with (a) the mean specific force
  over those samples, whose horizontal part points along the direction of travel, and (b), on a self-balancing
  vehicle, the mean lean about the vehicle's left axis (it leans into the acceleration, which keeps the specific
  force near its body axis): the leaky integral ``L[n] = c L[n-1] + w[n] / f_s``, ``c = exp(-1 / (tau f_s))``,
  ``tau = LEAN_TIME_CONSTANT``, of the rotation rate ``w``. In a turn both also carry the centripetal
  acceleration ``c = v_m (w_m . up)`` (``v_m`` the mean of the two fixes' speeds, ``w_m`` the mean rotation rate,
  ``up`` the vertical of the quiet samples so far) along the left axis, and riders slow into turns, so ``c`` is a
  second regressor. For each cue ``x`` (a device-frame 3-vector per interval) forward is the horizontal part of
  the coefficient of ``d`` in ``x ~ d + c``, ``u = P (S_xd S_cc - S_xc S_dc)``, normalised (``P = I - up up^T``,
  ``S`` centred sums over the intervals), and ``r`` the partial correlation of ``u . x`` with ``d`` given ``c``;
  the more correlated cue is kept: forward is ``u`` (force) or ``u x up`` (lean), if ``r`` is significant
  (:data:`SIGNIFICANCE`). Without GPS speed (or with too little change of speed, or no significant correlation)
  forward is the phone's top edge, or its back when it stands upright (the horizontal part of ``y - z``): the
  phone faces the rider, top edge forward or up.

Two things the samples cannot tell are said, not guessed:

* **A bias or a tilt.** A constant accelerometer bias ``b`` across the vertical turns the mean specific force as a
  tilt of the mount does; only the magnitude shows it: with ``m`` the magnitude of the mean specific force,
  a bias across the vertical gives ``m = sqrt(g^2 + |b|^2)``, i.e. a tilt of up to ``acos(g / m)``. When ``m``
  differs from g by more than :data:`FORCE_TOLERANCE`, the report says that the tilt may be the accelerometer's.
* **A flipped accelerometer.** An accelerometer that reads minus the specific force (iOS's acceleration, in g)
  with a right gyroscope is the mirror image of a right ride: every cue above agrees with it, and the estimate
  says the phone is upside down. The GPS track breaks the symmetry: the gyroscope's rotation about the estimated
  vertical must turn the way the track turns (:func:`track_turns`). When it significantly turns the other way the
  flip is reported with its fix; when the track cannot tell and the phone seems upside down, both readings are
  named.

All of it rests on running sums (:class:`MountStatistics`), so the same numbers come from a whole log
(:func:`estimate_mount`) and from a live ride sample by sample (:class:`MountTracker`, whose twin in the phone page
is ``MountTracker`` in ``ride/static/pipeline.js``).

The estimate is *usual* when it is within :data:`USUAL_ANGLE` of the nominal mount
(:data:`~spotfree.signal.frame.MOUNT`, flat on the handlebar, top edge forward); then the nominal mount is used, as
before mount detection, and the small difference stays in the features (a constant offset of roll and pitch, and a
little of ``acc_y`` in ``acc_x`` for a turn about the vertical). Otherwise the estimate is used and a warning says
so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS, Recording
from spotfree.signal.frame import GRAVITY, MOUNT

QUIET_RATE = 0.3
"""Rotation-rate magnitude (rad/s) below which a sample may count as at rest or cruising."""

QUIET_FORCE = 1.0
"""Largest difference (m/s^2) between the specific-force magnitude and g of a quiet sample."""

MIN_QUIET = 0.05
"""Fewest quiet samples, as a fraction of the log, for a trusted vertical."""

MIN_INTERVAL = 1.0
"""Least time (s) between the two GPS fixes of a speed change."""

MIN_INTERVALS = 8
"""Fewest speed changes for a forward direction from the data."""

SIGNIFICANCE = 1e-4
"""Largest chance that speed changes unrelated to every direction fit one as well: with ``n`` changes the
two-direction fit of a cue (the turn held) reaches a correlation ``r`` by chance with probability
``(1 - r^2)^((n - 4) / 2)`` (Gaussian noise). Below this the forward direction is taken from the data: e.g. ``r``
above 0.74 over 30 changes, above 0.53 over 60. Strict, because consecutive intervals are not quite independent."""

MIN_SPEED_CHANGE = 0.1
"""Least standard deviation of the speed changes ``d`` (m/s^2) for a forward direction from the data."""

USUAL_ANGLE = np.deg2rad(15.0)
"""An estimate within this angle of the nominal mount is usual: the nominal mount is used."""

FORCE_TOLERANCE = 0.25
"""Largest difference (m/s^2) between the magnitude of the mean specific force over a log and g of a sound
accelerometer; beyond it a bias or a scale error is reported (module docstring)."""

TRACK_CHORD = 3
"""Fixes spanned by each chord of the GPS track whose bearings give the track's turns (:func:`track_turns`)."""

TRACK_MIN_CHORD = 6.0
"""Shortest chord (m) whose bearing counts: a phone's position error moves it by about half a metre per second."""

EARTH_RADIUS = 6371000.0
"""Mean Earth radius (m), for the local east and north of GPS fixes."""

LEAN_TIME_CONSTANT = 2.0
"""Time constant (s) of the leaky integral that turns rotation rate into lean."""

LIVE_QUIET_SECONDS = 3.0
"""Seconds of quiet samples a live ride needs before it trusts its vertical."""

UNCERTAIN_SECONDS = 60.0
"""Seconds into a live ride after which a mount not yet known from the data is reported as uncertain."""

PRESETS = {
    "flat": MOUNT,
    "upright": np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
}
"""Named mounts for ``--mount``: flat on the handlebar, top edge forward (the nominal mount); standing upright in a
holder, portrait, screen towards the rider (forward is the phone's back, up its top edge)."""

TOP_EDGE_SOURCE = "the phone's top edge (or back, when upright): no GPS speed change to tell"
"""Where forward came from when the GPS speed did not tell."""

REPORT_KINDS = ("mount", "unusual-mount", "uncertain-mount")
"""The kinds of :class:`MountTracker`'s reports: the mount decided (usual, or unusual and used), the doubt."""

_CUES = ("the specific force that goes with GPS speed changes", "the lean that goes with GPS speed changes")


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
    force: float = GRAVITY
    """Magnitude (m/s^2) of the mean specific force over the log: g, give or take what the rider's accelerations
    leave in the mean, for a sound accelerometer."""

    @property
    def biased(self) -> bool:
        """Whether :attr:`force` is more than :data:`FORCE_TOLERANCE` from g: a tilt may be the accelerometer's."""
        return abs(self.force - GRAVITY) > FORCE_TOLERANCE

    def _bias_said(self) -> str:
        """What the accelerometer reads, when :attr:`biased`, as the reports say it."""
        return f"its mean specific force is {self.force:.2f} m/s^2, not g = {GRAVITY:.2f}"

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
                f"screen-up), {np.degrees(self.angle_from_nominal):.0f} deg from flat with the top edge forward"
                + (f" or an accelerometer bias ({self._bias_said()})" if self.biased else "")
                + f"; forward from {self.source}"
                + (f" (correlation {self.correlation:.2f}); " if self.source != TOP_EDGE_SOURCE else "; ")
                + (f"using the --mount {self.choice} choice" if self.choice != "auto" else
                   "using the nominal mount" if np.allclose(self.used, MOUNT) else "using the estimate"))


    def brief(self) -> str:
        """:meth:`describe` in at most 100 characters (an event's detail in the ride record)."""
        tilt = np.degrees(np.arccos(np.clip(self.estimated[2, 2], -1, 1)))
        forward = f"GPS speed (r {self.correlation:.2f})" if self.source != TOP_EDGE_SOURCE else "top edge or back"
        used = "nominal" if np.allclose(self.used, MOUNT) else "estimate"
        return (f"{np.degrees(self.angle_from_nominal):.0f} deg from flat ({tilt:.0f} deg tilt); forward from "
                f"{forward}; {used} used")


def _axes(v: np.ndarray) -> str:
    return "(" + ", ".join(f"{c:+.2f}" for c in v) + ")"


def rotation_angle(r: np.ndarray) -> float:
    """Angle (rad) of the rotation matrix ``r``."""
    return float(np.arccos(np.clip((np.trace(r) - 1) / 2, -1.0, 1.0)))


MOUNT_STATE = np.dtype([
    ("valid", "f8"), ("quiet", "f8"), ("force", "f8", 3), ("quiet_force", "f8", 3), ("lean", "f8", 3),
    ("fix", "f8", 2), ("has_fix", "?"), ("inside", "f8"), ("inside_sums", "f8", 9),
    ("n", "f8"), ("d", "f8"), ("dd", "f8"), ("c", "f8"), ("cc", "f8"), ("dc", "f8"),
    ("x", "f8", (2, 3)), ("xd", "f8", (2, 3)), ("xc", "f8", (2, 3)), ("xx", "f8", (2, 3, 3)),
])
"""Record of :class:`MountStatistics`: sample counts and force sums (all valid, quiet), the leaky lean, the open
interval (its starting fix ``(t, v)``, sample count and sums of force, lean and rotation rate), and the sums over
closed intervals (``n``, ``d``, ``dd``, ``c``, ``cc``, ``dc``; per cue ``x``, ``xd``, ``xc``, ``xx``)."""


class MountStatistics:
    """Running sums of a ride for its mount (see the module docstring), one sample or one block at a time.

    Per valid sample: the count and specific-force sum of all and of the quiet samples, the leaky lean integral,
    and the sums of the open speed-change interval; per closed interval, for the speed change ``d``, the turn ``c``
    and each cue ``x`` (mean specific force, mean lean; device frame): ``n``, the sums of ``d``, ``c``, ``d^2``,
    ``c^2``, ``d c``, and of ``x``, ``x d``, ``x c``, ``x x^T``. One compiled kernel (:func:`_accumulate`) takes
    a sample or a block; ``MountStatistics`` in ``ride/static/pipeline.js`` does the same operations in the same
    order. ``state_`` is the :data:`MOUNT_STATE` record (a one-element array)."""

    def __init__(self, rate: float):
        self.rate = float(rate)
        self.lean_c = math.exp(-1.0 / (LEAN_TIME_CONSTANT * self.rate))
        self.state_ = np.zeros(1, MOUNT_STATE)

    def update(self, t: float, acc, gyr, speed: float = math.nan) -> bool:
        """Take one sample at ``t`` (s): ``acc`` (m/s^2, gravity included) and ``gyr`` (rad/s) device-frame
        3-vectors, ``speed`` (m/s) on a GPS fix, NaN otherwise. True when it closed a speed-change interval."""
        return self.take(np.array([[t, *acc, *gyr, speed]]))[1]

    def update_block(self, rows: np.ndarray) -> None:
        """:meth:`update` for each row ``(t, ax, ay, az, gx, gy, gz, speed)`` of ``rows`` ``(n, 8)``."""
        self.take(rows)

    def take(self, rows: np.ndarray, quiet_target: float = math.inf, stop_on_close: bool = False,
             until: float = math.inf) -> tuple[int, bool]:
        """Take the rows ``(t, ax, ay, az, gx, gy, gz, speed)`` of ``rows`` ``(n, 8)`` up to the first after which
        the quiet samples number ``quiet_target``, an interval closed (with ``stop_on_close``) or ``t >= until``
        (s): ``(rows taken, whether the last closed an interval)``."""
        return _accumulate(self.state_, np.ascontiguousarray(rows, dtype=float), self.lean_c, 1.0 / self.rate,
                           QUIET_RATE, QUIET_FORCE, GRAVITY, MIN_INTERVAL, quiet_target, stop_on_close, until)

    @property
    def quiet(self) -> int:
        """Quiet samples so far."""
        return int(self.state_[0]["quiet"])

    @property
    def valid(self) -> int:
        """Valid (finite) samples so far."""
        return int(self.state_[0]["valid"])

    def up(self, min_quiet: float = MIN_QUIET) -> tuple[np.ndarray, bool]:
        """``(up, trusted)``: the unit vertical (device frame) from the quiet samples, or from all of them
        (``trusted`` False) when fewer than ``min_quiet`` of them are quiet."""
        s = self.state_[0]
        trusted = s["quiet"] > 0 and s["quiet"] >= min_quiet * s["valid"]
        return _unit(s["quiet_force"] if trusted else s["force"]), trusted

    def forward(self, up: np.ndarray) -> tuple[np.ndarray | None, str, float]:
        """``(forward, source, r)`` from the speed changes (``forward`` a horizontal unit vector, device frame), or
        ``(None, '', r)`` with fewer than :data:`MIN_INTERVALS` changes, too little change or no significant ``r``
        (``r`` NaN when not computed)."""
        s = self.state_[0]
        n = float(s["n"])
        if n < MIN_INTERVALS:
            return None, "", math.nan
        sdd = s["dd"] - s["d"] * s["d"] / n
        if sdd <= 0 or math.sqrt(sdd / n) < MIN_SPEED_CHANGE:
            return None, "", math.nan
        scc = s["cc"] - s["c"] * s["c"] / n
        sdc = s["dc"] - s["d"] * s["c"] / n
        turns = scc > 0 and sdd * scc - sdc * sdc > 0
        best = (None, "", -math.inf)
        for cue, name in enumerate(_CUES):
            sx = s["x"][cue]
            sxd = s["xd"][cue] - sx * s["d"] / n
            sxc = s["xc"][cue] - sx * s["c"] / n
            sxx = s["xx"][cue] - np.outer(sx, sx) / n
            w = _horizontal(sxd * scc - sxc * sdc if turns else sxd, up)
            size = float(np.linalg.norm(w))
            if size == 0:
                continue
            u = w / size
            zd, zc, zz = float(u @ sxd), float(u @ sxc), float(u @ sxx @ u)
            if turns:  # partial correlation with d, the turn c held
                zd, zz, dd = zd - zc * sdc / scc, zz - zc * zc / scc, sdd - sdc * sdc / scc
            else:
                dd = sdd
            if zz <= 0:
                continue
            r = zd / math.sqrt(zz * dd)
            if r > best[2]:
                best = (u if cue == 0 else _unit(np.cross(u, up)), name, r)
        if best[2] <= 0 or (1.0 - best[2] ** 2) ** ((n - 4) / 2) >= SIGNIFICANCE:
            return None, "", best[2]
        return best

    def estimate(self, choice: str = "auto", where: str = "", min_quiet: float = MIN_QUIET,
                 speed_given: bool = True, override: bool = True) -> MountEstimate:
        """The :class:`MountEstimate` of the samples so far (``choice`` as :func:`estimate_mount`; ``where``
        begins every warning; ``speed_given``: whether the ride has GPS speed, for the warning that it did not
        tell the direction; ``override``: whether the warning of an unusual mount names ``--mount``)."""
        if choice not in ("auto", "estimate", *PRESETS):
            raise InputError(f"--mount {choice!r} is not known; give auto, estimate, {', '.join(PRESETS)}")
        warnings = []
        fraction = self.quiet / max(self.valid, 1)
        up, trusted = self.up(min_quiet)
        if not trusted:
            warnings.append(f"{where}only {100 * fraction:.0f} % of the samples are at rest or cruising; the "
                            f"vertical is the mean over the whole log and may be off")
        forward, source, r = self.forward(up)
        if forward is None:
            forward, source = top_edge_forward(up), TOP_EDGE_SOURCE
            if speed_given:
                warnings.append(f"{where}the GPS speed changes do not tell the direction of travel; assumed the "
                                f"phone's top edge (or back) points forward")
        estimated = np.vstack([forward, np.cross(up, forward), up])
        s = self.state_[0]
        force = float(np.linalg.norm(s["force"] / max(s["valid"], 1)))  # the quiet samples' would be held near g
        result = MountEstimate(estimated, estimated, source, fraction, r, warnings, choice, force)
        if result.biased:
            tilt = (f"a bias across the vertical tilts the estimate by up to "
                    f"{np.degrees(np.arccos(GRAVITY / force)):.0f} deg" if force > GRAVITY else "a bias also tilts "
                    "the estimate")
            warnings.append(f"{where}the accelerometer's {result._bias_said().removeprefix('its ')}: it has a bias "
                            f"or a scale error, and {tilt}, which the data cannot tell from a tilt of the mount; "
                            f"calibrate the accelerometer, or give --mount flat|upright if you know how the phone sits")
        if choice == "auto":
            unusual = result.angle_from_nominal > USUAL_ANGLE
            result.used = estimated if unusual else MOUNT
            if unusual:
                mounted = (f"the estimate is {np.degrees(result.angle_from_nominal):.0f} deg from flat with the top "
                           f"edge forward (a tilt of the phone or the accelerometer's bias)" if result.biased else
                           f"the phone is mounted {np.degrees(result.angle_from_nominal):.0f} deg from flat with its "
                           f"top edge forward")
                warnings.append(f"{where}{mounted}; features use the estimated mount"
                                + (" (override with --mount flat|upright|estimate)" if override else ""))
        elif choice != "estimate":
            result.used = PRESETS[choice]
        result.used = np.asarray(result.used, dtype=float)
        return result


@numba.njit(cache=True, nogil=True)
def _accumulate(state, rows, lean_c, step, quiet_rate, quiet_force, g, min_interval, quiet_target, stop_on_close,
                until):
    """:meth:`MountStatistics.take`: rows ``(t, ax, ay, az, gx, gy, gz, speed)`` into ``state[0]``."""
    s = state[0]
    for k in range(rows.shape[0]):
        closed = _sample(s, rows[k], lean_c, step, quiet_rate, quiet_force, g, min_interval)
        if s["quiet"] >= quiet_target or (closed and stop_on_close) or rows[k, 0] >= until:
            return k + 1, closed
    return rows.shape[0], False


@numba.njit(cache=True, nogil=True)
def _sample(s, row, lean_c, step, quiet_rate, quiet_force, g, min_interval):
    """One row into the record ``s``; True when it closed a speed-change interval."""
    lean, sums = s["lean"], s["inside_sums"]
    t, a0, a1, a2, w0, w1, w2, speed = row
    if not (math.isfinite(a0) and math.isfinite(a1) and math.isfinite(a2) and math.isfinite(w0)
            and math.isfinite(w1) and math.isfinite(w2)):
        lean[0], lean[1], lean[2] = lean_c * lean[0], lean_c * lean[1], lean_c * lean[2]
        return False
    lean[0] = lean_c * lean[0] + w0 * step
    lean[1] = lean_c * lean[1] + w1 * step
    lean[2] = lean_c * lean[2] + w2 * step
    s["valid"] += 1.0
    f = s["force"]
    f[0] += a0
    f[1] += a1
    f[2] += a2
    norm_a = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    if math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) < quiet_rate and abs(norm_a - g) < quiet_force:
        s["quiet"] += 1.0
        q = s["quiet_force"]
        q[0] += a0
        q[1] += a1
        q[2] += a2
    values = (a0, a1, a2, lean[0], lean[1], lean[2], w0, w1, w2)
    for j in range(9):
        sums[j] += values[j]
    s["inside"] += 1.0
    if not math.isfinite(speed):
        return False
    fix = s["fix"]
    if not s["has_fix"] or t <= fix[0]:
        _open(s, t, speed)
        return False
    if t - fix[0] < min_interval:
        return False
    d = (speed - fix[1]) / (t - fix[0])
    up = s["quiet_force"] if s["quiet"] > 0 else s["force"]
    yaw = (up[0] * sums[6] + up[1] * sums[7] + up[2] * sums[8]) / (
        s["inside"] * math.sqrt(up[0] * up[0] + up[1] * up[1] + up[2] * up[2]))
    turn = 0.5 * (speed + fix[1]) * yaw
    s["n"] += 1.0
    s["d"] += d
    s["dd"] += d * d
    s["c"] += turn
    s["cc"] += turn * turn
    s["dc"] += d * turn
    for cue in range(2):
        x = (sums[3 * cue] / s["inside"], sums[3 * cue + 1] / s["inside"], sums[3 * cue + 2] / s["inside"])
        for i in range(3):
            s["x"][cue, i] += x[i]
            s["xd"][cue, i] += x[i] * d
            s["xc"][cue, i] += x[i] * turn
            for j in range(3):
                s["xx"][cue, i, j] += x[i] * x[j]
    _open(s, t, speed)
    return True


@numba.njit(cache=True, nogil=True)
def _open(s, t, speed):
    """Start the next interval at the fix ``(t, speed)``."""
    s["fix"][0] = t
    s["fix"][1] = speed
    s["has_fix"] = True
    s["inside"] = 0.0
    s["inside_sums"][:] = 0.0


def top_edge_forward(up: np.ndarray) -> np.ndarray:
    """Forward (device frame, unit, horizontal) when the data do not tell: the horizontal part of ``y - z`` (the
    top edge of a phone lying flat, the back of one standing upright), of ``y + z`` when that vanishes."""
    for guess in ((0.0, 1.0, -1.0), (0.0, 1.0, 1.0)):
        h = _horizontal(np.array(guess), up)
        if np.linalg.norm(h) > 0.1:
            return _unit(h)
    return _unit(_horizontal(np.array([1.0, 0.0, 0.0]), up))


def estimate_mount(rec: Recording, choice: str = "auto") -> MountEstimate:
    """The device-to-vehicle rotation of ``rec`` (raw IMU in the device frame; GPS ``speed`` used when present).

    ``choice``: ``auto`` (the nominal mount when the estimate is usual, else the estimate), ``estimate`` (always
    the estimate), or a name of :data:`PRESETS`. See the module docstring for the method."""
    if choice not in ("auto", "estimate", *PRESETS):
        raise InputError(f"--mount {choice!r} is not known; give auto, estimate, {', '.join(PRESETS)}")
    rec.require_imu("mount detection")
    stats = MountStatistics(rec.rate)
    speed = rec.channels.get("speed")
    speeds = np.full(len(rec), np.nan) if speed is None else speed
    stats.update_block(np.column_stack([rec.time, rec.array(ACC_CHANNELS), rec.array(GYRO_CHANNELS), speeds]))
    result = stats.estimate(choice, f"{rec.source}: ", speed_given=speed is not None)
    turns, r = track_turns(rec, result.estimated[2])
    told = turns >= MIN_INTERVALS and (1.0 - r * r) ** ((turns - 2) / 2) < SIGNIFICANCE
    flip = "multiply ax, ay, az by -1, or by -9.81 when they are in g"
    if told and r < 0:  # the mount estimated is the mirror image's: not a claim to repeat
        result.warnings[:] = [w for w in result.warnings if not w.startswith(f"{rec.source}: the phone is mounted")]
        result.warnings.append(
            f"{rec.source}: the gyroscope turns against the GPS track (correlation {r:.2f} over {turns} turns): the "
            f"accelerometer reads minus the specific force, as iOS's acceleration does; {flip}")
    elif not told and max(-result.estimated[2, 1], -result.estimated[2, 2]) > 0.7:
        result.warnings.append(
            f"{rec.source}: the accelerometer says the phone is upside down (screen or top edge towards the ground); "
            f"either it is, or the accelerometer reads minus the specific force, as iOS's acceleration does (then "
            f"{flip}): the GPS track "
            + ("is too short or straight to tell" if "lat" in rec.channels else "would tell, and the log has none"))
    return result


def track_turns(rec: Recording, up: np.ndarray) -> tuple[int, float]:
    """``(n, r)``: how many turns of the GPS track of ``rec`` were compared with its gyroscope, and their
    correlation (NaN for fewer than three).

    The track is cut into chords of :data:`TRACK_CHORD` fixes (``lat``, ``lon`` in degrees, as local east and north
    metres); at each joint of two chords of at least :data:`TRACK_MIN_CHORD` m the track turns by the difference
    of their bearings (counter-clockwise seen from above), and the gyroscope by the integral of its rotation rate
    about ``up`` (a device-frame unit vector) from the middle of the first chord to the middle of the second. A
    right accelerometer and gyroscope give ``r`` near 1; an accelerometer of flipped sign turns ``up`` over, and
    ``r`` near -1."""
    if "lat" not in rec.channels or "lon" not in rec.channels:
        return 0, math.nan
    track, gyro = [], []
    for _, part in rec.experiments():
        lat, lon = part.channels["lat"], part.channels["lon"]
        fix = np.flatnonzero(np.isfinite(lat) & np.isfinite(lon))
        if len(fix) < 2 * TRACK_CHORD + 1:
            continue
        east = np.radians(lon[fix]) * np.cos(np.radians(np.mean(lat[fix]))) * EARTH_RADIUS
        north = np.radians(lat[fix]) * EARTH_RADIUS
        turned = np.r_[0.0, np.cumsum(np.nan_to_num(part.array(GYRO_CHANNELS) @ up)) / part.rate]
        for b in range(TRACK_CHORD, len(fix) - TRACK_CHORD, TRACK_CHORD):
            a, c = b - TRACK_CHORD, b + TRACK_CHORD
            first, second = (east[b] - east[a], north[b] - north[a]), (east[c] - east[b], north[c] - north[b])
            if min(math.hypot(*first), math.hypot(*second)) < TRACK_MIN_CHORD:
                continue
            bearing = math.atan2(*second) - math.atan2(*first)  # clockwise from north
            track.append(-math.remainder(bearing, 2 * math.pi))
            gyro.append(turned[(fix[b] + fix[c]) // 2] - turned[(fix[a] + fix[b]) // 2])
    if len(track) < 3 or np.std(track) == 0 or np.std(gyro) == 0:
        return len(track), math.nan
    return len(track), float(np.corrcoef(track, gyro)[0, 1])


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _horizontal(v: np.ndarray, up: np.ndarray) -> np.ndarray:
    """The part of the vector ``v`` perpendicular to the unit vector ``up``."""
    return v - (v @ up) * up


class MountTracker:
    """The mount of a live ride, found from its first samples (see the module docstring).

    Until :data:`LIVE_QUIET_SECONDS` of quiet samples have come, the nominal mount is used. Then the vertical is
    known, and forward is taken from the GPS speed changes if they tell it (as offline), else from the phone's top
    edge (or back); the mount decided is used if it is unusual (:data:`USUAL_ANGLE`), else the nominal one. While
    forward is only assumed, each closed speed change is tried again until the GPS speed tells; then the mount is
    final and the statistics stop. Whenever the mount used changes, :meth:`update` (:meth:`update_block`) says so
    (where).

    ``reports`` collects ``(t, kind, detail)`` for the ride record (``detail`` at most 100 characters): each
    decision, of kind ``mount`` (usual: the nominal mount is used) or ``unusual-mount`` (the estimate is used), and,
    once, ``uncertain-mount`` when the mount is not final :data:`UNCERTAIN_SECONDS` into the ride."""

    def __init__(self, rate: float):
        self.rate = float(rate)
        self.statistics = MountStatistics(rate)
        self.used = MOUNT.copy()
        self.stage = "nominal"
        self.estimate: MountEstimate | None = None
        self.reports: list[tuple[float, str, str]] = []
        self._start: float | None = None
        self._has_speed = False
        self._doubted = False

    @property
    def final(self) -> bool:
        """True once the mount will not change again."""
        return self.stage == "final"

    def update(self, t: float, acc, gyr, speed: float = math.nan) -> bool:
        """Take one sample (as :meth:`MountStatistics.update`); True when the mount used changes at it."""
        return bool(self.update_block(np.array([[t, *acc, *gyr, speed]])))

    def update_block(self, rows: np.ndarray) -> list[tuple[int, np.ndarray]]:
        """:meth:`update` for each row ``(t, ax, ay, az, gx, gy, gz, speed)`` of ``rows`` ``(n, 8)``: ``(row, mount
        used from that row on)`` for each change, the statistics taken in one compiled call between decisions."""
        changes = []
        i, n = 0, len(rows)
        while i < n and not self.final:
            if self._start is None:
                self._start = float(rows[i, 0])
            quiet = LIVE_QUIET_SECONDS * self.rate if self.stage == "nominal" else math.inf
            until = math.inf if self._doubted else self._start + UNCERTAIN_SECONDS
            taken, closed = self.statistics.take(rows[i:], quiet, self.stage == "vertical", until)
            k = i + taken - 1
            t = float(rows[k, 0])
            self._has_speed = self._has_speed or bool(np.isfinite(rows[i:k + 1, 7]).any())
            i += taken
            changed = False
            if self.stage == "nominal" and self.statistics.quiet >= quiet:
                changed = self._decide(t)
            elif self.stage == "vertical" and closed and self.statistics.forward(self.statistics.up(0.0)[0])[0] \
                    is not None:
                changed = self._decide(t)
            if changed:
                changes.append((k, self.used))
            if not self._doubted and not self.final and t - self._start >= UNCERTAIN_SECONDS:
                self._doubted = True
                self.reports.append((t, REPORT_KINDS[2], (
                    f"no {LIVE_QUIET_SECONDS:g} s at rest or cruising in {UNCERTAIN_SECONDS:g} s; nominal mount "
                    f"used" if self.stage == "nominal" else
                    "GPS speed has not told forward; assumed: the top edge or back" if self._has_speed else
                    "no GPS speed to tell forward; assumed: the top edge or back")))
        return changes

    def _decide(self, t: float) -> bool:
        """Estimate now; True when the mount used changes."""
        estimate = self.statistics.estimate("auto", "", 0.0, speed_given=False, override=False)
        self.stage = "vertical" if estimate.source == TOP_EDGE_SOURCE else "final"
        changed = not np.array_equal(estimate.used, self.used)
        self.estimate, self.used = estimate, estimate.used
        unusual = not np.array_equal(estimate.used, MOUNT)
        self.reports.append((t, REPORT_KINDS[1] if unusual else REPORT_KINDS[0], estimate.brief()))
        return changed

    def pop_reports(self) -> list[tuple[float, str, str]]:
        """The reports since the last call."""
        reports, self.reports = self.reports, []
        return reports
