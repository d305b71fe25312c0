"""Motion channels of the hand: how fast it moves, turns and changes its fingers, whatever the posture.

From the hand feature channels (:mod:`spotfree.hand.features`, Leap frame) at sample ``t`` of rate ``f`` Hz:

* ``speed`` (m/s): ``|v_t|``, the palm speed the service reports;
* ``turn`` (rad/s): ``f (angle(d_t, d_{t-1}) + angle(n_t, n_{t-1}))``, how fast the hand direction ``d`` and the
  palm normal ``n`` turn;
* ``flex`` (1/s): ``f (|grab_t - grab_{t-1}| + sum_fingers |ext_t - ext_{t-1}|)``, how fast the fingers change;
* ``nrate_x nrate_y nrate_z`` and ``drate_x drate_y drate_z`` (1/s): ``f (n_t - n_{t-1})`` and ``f (d_t - d_{t-1})``,
  the signed rates of change of the palm normal and the hand direction (Leap frame).

They are backward differences, so a live stream computes them from the current and the previous sample alone;
the first sample of a gap-free stretch has no previous one and is NaN. The first three do not depend on which
posture the hand holds, which is what the posture-or-gesture decision needs; the signed rates tell a movement from
its reverse (``straight-to-left`` turns the hand one way, ``left-to-straight`` the other), which the orientation
itself, the same samples in the opposite order, hardly does within a short window.
"""

from __future__ import annotations

import numpy as np

from spotfree.hand.frames import DIRECTION, EXTENDED, NORMAL, VELOCITY
from spotfree.io.recording import Recording

NORMAL_RATE = ("nrate_x", "nrate_y", "nrate_z")
DIRECTION_RATE = ("drate_x", "drate_y", "drate_z")
MOTION = ("speed", "turn", "flex", *NORMAL_RATE, *DIRECTION_RATE)
"""The motion channels, in order."""

SOURCES = (*VELOCITY, *DIRECTION, *NORMAL, "grab", *EXTENDED)
"""Hand feature channels the motion channels are computed from, in the order :func:`motion_step` takes them."""


def motion_channels(feats: Recording) -> Recording:
    """``feats`` (hand features) with the :data:`MOTION` channels added; NaN at the first sample of every
    experiment and wherever this or the previous sample is NaN."""
    x = feats.array(SOURCES)
    previous = np.vstack([np.full((1, x.shape[1]), np.nan), x[:-1]])
    if feats.experiment is not None and len(feats) > 1:
        previous[1:][np.diff(feats.experiment) != 0] = np.nan
    values = motion_step(x, previous, feats.rate)
    return feats.with_channels(dict(zip(MOTION, values.T)), keep=True)


def motion_step(x: np.ndarray, previous: np.ndarray, rate: float) -> np.ndarray:
    """Motion channels ``(n, 9)`` of rows ``x`` of :data:`SOURCES` values given the rows ``previous`` one sample
    earlier (1-D rows give one row of 9)."""
    x, previous = np.atleast_2d(x), np.atleast_2d(previous)
    speed = np.linalg.norm(x[:, 0:3], axis=1)
    turn = _angle(x[:, 3:6], previous[:, 3:6]) + _angle(x[:, 6:9], previous[:, 6:9])
    flex = np.abs(x[:, 9:] - previous[:, 9:]).sum(axis=1)
    rates = (x[:, 3:9] - previous[:, 3:9]) * rate
    return np.column_stack([speed, turn * rate, flex * rate, rates[:, 3:6], rates[:, 0:3]])


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle (rad) between the rows of unit vectors ``a`` and ``b`` (``2 asin(|a - b| / 2)``, exact for small
    angles; NaN where either is NaN)."""
    return 2.0 * np.arcsin(np.clip(np.linalg.norm(a - b, axis=1) / 2.0, 0.0, 1.0))
