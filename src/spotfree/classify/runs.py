"""Events from a label stream: each run of an active state that lasts long enough is one event, named by the label
most of its samples carry.

A window classifier labels every sample from a short window, so inside one manoeuvre its label may change several
times (the first windows of a movement hold mostly what came before it, and a movement and another that starts the
same way look alike until they part), and a stray window may call the active state for a sample or two. Counted as
runs of equal labels, one manoeuvre would then give several detections. Here a detection is a run of the *state*
instead (``active``: e.g. "a gesture is going on"), and

* a run shorter than ``min_samples`` is no event (a blip of one or two windows);
* the event's label is the one most samples of the run carry (ties: the one that comes first in the run), the vote
  over the whole manoeuvre (:func:`vote`);
* its ``start`` is the run's first sample and its ``stop`` one past its last.

:class:`RunEvents` does the same one sample at a time: an event is known, and returned, at the first sample after
its run (or when the stream ends, :meth:`RunEvents.finish`), since only then is its vote complete.
:func:`run_events` gives the same events for a whole stream; runs never span two experiments.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spotfree.errors import InputError
from spotfree.io.checks import true_runs


@dataclass(frozen=True)
class RunEvent:
    """One event: ``label``, and the sample indices ``start`` (its first) and ``stop`` (one past its last)."""

    label: str
    start: int
    stop: int


def vote(labels) -> str:
    """The label most of ``labels`` carry; ties: the one that comes first."""
    names, first, counts = np.unique(np.asarray(labels).astype(str), return_index=True, return_counts=True)
    return str(names[max(range(len(names)), key=lambda k: (counts[k], -first[k]))])


def check_min_samples(min_samples) -> int:
    if not isinstance(min_samples, (int, np.integer)) or isinstance(min_samples, bool) or min_samples < 1:
        raise InputError(f"min_samples={min_samples!r}: give a whole number of samples >= 1")
    return int(min_samples)


def run_events(active: np.ndarray, label: np.ndarray, min_samples: int = 1,
               experiment: np.ndarray | None = None) -> list[RunEvent]:
    """The events of a whole stream (module docstring), in order: per run of ``active`` samples within one
    ``experiment`` lasting at least ``min_samples``, the vote of its ``label``."""
    min_samples = check_min_samples(min_samples)
    active = np.asarray(active, dtype=bool)
    label = np.asarray(label)
    if label.shape != active.shape:
        raise InputError(f"{len(label)} labels for {len(active)} samples: give one label per sample")
    starts = np.zeros(len(active), dtype=bool)
    if experiment is not None and len(active) > 1:
        starts[np.flatnonzero(np.diff(np.asarray(experiment)) != 0) + 1] = True
    events = []
    for start, stop in true_runs(active):
        bounds = [start, *(np.flatnonzero(starts[start + 1:stop]) + start + 1).tolist(), stop]
        for a, b in zip(bounds[:-1], bounds[1:]):
            if b - a >= min_samples:
                events.append(RunEvent(vote(label[a:b]), a, b))
    return events


class RunEvents:
    """:func:`run_events` one sample at a time; sample indices count every sample given since construction.

    Parameters
    ----------
    min_samples : int
        Fewest samples of a run that make an event.
    """

    def __init__(self, min_samples: int = 1):
        self.min_samples = check_min_samples(min_samples)
        self._index = 0
        self._start = -1
        self._counts: dict[str, list[int]] = {}

    def update(self, active: bool, label: str) -> RunEvent | None:
        """Take one sample; the event whose run ended just before it, if any."""
        event = None
        if active:
            if self._start < 0:
                self._start = self._index
            count = self._counts.setdefault(str(label), [0, self._index])
            count[0] += 1
        else:
            event = self.finish()
        self._index += 1
        return event

    def finish(self) -> RunEvent | None:
        """End the current run (the stream, or its experiment, ends): its event, if it makes one."""
        event = None
        if self._start >= 0 and self._index - self._start >= self.min_samples:
            best = max(self._counts, key=lambda name: (self._counts[name][0], -self._counts[name][1]))
            event = RunEvent(best, self._start, self._index)
        self._start, self._counts = -1, {}
        return event
