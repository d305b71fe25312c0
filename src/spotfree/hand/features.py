"""Feature channels of a hand-tracking Recording: what separates the postures and shows the gestures' motion.

From the channels of :data:`~spotfree.hand.frames.HAND_CHANNELS` (Leap frame: x right, y up, z toward the user),
per sample:

* ``pos_x pos_y pos_z`` (m): palm position minus the session's neutral ``p0``, the median palm position over the
  first ``calibration`` seconds with a hand (the session starts with the hand held still in ``straight``);
* ``vel_x vel_y vel_z`` (m/s): palm velocity as the service reports it;
* ``normal_x normal_y normal_z`` and ``dir_x dir_y dir_z`` (unit): palm normal and hand direction, renormalised
  to unit length after resampling;
* ``grab``, ``pinch`` (0..1): the service's grab and pinch strength;
* ``ext_thumb`` .. ``ext_pinky`` (0..1): extended flags (after resampling, the share of the time the finger was
  extended); these three kinds are clipped to 0..1, as the anti-aliasing filter overshoots a little at a step;
* ``spread`` (1): ``mean_f |tip_f - c| / w``, the mean distance of the five fingertips from their centroid
  ``c``, over the palm width ``w``, so that it does not depend on the size of the hand.

Each experiment (session) has its own neutral, or all use the given ``neutral``.
"""

from __future__ import annotations

import numpy as np

from spotfree.errors import InputError
from spotfree.hand.frames import DIRECTION, EXTENDED, FINGERS, HAND_CHANNELS, NORMAL, POSITION, VELOCITY
from spotfree.io.recording import Recording

FEATURES = (
    "pos_x", "pos_y", "pos_z", *VELOCITY, *NORMAL, *DIRECTION, "grab", "pinch", *EXTENDED, "spread",
)
"""The hand feature channels, in order."""

CALIBRATION = 1.0
"""s of hand presence at the start of a session whose median palm position is the neutral."""

MIN_CALIBRATION_SAMPLES = 5
"""Fewest samples with a hand in the calibration interval."""


def hand_features(rec: Recording, calibration: float = CALIBRATION, neutral: np.ndarray | None = None) -> Recording:
    """The :data:`FEATURES` of a hand-tracking Recording, on its grid, truth and gaps kept (NaN where it is NaN).

    ``neutral`` (3,) m, Leap frame, replaces the per-session calibration when given.
    """
    missing = [c for c in HAND_CHANNELS if c not in rec.channels]
    if missing:
        raise InputError(f"{rec.source}: no hand channel(s) {', '.join(missing[:3])}; read the log with read_hand_log")
    columns: dict[str, list[np.ndarray]] = {name: [] for name in FEATURES}
    for number, part in rec.experiments():
        origin = _neutral(part, calibration, number) if neutral is None else np.asarray(neutral, dtype=float)
        for name, values in _features(part, origin).items():
            columns[name].append(values)
    return rec.with_channels({name: np.concatenate(parts) for name, parts in columns.items()})


def _neutral(rec: Recording, calibration: float, number: int) -> np.ndarray:
    """Median palm position (m) over the first ``calibration`` s of samples with a hand."""
    position = rec.array(list(POSITION))
    present = np.flatnonzero(np.all(np.isfinite(position), axis=1))
    window = present[rec.time[present] < rec.time[present[0]] + calibration] if len(present) else present
    if len(window) < MIN_CALIBRATION_SAMPLES:
        raise InputError(
            f"{rec.source} (session {number}): {len(window)} sample(s) with a hand in the first {calibration:g} s; "
            f"a session starts with the hand held still over the sensor in the straight posture, or give a neutral"
        )
    return np.median(position[window], axis=0)


def _features(rec: Recording, neutral: np.ndarray) -> dict[str, np.ndarray]:
    """The feature columns of one session relative to ``neutral``."""
    position = rec.array(list(POSITION)) - neutral
    normal = _unit(rec.array(list(NORMAL)))
    direction = _unit(rec.array(list(DIRECTION)))
    tips = np.stack([rec.array([f"tip_{f}_{a}" for a in "xyz"]) for f in FINGERS], axis=1)
    spread = np.linalg.norm(tips - tips.mean(axis=1, keepdims=True), axis=2).mean(axis=1) / rec.channels["palm_width"]
    return {
        "pos_x": position[:, 0], "pos_y": position[:, 1], "pos_z": position[:, 2],
        **{name: rec.channels[name] for name in VELOCITY},
        **dict(zip(NORMAL, normal.T)), **dict(zip(DIRECTION, direction.T)),
        **{name: np.clip(rec.channels[name], 0.0, 1.0) for name in ("grab", "pinch", *EXTENDED)},
        "spread": spread,
    }


def _unit(vectors: np.ndarray) -> np.ndarray:
    """Rows scaled to unit length (NaN rows stay NaN)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)
