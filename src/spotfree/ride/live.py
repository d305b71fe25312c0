"""One live ride on the server: raw samples in, features and labels out, sample by sample.

:class:`LiveRide` runs the causal ride features (:class:`~spotfree.signal.features.FeatureStream`, derived
channels included, for the operator's plot) and feeds the model's channels of them to
:class:`~spotfree.classify.stream.RideClassifier` (``update_features``), so each sample is filtered once; the
labels equal ``RideClassifier.update`` on the raw samples while the mount is the nominal one. A segment (filters,
window buffer) starts afresh at a non-finite sample or a time step longer than ``max_gap`` s, as in
:mod:`spotfree.classify.stream`.

The mount: :class:`~spotfree.signal.mount.MountTracker` estimates the device-to-vehicle rotation from the ride's
first samples (gravity at rest or cruising, then forward from the GPS speed changes); the features use the
nominal mount until it decides, then the mount it decided: the segment's samples so far (at most
:data:`HISTORY_SECONDS`) are run again through the features and windows of the new mount, so that from then on
features and labels are those of the causal :func:`~spotfree.signal.features.ride_features` with that mount, and
no label is lost. Its reports (the mount, and whether it is unusual or uncertain) are events for the ride record
(:meth:`LiveRide.pop_events`). The page runs the same tracker (``MountTracker`` in ``static/pipeline.js``) on the
same samples, so it switches at the same sample.

:func:`pipeline_spec` is the same pipeline as numbers for the page's JavaScript copy (``static/pipeline.js``):
filter coefficients, the mount tracker's parameters, the channel scales and the CRC_RLS residual operators
``E_i = I - A_i P_i`` stacked row by row ``(C d, d)``, so the page keeps classifying when its connection drops.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.signal

from spotfree.classify.batch import dictionary_classifier, model_affine
from spotfree.classify.kcrc import KernelCRCClassifier
from spotfree.classify.stream import MAX_GAP, RideClassifier, segment_runs, starts_segment
from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.representation import summary_tables
from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS, Event
from spotfree.signal.butterworth import butter_lowpass
from spotfree.signal.complementary import pi_complementary_design
from spotfree.signal.features import LONG_CUTOFF, FeatureStream, lean_coefficients
from spotfree.signal import mount as mount_tracking
from spotfree.signal.frame import GRAVITY, MOUNT
from spotfree.signal.mount import MountTracker
from spotfree.signal.orientation import GravityPI
from spotfree.signal.speed_aided import SpeedAidedParameters

HISTORY_SECONDS = 120.0
"""Seconds of the current segment held while the mount may still change, run again through the features of the
new mount when it does."""

PAGE_ORIENTATIONS = ("default", "paper")
"""Attitude filters the page's JavaScript pipeline implements."""


class LiveRide:
    """Features and labels of one ride, one raw sample at a time (see the module docstring).

    Parameters
    ----------
    model : DictionaryModel
        A model of ride features (``model.features == "ride"``).
    classifier : estimator, optional
        Fitted by :func:`~spotfree.classify.batch.dictionary_classifier` once and shared between rides.
    """

    def __init__(self, model: DictionaryModel, classifier=None, max_gap: float = MAX_GAP):
        if model.features != "ride":
            raise InputError("the live service needs a model of ride features (trained on raw IMU logs)")
        self.model = model
        self.max_gap = max_gap
        self.mount = MountTracker(model.rate)
        self._classifier = RideClassifier(model, classifier=classifier, max_gap=max_gap)
        self._features = FeatureStream(model.rate, model.orientation, derived=True)
        self._pick = np.array([FEATURE_COLUMNS.index(c) for c in model.channels])
        self._time: float | None = None
        self._history: list[np.ndarray] = []
        self._hold = int(round(HISTORY_SECONDS * model.rate))

    def pop_events(self) -> list[Event]:
        """The mount's reports since the last call (:class:`~spotfree.signal.mount.MountTracker`: kinds ``mount``,
        ``unusual-mount``, ``uncertain-mount``) as events at the sample's time."""
        return [Event(kind, t, t, detail) for t, kind, detail in self.mount.pop_reports()]

    def _remount(self, mount: np.ndarray) -> None:
        """Features and windows on ``mount``, from the start of the segment: the samples held are run again
        through them (their labels dropped), so that the next sample is as if ``mount`` had been used all along."""
        self._features = FeatureStream(self.model.rate, self.model.orientation, derived=True, mount=mount)
        self._classifier.reset()
        if self._history:
            past = np.concatenate(self._history)[-self._hold:]
            feats = self._features.update_block(past, _IMU_COLUMNS)
            self._classifier.update_produced_block(feats, past[:, 0], [(slice(0, len(past)), True)])

    def _hold_rows(self, rows: np.ndarray, switch_ahead: bool = False) -> None:
        """Hold the sample rows just taken while the mount may still change (the last :data:`HISTORY_SECONDS`);
        ``switch_ahead``: a later row of the block changes it (the tracker has seen the whole block)."""
        if self.mount.final and not switch_ahead:
            self._history = []
            return
        self._history.append(rows)
        if sum(len(h) for h in self._history) > 2 * self._hold:
            self._history = [np.concatenate(self._history)[-self._hold:]]

    def update(self, t: float, acc, gyr, speed: float = math.nan) -> tuple[np.ndarray, str | None]:
        """``(features, label)`` of one sample at ``t`` (s): ``acc`` (m/s^2, gravity included) and ``gyr``
        (rad/s) device-frame 3-vectors (Android axes), ``speed`` (m/s) on a GPS fix, NaN otherwise.
        ``features`` follow :data:`~spotfree.ride.records.FEATURE_COLUMNS` (NaN on a non-finite sample)."""
        values = (*acc, *gyr)
        finite = all(math.isfinite(v) for v in values)
        previous, self._time = self._time, float(t)
        if not finite or starts_segment(previous, self._time, self.max_gap):
            self._history = []
            self._features.reset()
        if self.mount.update(self._time, acc, gyr, speed):
            self._remount(self.mount.used)
        if not finite:
            nan = np.full(len(FEATURE_COLUMNS), np.nan)
            return nan, self._classifier.update_features(nan[self._pick], t)
        feats = self._features.update(acc, gyr, speed)
        self._hold_rows(np.array([[self._time, *values, math.nan, math.nan, speed]]))
        return feats, self._classifier.update_features(feats[self._pick], t)

    def update_block(self, table: np.ndarray) -> tuple[np.ndarray, list[str | None]]:
        """:meth:`update` for every row of a sample table ``(n, 10)`` in
        :data:`~spotfree.ride.records.SAMPLE_COLUMNS` order (``time ax ay az gx gy gz lat lon speed``): features
        ``(n, len(FEATURE_COLUMNS))`` and one label per row, from one compiled call per segment (and mount) for
        the features and one for the windows when the IMU values are finite."""
        table = np.asarray(table, dtype=float)
        if not math.isfinite(table[:, 1:7].sum()):  # NaN or infinity somewhere (or an overflow): sample by sample
            rows = [self.update(r[0], r[1:4], r[4:7], r[9]) for r in table.tolist()]
            return np.array([f for f, _ in rows]), [label for _, label in rows]
        t = table[:, 0]
        remounts = {} if self.mount.final else dict(self.mount.update_block(table[:, _TRACKED_COLUMNS]))
        feats = np.empty((len(table), len(FEATURE_COLUMNS)))
        labels: list[str | None] = []
        for rows, fresh in _split(segment_runs(t, self._time, self.max_gap), remounts):
            if fresh:
                self._history = []
                self._features.reset()
            if rows.start in remounts:
                self._remount(remounts[rows.start])
            feats[rows] = self._features.update_block(table[rows], _IMU_COLUMNS)
            labels += self._classifier.update_produced_block(feats[rows], t[rows], [(slice(0, len(t[rows])), fresh)])
            self._hold_rows(table[rows], any(k >= rows.stop for k in remounts))
        self._time = float(t[-1])
        return feats, labels


def _split(runs: list[tuple[slice, bool]], starts) -> list[tuple[slice, bool]]:
    """``runs`` (:func:`~spotfree.classify.stream.segment_runs`) split before each row in ``starts`` (the pieces
    go on the segment)."""
    out = []
    for rows, fresh in runs:
        bounds = [rows.start, *(k for k in sorted(starts) if rows.start < k < rows.stop), rows.stop]
        out += [(slice(a, b), fresh and a == rows.start) for a, b in zip(bounds, bounds[1:])]
    return out


_IMU_COLUMNS = np.array([SAMPLE_COLUMNS.index(c) for c in ("ax", "ay", "az", "gx", "gy", "gz", "speed")])
"""Where :meth:`LiveRide.update_block` finds the IMU values and the GPS speed in a sample table."""
_TRACKED_COLUMNS = np.array([SAMPLE_COLUMNS.index(c) for c in ("time", "ax", "ay", "az", "gx", "gy", "gz", "speed")])
"""The sample-table columns the mount tracker takes (:meth:`~spotfree.signal.mount.MountTracker.update_block`)."""


_TRACKER_PARAMETERS = ("QUIET_RATE", "QUIET_FORCE", "MIN_INTERVAL", "MIN_INTERVALS", "SIGNIFICANCE",
                       "MIN_SPEED_CHANGE", "USUAL_ANGLE", "LEAN_TIME_CONSTANT", "LIVE_QUIET_SECONDS",
                       "UNCERTAIN_SECONDS")
"""The constants of :mod:`spotfree.signal.mount` the page's ``MountTracker`` needs (sent lower-case)."""


def _sections(sos: np.ndarray) -> dict:
    """Second-order sections as ``[b0, b1, b2, a1, a2]`` rows and their at-rest state per unit input."""
    return {"sections": [[s[0], s[1], s[2], s[4], s[5]] for s in sos.tolist()],
            "zi": scipy.signal.sosfilt_zi(sos).tolist()}


def pipeline_spec(model: DictionaryModel, classifier=None) -> dict:
    """The model's streaming pipeline as JSON-ready numbers for ``static/pipeline.js`` (CRC_RLS or kernel CRC_RLS).

    Keys: ``classes``, ``channels``, ``pick`` (indices into :data:`FEATURE_COLUMNS`), ``rate`` (Hz), ``window``,
    ``step``, ``scale``, ``normalisation``, ``affine``, ``max_gap`` (s), ``mount`` (the nominal device to vehicle
    axes, used until the ride's own is known), ``mount_tracker`` (the constants of :mod:`spotfree.signal.mount`,
    lower-case), ``mount_history`` (:data:`HISTORY_SECONDS`),
    ``gravity`` (m/s^2), ``attitude`` (``kind`` and its parameters), ``lowpass`` and ``long_lowpass``
    (Butterworth sections), ``lean`` (``b``, ``a``, ``c``), ``speed_aided`` (noise densities), ``operator``
    (the ``(C d, d)`` residual operators, flat, row-major), ``reject`` (None when off), ``kernel`` (None for
    CRC_RLS; for kernel CRC_RLS ``gamma``, the ``m`` ``landmarks`` ``(m, d)`` and the ``normalisation``
    ``(f, m)``, flat, row-major, and then ``operator`` acts on the ``f`` features), ``summary`` (None for a
    ``hankel`` model; for a ``summary`` one the tables of :func:`~spotfree.representation.summary_tables`: ``taper``,
    ``cos`` and ``sin`` ``(bins, L)`` flat, ``band``, ``bands``, and the standardisation ``offset``, ``scale``; the
    classifier then acts on the represented window).
    """
    if model.features != "ride":
        raise InputError("the page pipeline needs a model of ride features")
    if model.orientation not in PAGE_ORIENTATIONS:
        raise InputError(f"the page pipeline implements the orientation filters {', '.join(PAGE_ORIENTATIONS)}, "
                         f"not {model.orientation!r}; serve a model trained with one of them")
    clf = classifier if classifier is not None else dictionary_classifier(model, causal=True)
    kernel = None
    if isinstance(clf, KernelCRCClassifier):
        kernel = {"gamma": clf.gamma_, "m": len(clf.landmarks_), "features": len(clf.normalisation_),
                  "landmarks": clf.landmarks_.reshape(-1).tolist(),
                  "normalisation": clf.normalisation_.reshape(-1).tolist()}
    operators = getattr(clf.crc_ if kernel else clf, "residual_operators_", None)
    if operators is None:
        raise InputError("the page pipeline needs a CRC_RLS or kernel CRC_RLS classifier (residual operators)")
    if model.orientation == "default":
        pi = GravityPI(model.rate)
        attitude = {"kind": "default", **{k: getattr(pi, k) for k in (
            "kp", "ki", "acc_scale", "rate_scale", "max_error", "rest_gyr", "rest_acc", "rest_time", "rest_gain",
            "rest_tau", "g", "acc_tau", "motion_tau", "startup_gain", "startup_time")}}
    else:
        design = pi_complementary_design(rate=model.rate)
        attitude = {"kind": "paper", "a": design.a.tolist(), "b_rate": design.b_rate.tolist(),
                    "b_acc": design.b_acc.tolist(),
                    "zi": scipy.signal.lfilter_zi(design.b_acc, design.a).tolist()}
    summary = None
    if model.representation == "summary":
        taper, cos, sin, band, bands = summary_tables(model.window)
        summary = {"taper": taper.tolist(), "cos": cos.reshape(-1).tolist(), "sin": sin.reshape(-1).tolist(),
                   "band": band.tolist(), "bands": int(bands), "offset": model.feature_offset.tolist(),
                   "scale": model.feature_scale.tolist()}
    b, a, c = lean_coefficients(model.rate)
    return {
        "classes": [str(name) for name in clf.classes_],
        "channels": list(model.channels),
        "pick": [FEATURE_COLUMNS.index(name) for name in model.channels],
        "rate": float(model.rate),
        "window": int(model.window),
        "step": int(model.step),
        "scale": np.asarray(model.scale, dtype=float).tolist(),
        "normalisation": model.normalisation,
        "affine": model_affine(model),
        "max_gap": MAX_GAP,
        "mount": MOUNT.tolist(),
        "mount_tracker": {name.lower(): float(getattr(mount_tracking, name)) for name in _TRACKER_PARAMETERS},
        "mount_history": HISTORY_SECONDS,
        "gravity": GRAVITY,
        "attitude": attitude,
        "lowpass": _sections(butter_lowpass(model.rate)),
        "long_lowpass": _sections(butter_lowpass(model.rate, LONG_CUTOFF)),
        "lean": {"b": b, "a": a, "c": c},
        "speed_aided": vars(SpeedAidedParameters()),
        "operator": operators.reshape(-1).tolist(),
        "reject": clf.reject,
        "kernel": kernel,
        "summary": summary,
    }
