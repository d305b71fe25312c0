"""Several models on one ride (braking, lateral manoeuvres, road surface): one feature pass, one label per model.

The ride features (:func:`~spotfree.signal.features.ride_features` with the derived channels, or one
:class:`~spotfree.signal.features.FeatureStream` when streaming) are computed once for all models, so the models must
share the rate and the attitude filter. Each model then keeps its own channels, window, step and classifier: in
batch :func:`~spotfree.classify.batch.classify_recording` on the shared features; in streaming one ring buffer of
feature vectors serves every model (:class:`~spotfree.classify.ring.ModelRing`), so a sample costs one compiled
feature step and one compiled call that windows and classifies each due model. The labels of
:class:`MultiModelStream` equal the causal labels of :func:`classify_models` sample for sample. The offline votes
run per model on the batch labels (:func:`spotfree.votes.voted_models`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from spotfree.classify import DEFAULT_METHOD
from spotfree.classify.batch import Labels, classify_recording, dictionary_classifier
from spotfree.classify.ring import ModelRing
from spotfree.classify.smoothing import check_smoothing
from spotfree.classify.stream import MAX_GAP, PRODUCED, starts_segment
from spotfree.errors import InputError
from spotfree.io.checks import write_text
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.signal.features import FeatureStream, imu_floats, ride_features


def model_names(paths) -> list[str]:
    """Column names for model files: their stems, which must differ (``braking.npz`` -> ``braking``)."""
    names = [Path(p).stem for p in paths]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise InputError(f"model files share the name {', '.join(twice)}; the label columns are named by the file "
                         "stem, so rename one of the files")
    return names


def _check_models(models: Mapping[str, DictionaryModel]) -> None:
    """One feature pass must serve every model: same rate, same attitude filter, same kind of features."""
    if not models:
        raise InputError("no model given; pass at least one MODEL.npz")
    first_name, first = next(iter(models.items()))
    for name, model in models.items():
        if name in ("time", "experiment"):
            raise InputError(f"a model may not be named '{name}' (a column of the output); rename its file")
        if abs(model.rate - first.rate) > 1e-6 * first.rate:
            (own, other), fix = (f"{m.rate:g} Hz" for m in (first, model)), "train them at one rate"
        elif model.features != first.features:
            own, other = (f"{m.features} features" for m in (first, model))
            fix = "classify the log with each model in its own call, or train both with the same --features"
        elif model.features == "ride" and model.orientation != first.orientation:
            own, other = (f"--orientation {m.orientation}" for m in (first, model))
            fix = "train them with the same --orientation"
        else:
            continue
        raise InputError(f"models {first_name} and {name} cannot share one feature pass: {first_name} is of {own}, "
                         f"{name} of {other}; {fix}")


def shared_features(models: Mapping[str, DictionaryModel], rec: Recording) -> Recording:
    """The ride features of a raw IMU log ``rec``, computed once for all ``models`` (derived channels included), or
    ``rec`` itself when the models are not of ride features or it holds none of the raw channels."""
    _check_models(models)
    first = next(iter(models.values()))
    if first.features == "ride" and rec.has_imu:
        return ride_features(rec, orientation=first.orientation, derived=True)
    return rec


def model_labels(models: Mapping[str, DictionaryModel], rec: Recording, method: str = DEFAULT_METHOD,
                 centred: bool = False, smoothing: int | None = None,
                 classifiers: Mapping | None = None) -> dict[str, Labels]:
    """The :func:`~spotfree.classify.batch.classify_recording` labels of every model (by name) on
    :func:`shared_features` of ``rec``; ``classifiers``: each model's classifier already fitted for this method and
    alignment (by name; fitted here when None)."""
    feats = shared_features(models, rec)
    return {name: classify_recording(model, feats, method=method, centred=centred, smoothing=smoothing,
                                     classifier=(classifiers or {}).get(name))
            for name, model in models.items()}


def label_table(labels: Mapping[str, Labels]) -> pd.DataFrame:
    """``experiment`` (when the labels have one), ``time`` (s) and one label column per model (named by its key)
    from labels of one recording."""
    first = next(iter(labels.values()))
    table: dict[str, object] = {}
    if first.experiment is not None:
        table["experiment"] = first.experiment
    table["time"] = first.time
    table.update({name: own.label for name, own in labels.items()})
    return pd.DataFrame(table)


def classify_models(models: Mapping[str, DictionaryModel], rec: Recording, method: str = DEFAULT_METHOD,
                    centred: bool = False, smoothing: int | None = None) -> pd.DataFrame:
    """One label column per model (named by its key) for every sample of ``rec``, after ``experiment`` (when the
    recording has one) and ``time`` (s); ``""`` where a model gives no label (see
    :mod:`spotfree.classify.batch`). The ride features of a raw IMU log are computed once for all models."""
    return label_table(model_labels(models, rec, method=method, centred=centred, smoothing=smoothing))


def write_labels(table: pd.DataFrame, path: str | Path) -> None:
    """Write a :func:`classify_models` table as CSV, atomically (times written exactly, empty where no label)."""
    table = table.assign(time=[repr(float(t)) for t in np.round(table["time"].to_numpy(float), 9)])
    write_text(Path(path), table.to_csv(index=False, lineterminator="\n"))


class MultiModelStream:
    """Label a ride sample by sample with several ride-feature models at once (see the module docstring).

    Parameters
    ----------
    models : mapping of name to DictionaryModel
        Models of ride features at one rate and attitude filter; :attr:`names` keeps their order.
    method, smoothing, max_gap :
        As for :class:`~spotfree.classify.stream.RideClassifier`, the same for every model.
    classifiers : mapping of name to fitted classifier, optional
        Classifiers already fitted by :func:`~spotfree.classify.batch.dictionary_classifier`.
    """

    def __init__(self, models: Mapping[str, DictionaryModel], method: str = DEFAULT_METHOD,
                 smoothing: int | None = None, max_gap: float = MAX_GAP,
                 classifiers: Mapping[str, object] | None = None):
        _check_models(models)
        first = next(iter(models.values()))
        if first.features != "ride":
            raise InputError("MultiModelStream runs models of ride features on raw IMU samples; these models were "
                             "trained on other channels")
        classifiers = classifiers or {}
        unknown = sorted({c for m in models.values() for c in m.channels} - set(PRODUCED))
        if unknown:
            raise InputError(f"model channel(s) {', '.join(unknown)} are not ride features ({', '.join(PRODUCED)})")
        self.names = tuple(models)
        self.max_gap = max_gap
        self._features = FeatureStream(first.rate, first.orientation, derived=True)
        self._values = np.zeros(len(PRODUCED))
        fitted = [dictionary_classifier(m, method, causal=True) if classifiers.get(n) is None else classifiers[n]
                  for n, m in models.items()]
        picks = [np.array([PRODUCED.index(c) for c in m.channels]) for m in models.values()]
        self._ring = ModelRing(list(models.values()), picks, len(PRODUCED), fitted, check_smoothing(smoothing))
        self._time: float | None = None

    def reset(self) -> None:
        """Start a new segment for every model (at a gap or a new ride)."""
        self._features.reset()
        self._ring.reset()

    def update(self, acc, gyr, t: float | None = None, speed: float = math.nan) -> tuple[str | None, ...]:
        """The label of every model (in :attr:`names` order; None before its first full window) at this sample.

        ``acc`` (m/s^2, gravity included) and ``gyr`` (rad/s): device-frame 3-vectors (Android: x right, y up, z
        out of the screen); ``t`` (s), optional: a step longer than ``max_gap`` or not forward starts a segment;
        ``speed``: GPS speed (m/s) on a fix, NaN otherwise.
        """
        a0, a1, a2, w0, w1, w2 = imu_floats(acc, gyr)
        if t is not None:
            previous, self._time = self._time, float(t)
            if starts_segment(previous, self._time, self.max_gap):
                self.reset()
        if not math.isfinite(a0 + a1 + a2 + w0 + w1 + w2):
            self.reset()
            return (None,) * len(self.names)
        self._features.step(a0, a1, a2, w0, w1, w2, float(speed), self._values)
        return tuple(self._ring.push(self._values))
