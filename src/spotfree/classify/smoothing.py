"""Label smoothing: a short majority vote over the per-sample label stream.

The smoothed label at sample ``t`` is the class named most often among the labels of the ``n`` samples

* ``t - n + 1 .. t`` (causal, what a live stream can do), or
* ``t - n + 1 + n // 2 .. t + n // 2`` (centred, offline),

within one gap-free segment. A sample without a label (before the first full window, or near a gap) holds a
place in the ``n`` but casts no vote, and smoothing never labels a sample that had no label. Ties go to the most
recent of the tied labels, so ``n = 1`` and a run of one class pass unchanged and a change of class shows once
it holds more than half of the last ``n`` samples: a causal vote adds about ``n / 2`` samples of delay.

Offline (centred) labels are voted over the model's ``smoothing`` span unless asked otherwise
(:func:`vote_samples`; :data:`VOTE_SECONDS` for a model without one). The learner's decoding makes each change of
class pay ``smoothing`` seconds of windows' log-posterior, so that its names seldom hold a class for less; the vote
keeps the offline labels to the same prior, and a class that shows for fewer than half of those samples between
runs of another takes theirs. Live labels are not voted
unless asked, since every sample of a causal vote is a sample of delay.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from spotfree.errors import InputError

VOTE_SECONDS = 0.5
"""Span (s) of the centred vote of offline labels when the model has no ``smoothing`` of its own, and of the peers':
the learner's default ``smoothing``."""


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


def vote_samples(seconds: float, rate: float) -> int:
    """The odd number of samples at ``rate`` Hz whose span is nearest ``seconds`` from above (at least 1), so that a
    centred vote has a middle sample: ``k = round(seconds * rate)``, then ``k`` or ``k + 1``."""
    k = max(0, int(round(seconds * rate)))
    return k + 1 - k % 2


def alignment_smoothing(n: int | None, centred: bool, offline: int) -> int | None:
    """The vote (samples, validated; None for none) that labels of this alignment get when ``n`` is asked for: ``n``
    itself (0: none), or for None the default, ``offline`` samples centred (the model's, :func:`vote_samples`) and
    none live."""
    return check_smoothing((offline if centred else None) if n is None else n)


def majority_vote(labels: np.ndarray, n: int, centred: bool = False) -> np.ndarray:
    """Smoothed labels of one gap-free segment (``""`` where ``labels`` has none), see the module docstring."""
    labels = np.asarray(labels, dtype=object)
    vote = MajorityVote(n)
    shift = vote.n // 2 if centred else 0
    voted = [vote.update(label) for label in [*labels, *[None] * shift]][shift:]
    out = np.array([v or "" for v in voted], dtype=object)
    out[labels == ""] = ""
    return out
