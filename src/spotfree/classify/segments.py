"""Segment vote (offline): labels made constant between change points of the model's own channels.

A ride is piecewise steady: a straight, a turn, a patch of cobblestone. A window classifier labels each sample from
a short window, so near every change and wherever a short window happens to look like another class its labels
flicker. The segment vote finds the changes in the signal itself and lets each segment's labels agree:

1. the model's channels of one gap-free stretch, a level channel (:data:`~spotfree.signal.features.LEVEL_CHANNELS`)
   as ``log(level + LEVEL_FLOOR)`` (a change of surface multiplies it), each standardised over the stretch, form
   ``x`` (n, d);
2. PELT (Killick, Fearnhead, Eckley 2012, through ``ruptures``) cuts ``x`` where the least-squares cost
   ``sum_segments sum_t ||x_t - mean_segment||^2 + penalty * changes`` is lowest, segments at least ``min_size``
   samples long: ``penalty`` is in units of the standardised squared error, so it does not depend on the channels'
   units (larger: fewer, longer segments);
3. every segment takes the label most of its labelled samples carry (ties: the earliest such label); samples
   without a label stay without one, and the classes in ``keep`` (short events such as ``kerb``) keep their labels
   and cast no vote.

Seeing the whole stretch, this is for offline use (``spotfree classify --segments``), not for a live stream.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import ruptures

from spotfree.errors import InputError
from spotfree.signal.features import LEVEL_CHANNELS

LEVEL_FLOOR = 1e-3
"""Added to a level channel (its units) before the logarithm, so that a vehicle standing still (no vibration,
level 0) does not give minus infinity."""
MIN_SIZE = 3
"""Shortest segment (samples)."""


def check_penalty(penalty: float | None) -> float | None:
    """``penalty`` validated: None or 0 means no segment vote."""
    if penalty is None or penalty == 0:
        return None
    if isinstance(penalty, bool) or not isinstance(penalty, (int, float, np.integer, np.floating)) \
            or not np.isfinite(penalty) or penalty < 0:
        raise InputError(f"segment penalty (--segments) must be a number > 0 (or 0 for none), got {penalty!r}")
    return float(penalty)


def segment_signal(channels: dict[str, np.ndarray], names: Iterable[str]) -> np.ndarray:
    """The (n, d) signal the change points are found in (step 1 of the module docstring) from one stretch's
    ``channels``; a channel constant over the stretch is left at 0."""
    columns = []
    for name in names:
        values = np.asarray(channels[name], dtype=float)
        if name in LEVEL_CHANNELS:
            values = np.log(np.maximum(values, 0.0) + LEVEL_FLOOR)
        spread = values.std()
        columns.append((values - values.mean()) / spread if np.ptp(values) > 0 else np.zeros_like(values))
    return np.column_stack(columns)


def change_points(x: np.ndarray, penalty: float, min_size: int = MIN_SIZE) -> np.ndarray:
    """Ends (exclusive) of the segments PELT cuts ``x`` (n, d) into under ``penalty``; the last is ``n``."""
    x = np.asarray(x, dtype=float)
    if len(x) < 2 * min_size:
        return np.array([len(x)])
    return np.asarray(ruptures.Pelt(model="l2", min_size=min_size, jump=1).fit(x).predict(pen=penalty))


def segment_vote(labels: np.ndarray, ends: np.ndarray, keep: Iterable[str] = ()) -> np.ndarray:
    """``labels`` of one stretch (``""``: none) with every segment ending at ``ends`` set to its majority label,
    except the samples without a label and those of a class in ``keep``."""
    labels = np.asarray(labels, dtype=object)
    out = labels.copy()
    kept = np.isin(labels.astype(str), list(keep)) | (labels == "")
    start = 0
    for end in ends:
        voters = labels[start:end][~kept[start:end]]
        if len(voters):
            names, first, counts = np.unique(voters.astype(str), return_index=True, return_counts=True)
            winner = str(names[np.lexsort((first, -counts))[0]])
            out[start:end][~kept[start:end]] = winner
        start = end
    return out
