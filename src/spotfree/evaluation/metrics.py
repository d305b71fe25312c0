"""Per-sample scores of a label stream against the ground truth (evaluation only; training never reads truth).

A label stream holds one class name per sample, ``""`` where no window gave one (the first window of every ride,
gaps). Every score counts labelled samples only, so a method is not charged for the samples it cannot label;
:func:`accuracy` reports how many it scored.

Transitions: the true label of a braking ride changes at a sample ``c`` (``truth[c] != truth[c - 1]`` within one
experiment). A window straddling ``c`` holds two states, so a score may leave out the band

    { k : c - h <= k < c + h },    h = round(band * f_s)

of ``2 h`` samples (``band`` = 0.5 s: the last ``h`` samples of the old state and the first ``h`` of the new).

Events: a short class (a kerb strike, a few tenths of a second) may also be scored as events rather than samples
(:func:`event_detection`): each run of true samples of the class is one event, detected when a run of that label
starts or ends within ``tolerance`` seconds of it (overlapping ``[start - t, stop + t)``); a run of the label that
meets no true event that way is a false alarm. False alarms are counted per hour of riding without the event: the
labelled samples whose truth is not the class.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spotfree.errors import InputError
from spotfree.io.checks import true_runs

TRANSITION_BAND = 0.5
"""Half-width (s) of the band around a true label change that :func:`near_transitions` marks."""
EVENT_TOLERANCE = 0.5
"""Seconds by which a label run may miss a true event and still detect it (:func:`event_detection`)."""


@dataclass(frozen=True)
class Score:
    """``correct`` of ``total`` scored samples."""

    correct: int
    total: int

    @property
    def rate(self) -> float:
        """``correct / total``; NaN when nothing was scored."""
        return self.correct / self.total if self.total else float("nan")

    def __add__(self, other: "Score") -> "Score":
        return Score(self.correct + other.correct, self.total + other.total)


@dataclass(frozen=True)
class EventScore:
    """``detected`` of ``events`` true events of one class, ``false_alarms`` label runs that meet none, over
    ``seconds`` of labelled riding without the event (samples whose truth is another class)."""

    detected: int
    events: int
    false_alarms: int
    seconds: float

    @property
    def rate(self) -> float:
        """``detected / events``; NaN when there was no event."""
        return self.detected / self.events if self.events else float("nan")

    @property
    def precision(self) -> float:
        """``detected / (detected + false_alarms)``: a detected event counts one true run; NaN when nothing fired."""
        fired = self.detected + self.false_alarms
        return self.detected / fired if fired else float("nan")

    @property
    def f1(self) -> float:
        """Harmonic mean of :attr:`precision` and recall (:attr:`rate`); NaN when either is."""
        p, r = self.precision, self.rate
        return 2 * p * r / (p + r) if p + r > 0 else float("nan")

    @property
    def false_alarms_per_hour(self) -> float:
        """False alarms per hour of labelled riding without the event; NaN when there was none."""
        return 3600.0 * self.false_alarms / self.seconds if self.seconds else float("nan")

    def __add__(self, other: "EventScore") -> "EventScore":
        return EventScore(self.detected + other.detected, self.events + other.events,
                          self.false_alarms + other.false_alarms, self.seconds + other.seconds)


def _check(predicted, truth) -> tuple[np.ndarray, np.ndarray]:
    predicted, truth = np.asarray(predicted).astype(str), np.asarray(truth).astype(str)
    if predicted.shape != truth.shape or predicted.ndim != 1:
        raise InputError(f"labels have shape {predicted.shape} and truth {truth.shape}; give one label per sample")
    return predicted, truth


def near_transitions(truth, experiment=None, rate: float = 20.0, band: float = TRANSITION_BAND) -> np.ndarray:
    """Boolean mask of the samples within ``band`` seconds of a true label change (module docstring).

    ``experiment`` (one number per sample, or None): a change of experiment is not a change of label.
    """
    truth = np.asarray(truth).astype(str)
    half = int(round(band * rate))
    change = np.flatnonzero(truth[1:] != truth[:-1]) + 1
    if experiment is not None:
        experiment = np.asarray(experiment)
        change = change[experiment[change] == experiment[change - 1]]
    mask = np.zeros(len(truth), dtype=bool)
    for c in change:
        mask[max(0, c - half):c + half] = True
    return mask


def accuracy(predicted, truth, mask=None) -> Score:
    """Labelled samples (inside ``mask``, when given) whose label equals the truth."""
    predicted, truth = _check(predicted, truth)
    scored = predicted != ""
    if mask is not None:
        scored &= np.asarray(mask, dtype=bool)
    return Score(int(np.sum(predicted[scored] == truth[scored])), int(scored.sum()))


def class_accuracy(predicted, truth, classes) -> dict[str, Score]:
    """Per true class: labelled samples of that class labelled as it (the class's recall)."""
    predicted, truth = _check(predicted, truth)
    return {c: accuracy(predicted, truth, truth == c) for c in classes}


def event_detection(predicted, truth, name: str, experiment=None, rate: float = 20.0,
                    tolerance: float = EVENT_TOLERANCE) -> EventScore:
    """Events of class ``name`` detected by the runs of the label ``name`` (module docstring), each experiment on
    its own (``experiment``: one number per sample, or None for one ride)."""
    predicted, truth = _check(predicted, truth)
    if not np.isfinite(rate) or rate <= 0 or not np.isfinite(tolerance) or tolerance < 0:
        raise InputError(f"event detection needs a rate > 0 Hz and a tolerance >= 0 s, got {rate!r} and {tolerance!r}")
    groups = np.zeros(len(truth)) if experiment is None else np.asarray(experiment)
    if groups.shape != truth.shape:
        raise InputError(f"experiment has shape {groups.shape} and truth {truth.shape}; give one number per sample")
    reach = int(round(tolerance * rate))
    total = EventScore(0, 0, 0, 0.0)
    for group in np.unique(groups):
        inside = groups == group
        events, runs, found, hits = event_runs(predicted[inside] == name, truth[inside] == name, reach)
        detected, alarms = sum(found), hits.count(False)
        without = float(np.sum((predicted[inside] != "") & (truth[inside] != name))) / rate
        total += EventScore(detected, len(events), alarms, without)
    return total


def event_runs(fired, true, reach: int) -> tuple[list[tuple[int, int]], list[tuple[int, int]], list[bool],
                                                 list[bool]]:
    """In one ride, the runs ``(start, stop)`` of ``true`` (the events) and of ``fired`` (the label runs), whether
    each event is detected and whether each label run meets an event: a run ``[a, b)`` meets an event
    ``[start, stop)`` when ``a < stop + reach`` and ``b > start - reach`` (``reach`` in samples)."""
    events, runs = true_runs(true), true_runs(fired)
    meets = [[a < stop + reach and b > start - reach for a, b in runs] for start, stop in events]
    return (events, runs, [any(row) for row in meets],
            [any(row[k] for row in meets) for k in range(len(runs))])


def confusion_matrix(predicted, truth, classes) -> np.ndarray:
    """Counts ``C[i, j]`` of labelled samples of true class ``classes[i]`` labelled ``classes[j]`` (samples whose
    truth or label is not in ``classes`` are not counted)."""
    predicted, truth = _check(predicted, truth)
    classes = np.asarray(list(classes), dtype=str)
    row, col = _index(truth, classes), _index(predicted, classes)
    inside = (row >= 0) & (col >= 0)
    counts = np.zeros((len(classes), len(classes)), dtype=int)
    np.add.at(counts, (row[inside], col[inside]), 1)
    return counts


def _index(names: np.ndarray, classes: np.ndarray) -> np.ndarray:
    """Position of every name in ``classes``, -1 when absent."""
    index = np.full(len(names), -1)
    for k, c in enumerate(classes):
        index[names == c] = k
    return index


def label_count(predicted, name: str) -> Score:
    """How many labelled samples carry ``name``, out of all labelled samples (the paper's "6 out of 7800")."""
    predicted = np.asarray(predicted).astype(str)
    labelled = predicted != ""
    return Score(int(np.sum(predicted == name)), int(labelled.sum()))


def naming_scores(window_labels: list[np.ndarray], window_ends: list[np.ndarray], truths: list[np.ndarray],
                  window: int, classes) -> dict[str, tuple[Score, Score]]:
    """How spotting-free training named its windows: per class, ``(precision, recall)`` of the window names against
    the hidden truth at each window's centre sample (``end - window // 2``), over every training recording
    (``window_labels[r]`` and ``window_ends[r]`` of the recording whose per-sample truth is ``truths[r]``).
    Precision: windows named the class that are truly it, of those named it; recall: of those truly it."""
    named = np.concatenate([np.asarray(n).astype(str) for n in window_labels])
    truth = np.concatenate([np.asarray(t).astype(str)[np.asarray(e) - window // 2]
                            for t, e in zip(truths, window_ends)])
    hit = named == truth
    return {c: (Score(int(np.sum(hit & (named == c))), int(np.sum(named == c))),
                Score(int(np.sum(hit & (truth == c))), int(np.sum(truth == c)))) for c in classes}
