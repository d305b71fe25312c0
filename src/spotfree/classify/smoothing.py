"""Label smoothing: a short majority vote over the per-sample label stream.

The smoothed label at sample ``t`` is the class named most often among the labels of the ``n`` samples

* ``t - n + 1 .. t`` (causal, what a live stream can do), or
* ``t - n + 1 + n // 2 .. t + n // 2`` (centred, offline),

within one gap-free segment. A sample without a label (before the first full window, or near a gap) holds a
place in the ``n`` but casts no vote, and smoothing never labels a sample that had no label. Ties go to the most
recent of the tied labels, so ``n = 1`` and a run of one class pass unchanged and a change of class shows once
it holds more than half of the last ``n`` samples: a causal vote adds about ``n / 2`` samples of delay.

Offline (centred) labels are voted over :data:`OFFLINE_VOTE` samples unless asked otherwise; live labels are not
voted unless asked, since every sample of a causal vote is a sample of delay.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from spotfree.errors import InputError

OFFLINE_VOTE = 3
"""Samples of the centred vote that offline labels get by default: a run of one sample between two others becomes
theirs, and every change of class between runs of two samples or more stays where it was. A label that flickers for
one sample is otherwise an event of its own when the labels are scored or counted as events."""


def check_smoothing(n: int | None) -> int | None:
    """``n`` (samples) validated: None or 0 means no smoothing."""
    if n is None or n == 0:
        return None
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise InputError(f"smoothing (--smooth) must be a whole number of samples >= 1 (or 0 for none), got {n!r}")
    return int(n)


class MajorityVote:
    """Causal majority of the last ``n`` labels, one label at a time (:meth:`reset` at a gap)."""

    def __init__(self, n: int):
        self.n = check_smoothing(n) or 1
        self.reset()

    def reset(self) -> None:
        """Forget every label seen."""
        self._recent: deque = deque()
        self._count: dict[str, int] = {}
        self._last: dict[str, int] = {}
        self._index = 0

    def update(self, label: str | None) -> str | None:
        """The majority among the last ``n`` labels including ``label`` (None or ``""``: no vote); None when no
        label is among them."""
        self._recent.append(label or None)
        if label:
            self._count[label] = self._count.get(label, 0) + 1
            self._last[label] = self._index
        if len(self._recent) > self.n:
            old = self._recent.popleft()
            if old is not None:
                self._count[old] -= 1
        self._index += 1
        best, key = None, (0, -1)
        for name, count in self._count.items():
            if count and (count, self._last[name]) > key:
                best, key = name, (count, self._last[name])
        return best


def alignment_smoothing(n: int | None, centred: bool) -> int | None:
    """The vote (samples, validated; None for none) that labels of this alignment get when ``n`` is asked for: ``n``
    itself (0: none), or for None the default, :data:`OFFLINE_VOTE` samples offline and none live."""
    return check_smoothing((OFFLINE_VOTE if centred else None) if n is None else n)


def majority_vote(labels: np.ndarray, n: int, centred: bool = False) -> np.ndarray:
    """Smoothed labels of one gap-free segment (``""`` where ``labels`` has none), see the module docstring."""
    labels = np.asarray(labels, dtype=object)
    vote = MajorityVote(n)
    shift = vote.n // 2 if centred else 0
    voted = [vote.update(label) for label in [*labels, *[None] * shift]][shift:]
    out = np.array([v or "" for v in voted], dtype=object)
    out[labels == ""] = ""
    return out
