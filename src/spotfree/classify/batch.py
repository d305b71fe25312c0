"""Batch classification: one label per sample of a recording from the windows of a trained dictionary.

Every window ``y`` of ``model.window`` samples (channels divided by the model's scales, the column normalised as in
training, the constant row ``model.parameters["affine"]`` appended) is classified against the dictionary by
``method`` (:data:`spotfree.classify.METHODS`). Windows are taken every ``model.step`` samples inside each
gap-free segment of one experiment (:meth:`Recording.segments`); none spans a gap or two experiments.

Alignment of a window ending at sample ``e`` with the label stream (offset ``o``):

* ``causal``  (``o = 0``): the window labels sample ``e``, the newest sample it holds. This is what a live stream
  can do; a manoeuvre is labelled late by part of a window (:mod:`spotfree.classify.latency`).
* ``centred`` (``o = window // 2``): the window labels its centre ``e - o`` (offline only).

A window labels ``step`` samples from ``e - o`` on, up to ``stop - o`` where ``stop`` ends its segment. Samples
with no label: the first ``window - 1 - o`` of every segment, its last ``o``, and every sample inside a gap.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.classify import DEFAULT_METHOD, make_classifier
from spotfree.classify.smoothing import VOTE_SECONDS, alignment_smoothing, majority_vote, vote_samples
from spotfree.errors import InputError
from spotfree.io.checks import write_text
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.signal.body import body_features
from spotfree.signal.features import ride_features
from spotfree.windows import ChannelScaling, recording_windows, with_affine_row

RATE_TOLERANCE = 1e-6
"""Relative difference between the model's rate and the input's that still counts as the same rate."""


@dataclass
class LabelBreak:
    """Labels stop after ``stopped`` (s, the last labelled sample) and resume at ``resumed`` (s) in ``experiment``."""

    experiment: int
    stopped: float
    resumed: float

    def __str__(self) -> str:
        return (f"experiment {self.experiment}: labels stop after {self.stopped:.2f} s and resume at "
                f"{self.resumed:.2f} s")


@dataclass
class Labels:
    """One label per sample of a recording: ``label[k]`` is a class name, or ``""`` where no window gives one.

    ``meta`` says how they were made: ``method``, ``alignment`` (``causal`` / ``centred``), ``offset`` (samples),
    ``window``, ``step``, ``smoothing`` (samples, 0 for none) and the model's ``classes``; the offline votes
    (:func:`spotfree.votes.apply_votes`) add theirs.
    """

    time: np.ndarray
    label: np.ndarray
    rate: float
    experiment: np.ndarray | None = None
    source: str = "<memory>"
    meta: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.time)

    def labelled(self) -> np.ndarray:
        """Boolean mask of the samples that have a label."""
        return self.label != ""

    def stretches(self) -> list[tuple[int, int]]:
        """``(start, stop)`` index ranges of consecutive labelled samples within one experiment."""
        ok = self.labelled()
        cut = np.r_[True, ~ok[:-1]] if len(ok) else np.empty(0, dtype=bool)
        end = np.r_[~ok[1:], True] if len(ok) else np.empty(0, dtype=bool)
        if self.experiment is not None and len(ok) > 1:
            change = np.diff(self.experiment) != 0
            cut[1:] |= change
            end[:-1] |= change
        return list(zip(np.flatnonzero(ok & cut).tolist(), (np.flatnonzero(ok & end) + 1).tolist()))

    def write_csv(self, path: str | Path) -> None:
        """Write ``experiment`` (when set), ``time`` (s) and ``label`` (empty where none) as CSV, atomically."""
        columns: dict[str, object] = {}
        if self.experiment is not None:
            columns["experiment"] = self.experiment
        columns["time"] = [repr(float(t)) for t in np.round(self.time, 9)]
        columns["label"] = self.label
        write_text(Path(path), pd.DataFrame(columns).to_csv(index=False, lineterminator="\n"))

    def breaks(self) -> list[LabelBreak]:
        """Where labels stop and resume inside one experiment (at gaps in the input)."""
        experiment = self.experiment if self.experiment is not None else np.ones(len(self), dtype=int)
        spans = self.stretches()
        return [
            LabelBreak(int(experiment[a_stop - 1]), float(self.time[a_stop - 1]), float(self.time[b_start]))
            for (_, a_stop), (b_start, _) in zip(spans, spans[1:])
            if experiment[a_stop - 1] == experiment[b_start]
        ]


def model_features(model: DictionaryModel, rec: Recording) -> Recording:
    """``rec`` with the model's channels: the ride features (with the model's orientation filter) of a raw IMU log,
    or the body channels (:mod:`spotfree.signal.body`) of a log with an accelerometer, when the model was trained on
    them, else ``rec`` itself; the channels and rate must match the model's."""
    if model.features == "ride" and rec.has_imu:
        rec = ride_features(rec, orientation=model.orientation, derived=True)
    elif model.features == "body" and rec.has_accelerometer:
        rec = body_features(rec)
    missing = [c for c in model.channels if c not in rec.channels]
    if missing or abs(rec.rate - model.rate) > RATE_TOLERANCE * model.rate:
        fix = (f"resample the log to {model.rate:g} Hz" if not missing else
               f"give the raw IMU log (ax ay az gx gy gz) so the {model.features} features can be computed"
               if model.features in ("ride", "body") else "give a log with those channels")
        raise InputError(
            f"model expects channels {','.join(model.channels)} at {model.rate:g} Hz; {rec.source} has "
            f"{','.join(rec.names) or 'no channels'} at {rec.rate:g} Hz; {fix}"
        )
    return rec


def dictionary_classifier(model: DictionaryModel, method: str = DEFAULT_METHOD, causal: bool = False, **params):
    """Classifier ``method`` fitted on the model's dictionary columns (with the affine row), one atom per column;
    ``causal``: on its causal columns when it has them (:meth:`DictionaryModel.columns`). Kernel CRC_RLS takes the
    model's ``parameters["landmarks"]`` unless ``params`` name them (models without it: the classifier's default)."""
    dictionary, column_class = model.columns(causal)
    atoms = with_affine_row(dictionary, model_affine(model)).T
    if method == "kcrc" and "landmarks" in model.parameters:
        params.setdefault("landmarks", model.parameters["landmarks"])
    return make_classifier(method, **params).fit(atoms, np.asarray(model.classes)[column_class])


def model_affine(model: DictionaryModel) -> float:
    """The constant row appended to every window (``parameters["affine"]``; 0 when the model has none)."""
    return float(model.parameters.get("affine", 0.0))


def vote_seconds(model: DictionaryModel) -> float:
    """Span (s) of the centred vote the model's offline labels get by default: its learner's ``smoothing``
    (:data:`~spotfree.classify.smoothing.VOTE_SECONDS` for a model without one)."""
    return float(model.parameters.get("smoothing", VOTE_SECONDS))


def offline_vote(model: DictionaryModel) -> int:
    """Samples of that vote (:func:`vote_seconds`), an odd number."""
    return vote_samples(vote_seconds(model), model.rate)


def alignment_offset(model: DictionaryModel, centred: bool) -> int:
    """Samples between a window's last sample and the sample it labels: 0 causal, ``window // 2`` centred."""
    return model.window // 2 if centred else 0


def classify_recording(model: DictionaryModel, rec: Recording, method: str = DEFAULT_METHOD, centred: bool = False,
                       smoothing: int | None = None, classifier=None) -> Labels:
    """Label every sample of ``rec`` (a raw IMU log or a log of the model's channels), see the module docstring.

    ``smoothing``: majority vote over that many samples (:mod:`spotfree.classify.smoothing`), 0 for none; None: the
    default of the alignment (:func:`~spotfree.classify.smoothing.alignment_smoothing`: the model's
    :func:`offline_vote` centred, none causal).
    ``classifier``: a classifier already fitted by :func:`dictionary_classifier` (fitted here when None).
    """
    smoothing = alignment_smoothing(smoothing, centred, offline_vote(model))
    feats = classifiable_features(model, rec)
    segments = feats.segments()
    clf = classifier if classifier is not None else dictionary_classifier(model, method, causal=not centred)
    scaling = ChannelScaling(tuple(model.channels), model.scale)
    windows = recording_windows(feats, tuple(model.channels), model.window, model.step, scaling,
                                model.normalisation)
    predicted = np.asarray(clf.predict(model.inputs(windows.matrix))).astype(str)
    offset = alignment_offset(model, centred)
    label = np.full(len(feats), "", dtype=object)
    first = np.searchsorted(windows.ends, [start for start, _ in segments])
    last = np.searchsorted(windows.ends, [stop for _, stop in segments])
    for (start, stop), i, j in zip(segments, first, last):
        if i == j:
            continue
        samples = np.arange(windows.ends[i] - offset, stop - offset)
        label[samples] = predicted[i + (samples - samples[0]) // model.step]
        if smoothing:
            label[start:stop] = majority_vote(label[start:stop], smoothing, centred)
    return Labels(
        time=feats.time, label=label, rate=feats.rate, experiment=feats.experiment, source=rec.source,
        meta={"method": method, "alignment": "centred" if centred else "causal", "offset": offset,
              "window": model.window, "step": model.step, "smoothing": smoothing or 0,
              "classes": [str(c) for c in model.classes]},
    )


def classifiable_features(model: DictionaryModel, rec: Recording) -> Recording:
    """:func:`model_features` of ``rec``, refused when no gap-free stretch holds a window."""
    feats = model_features(model, rec)
    if not any(stop - start >= model.window for start, stop in feats.segments()):
        raise InputError(
            f"{rec.source}: no gap-free stretch is as long as the model's window ({model.window} samples = "
            f"{model.window / model.rate:.2f} s); nothing to classify"
        )
    return feats
