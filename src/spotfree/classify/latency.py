"""Decision latency: how long after a true manoeuvre onset the label stream names it (evaluation only).

A true onset of class ``c`` is a sample ``t0`` inside a stretch of labelled samples (one experiment, no gap) where
the ground truth (the hidden ``label`` column, never read by training or classification) changes to ``c``; its
true run lasts to ``t1``. The onset is detected when a label ``c`` appears in ``[t0, t1 + tolerance)`` within the
stretch; the delay is

    delay = (s - t0) / f_s   seconds,

where ``s`` is where that run of ``c`` labels starts, traced back from ``t0`` no further than the start of the
preceding true run: a causal window names a manoeuvre late (``s > t0``), a centred one may name it a little early
(``s < t0``). Per class: the median delay, and how many onsets were detected.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from spotfree.classify import DEFAULT_METHOD
from spotfree.classify.batch import Labels, classify_recording
from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel


@dataclass
class OnsetLatency:
    """Delays (s) of the detected onsets of one class, and how many onsets there were."""

    name: str
    onsets: int
    delays: np.ndarray

    @property
    def detected(self) -> int:
        return len(self.delays)

    @property
    def median(self) -> float:
        """Median delay (s); NaN when no onset was detected."""
        return float(np.median(self.delays)) if len(self.delays) else float("nan")


def onset_latency(labels: Labels, truth: np.ndarray, tolerance: float = 1.0) -> dict[str, OnsetLatency]:
    """Per class of the model, the delay from each true onset to the label (module docstring).

    ``truth``: the ground-truth class of every sample of the labelled recording; ``tolerance`` (s): how long after
    the true run ends a label still counts as detecting it.
    """
    truth = np.asarray(truth).astype(str)
    if truth.shape != labels.label.shape:
        raise InputError(f"{labels.source}: truth has {len(truth)} samples, the labels {len(labels)}")
    late = int(round(tolerance * labels.rate))
    delays: dict[str, list[float]] = {c: [] for c in labels.meta.get("classes", sorted(set(truth)))}
    onsets = dict.fromkeys(delays, 0)
    for start, stop in labels.stretches():
        changes = start + 1 + np.flatnonzero(truth[start + 1:stop] != truth[start:stop - 1])
        bounds = np.r_[start, changes, stop]
        for previous, t0, t1 in zip(bounds[:-2], bounds[1:-1], bounds[2:]):
            name = truth[t0]
            if name not in delays:
                continue
            onsets[name] += 1
            hits = np.flatnonzero(labels.label[t0:min(t1 + late, stop)] == name)
            if not len(hits):
                continue
            s = t0 + hits[0]
            if s == t0:
                while s > previous and labels.label[s - 1] == name:
                    s -= 1
            delays[name].append((s - t0) / labels.rate)
    return {c: OnsetLatency(c, onsets[c], np.array(delays[c])) for c in delays}


def decision_latency(model: DictionaryModel, rec: Recording, method: str = DEFAULT_METHOD, smoothing: int | None = None,
                     tolerance: float = 1.0) -> dict[str, dict[str, OnsetLatency]]:
    """``{"causal": ..., "centred": ...}``: :func:`onset_latency` of both window alignments on ``rec``, whose
    ``truth["label"]`` holds the ground truth."""
    if "label" not in rec.truth:
        raise InputError(f"{rec.source}: no 'label' column; decision latency needs the ground truth")
    return {
        alignment: onset_latency(
            classify_recording(model, rec, method, centred=alignment == "centred", smoothing=smoothing),
            rec.truth["label"], tolerance)
        for alignment in ("causal", "centred")
    }
