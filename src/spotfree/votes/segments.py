"""The offline votes' algorithms: the segment vote (labels made constant between change points of the model's own
channels), the event vote and the event edges.

A ride is piecewise steady: a straight, a turn, a patch of cobblestone. A window classifier labels each sample from
a short window, so near every change and wherever a short window happens to look like another class its labels
flicker. The segment vote finds the changes in the signal itself and lets each segment's labels agree:

1. the model's channels of one gap-free stretch, a level channel (:data:`~spotfree.signal.features.LEVEL_CHANNELS`)
   as ``log(level + LEVEL_FLOOR)`` (a change of surface multiplies it), each standardised over the stretch, form
   ``x`` (n, d);
2. PELT (Killick, Fearnhead, Eckley 2012) cuts ``x`` where the least-squares cost
   ``sum_segments (sum_t ||x_t - mean_segment||^2 + penalty)`` is lowest, segments at least ``min_size`` samples
   long: ``penalty`` is in units of the standardised squared error, so it does not depend on the channels' units
   (larger: fewer, longer segments). Written here, compiled, on cumulative sums (a segment's cost in O(d)); it gives
   the breakpoints of ``ruptures.Pelt(model="l2", jump=1)``;
3. every segment takes the label most of its labelled samples carry (ties: the earliest such label); samples
   without a label stay without one, and the classes in ``keep`` (short events such as ``kerb``) keep their labels
   and cast no vote.

The event vote (:func:`event_ends`) is the same vote over other segments: the runs of labels other than a model's
background class. It is for models whose other classes are whole manoeuvres separated by the background, named by
the manoeuvre as a whole: a turn whose yaw rate peaks high is a sharp turn from its first degree of yaw to its last,
though it starts and ends as gently as a gentle turn. Not for the braking model (a sudden stop passes through normal
braking as the lean builds up and eases off, and is labelled so).

Event edges (:func:`event_edges`, after the event vote): where a manoeuvre starts and ends is a convention (a turn is
a turn from a yaw rate of 0.10 rad/s on, say) that windows named without labels cannot learn, and a causal window
sees a manoeuvre only some samples after it began. Given a channel and the level that convention uses, each edge
between an event and the background moves, by at most one window, to where the channel's distance from its
background median crosses that level.

Seeing the whole stretch, all three are for offline use (``spotfree classify --segments``, ``--events``,
``--edges``), not for a live stream.
"""

from __future__ import annotations

from collections.abc import Iterable

import numba
import numpy as np

from spotfree.classify.runs import vote
from spotfree.io.checks import true_runs
from spotfree.signal.features import LEVEL_CHANNELS

LEVEL_FLOOR = 1e-3
"""Added to a level channel (its units) before the logarithm, so that a vehicle standing still (no vibration,
level 0) does not give minus infinity."""
MIN_SIZE = 3
"""Shortest segment (samples)."""


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
    x = np.ascontiguousarray(x, dtype=float)
    if len(x) < 2 * min_size:
        return np.array([len(x)])
    return _pelt_l2(x, float(penalty), int(min_size))


@numba.njit(cache=True)
def _pelt_l2(x: np.ndarray, penalty: float, min_size: int) -> np.ndarray:  # pragma: no cover - compiled
    """PELT on ``x`` (n, d), ``n >= 2 min_size``. ``best[e]``: the lowest cost of ``x[:e]`` cut into segments of at
    least ``min_size``, each costing its squared deviation from its mean plus ``penalty``; a candidate start ``s``
    is pruned once ``best[s] + cost(s, e) > best[e] + penalty`` (it can never end a better segmentation)."""
    n, d = x.shape
    first = np.zeros((n + 1, d))
    square = np.zeros(n + 1)
    for i in range(n):
        first[i + 1] = first[i] + x[i]
        square[i + 1] = square[i] + np.sum(x[i] * x[i])
    best = np.zeros(n + 1)
    start = np.zeros(n + 1, dtype=np.int64)
    candidates = np.empty(n + 1, dtype=np.int64)
    totals = np.empty(n + 1)
    count = 0
    for end in range(min_size, n + 1):
        new = end - min_size
        if new == 0 or new >= min_size:
            candidates[count] = new
            count += 1
        lowest, arg = np.inf, 0
        for j in range(count):
            s = candidates[j]
            mean_part = 0.0
            for k in range(d):
                diff = first[end, k] - first[s, k]
                mean_part += diff * diff
            totals[j] = best[s] + square[end] - square[s] - mean_part / (end - s) + penalty
            if totals[j] < lowest:
                lowest, arg = totals[j], s
        best[end], start[end] = lowest, arg
        kept = 0
        for j in range(count):
            if totals[j] <= lowest + penalty:
                candidates[kept] = candidates[j]
                kept += 1
        count = kept
    ends = [n]
    while start[ends[-1]] > 0:
        ends.append(start[ends[-1]])
    return np.array(ends[::-1])


def event_ends(labels: np.ndarray, background: str) -> np.ndarray:
    """Ends (exclusive) of the runs of ``labels`` that alternate between ``background`` (or no label, ``""``) and
    the other classes; the last is ``len(labels)``."""
    labels = np.asarray(labels).astype(str)
    inside = (labels != background) & (labels != "")
    return np.r_[np.flatnonzero(inside[1:] != inside[:-1]) + 1, len(labels)]


def event_edges(labels: np.ndarray, values: np.ndarray, background: str, level: float, reach: int) -> np.ndarray:
    """``labels`` of one stretch with each edge between the ``background`` class and an event (a run of other
    labels) moved to where ``u[t] = |values[t] - m|`` crosses ``level``, ``m`` the median of ``values`` over the
    samples labelled ``background`` (0 when there are none; a gyro bias cancels):

    * an edge whose background neighbours have ``u >= level`` moves into the background while they do;
    * else an edge whose event samples have ``u < level`` moves into the event while they do (one sample of the
      event stays);

    each by at most ``reach`` samples. Samples without a label (``""``) stop an edge; samples taken keep the label
    of the event's end they join."""
    labels = np.asarray(labels, dtype=object)
    values = np.asarray(values, dtype=float)
    out = labels.copy()
    quiet = labels.astype(str) == background
    centre = float(np.nanmedian(values[quiet])) if quiet.any() else 0.0
    away = np.abs(values - centre) >= level
    for start, stop in true_runs(~quiet & (labels != "")):
        onset = start
        while onset > 0 and start - onset < reach and quiet[onset - 1] and away[onset - 1]:
            onset -= 1
        if onset < start:
            out[onset:start] = labels[start]
        else:
            while onset < stop - 1 and onset - start < reach and not away[onset]:
                onset += 1
            out[start:onset] = background
        end = stop
        while end < len(labels) and end - stop < reach and quiet[end] and away[end]:
            end += 1
        if end > stop:
            out[stop:end] = labels[stop - 1]
        else:
            while end > onset + 1 and stop - end < reach and not away[end - 1]:
                end -= 1
            out[end:stop] = background
    return out


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
            out[start:end][~kept[start:end]] = vote(voters)
        start = end
    return out
