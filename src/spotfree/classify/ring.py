"""Streaming windows of several models over one ring buffer of feature samples, classified in compiled code.

:class:`ModelRing` keeps the last ``L_max`` feature vectors of a segment (``L_max`` the longest window among its
models) in a ring buffer stored twice over, so that the last ``L`` samples of any model are contiguous; per sample
one compiled call (:func:`~spotfree.kernels.ring_step`) stores the sample and windows, represents and
classifies every model whose window is due. Windows and labels are those of
:func:`~spotfree.classify.batch.classify_recording` (same scaling, same representation, same order, causal alignment).
CRC_RLS and kernel CRC_RLS run compiled for every representation; other classifiers get the gathered window in
Python.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from spotfree.classify.base import UNKNOWN
from spotfree.classify.crc import CRCClassifier
from spotfree.classify.kcrc import KernelCRCClassifier
from spotfree.kernels import IN_PYTHON, MODEL, NOT_FINITE, ring_block, ring_step
from spotfree.classify.smoothing import MajorityVote
from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.representation import summary_tables


class ModelRing:
    """The windows of several models over one stream of feature vectors (see the module docstring).

    Parameters
    ----------
    models : sequence of DictionaryModel
    picks : sequence of int arrays
        For each model, the index of each of its channels in the feature vectors given to :meth:`push`.
    width : int
        Length of those feature vectors.
    classifiers : sequence of fitted classifiers
        One per model (:func:`~spotfree.classify.batch.dictionary_classifier`); a plain
        :class:`~spotfree.classify.crc.CRCClassifier` or :class:`~spotfree.classify.kcrc.KernelCRCClassifier` runs
        compiled, any other through its ``predict_one``.
    smoothing : int or None
        Causal majority vote over that many samples, per model.
    """

    def __init__(self, models: Sequence[DictionaryModel], picks: Sequence[np.ndarray], width: int,
                 classifiers: Sequence, smoothing: int | None = None):
        if not len(models) == len(picks) == len(classifiers) > 0:
            raise InputError(f"ModelRing needs one channel pick and one classifier per model, got {len(models)} "
                             f"models, {len(picks)} picks, {len(classifiers)} classifiers")
        for model, pick in zip(models, picks):
            if len(pick) != len(model.channels) or len(model.scale) != len(model.channels) or (
                    len(pick) and not 0 <= min(pick) <= max(pick) < width):
                raise InputError(f"ModelRing: a model of channels {','.join(model.channels)} needs one scale and "
                                 f"one index below {width} per channel, got picks {list(pick)}")
        self.width = width
        self.models_ = np.zeros(len(models), MODEL)
        operators, kernels, y = [], [], 0
        for row, model, pick, clf in zip(self.models_, models, picks, classifiers):
            affine = float(model.parameters.get("affine", 0.0))
            kernel = type(clf) is KernelCRCClassifier
            compiled = kernel or type(clf) is CRCClassifier
            d = len(pick) * model.window + (affine != 0)
            row["window"], row["step"], row["channels"], row["d"], row["y"] = model.window, model.step, len(pick), d, y
            row["affine"], row["unit"], row["compiled"] = affine, model.normalisation == "unit", compiled
            row["reject"] = np.inf if getattr(clf, "reject", None) is None else clf.reject
            y += d
            if compiled and model.representation == "summary":
                taper, cos, sin, band, bands = summary_tables(model.window)
                row["summary"], row["bins"], row["bands"] = True, len(band), bands
                row["tables"], row["z"], row["p"] = sum(k.size for k in kernels), y, len(model.feature_offset)
                kernels += [taper, cos.reshape(-1), sin.reshape(-1), band.astype(float), model.feature_offset,
                            model.feature_scale]
                y += row["p"]
            if kernel:
                row["kernel"], row["gamma"], row["fitted"] = True, clf.gamma_, sum(k.size for k in kernels)
                row["m"], row["features"], row["head"] = len(clf.landmarks_), len(clf.normalisation_), clf.head_
                kernels.append(clf.live_)
            if compiled:
                row["classes"] = len(clf.classes_)
                if not kernel:
                    row["operator"] = sum(o.size for o in operators)
                    operators.append(clf.residual_operators_.astype(float).reshape(-1))
        self.models_["first"] = np.cumsum([0] + [len(p) for p in picks])[:-1]
        self._picks = np.concatenate([np.asarray(p, dtype=np.int64) for p in picks])
        self._scales = np.concatenate([np.asarray(m.scale, dtype=float) for m in models])
        self._operators = np.concatenate(operators) if operators else np.zeros(0)
        self._kernels = np.ascontiguousarray(np.concatenate(kernels), dtype=float) if kernels else np.zeros(0)
        self._windows = np.zeros(y)
        self._ring = np.zeros((width, 2 * max(m.window for m in models)))
        self._cursor = np.zeros(2, dtype=np.int64)
        self._names = [(*map(str, clf.classes_), UNKNOWN) for clf in classifiers]
        self._predict = [_window_predictor(clf, model) for clf, model in zip(classifiers, models)]
        self._views = [self._windows[r["y"]:r["y"] + r["d"]] for r in self.models_]
        self._codes = self.models_["code"]
        self._votes = [MajorityVote(smoothing) for _ in models] if smoothing else None
        self._block = self._votes is None and bool(self.models_["compiled"].all())
        self.reset()

    def reset(self) -> None:
        """Start a new segment: no label until a model's first full window."""
        self._cursor[:] = 0
        self._labels: list[str | None] = [None] * len(self.models_)
        for vote in self._votes or ():
            vote.reset()

    def push(self, values: np.ndarray) -> list[str | None]:
        """The label of every model after the feature vector ``values`` ``(width,)`` (finite, float64): the label of
        its newest window, held between windows (None before the first), majority-voted when smoothing."""
        ring_step(self._ring, self._cursor, self.models_, self._picks, self._scales, self._operators, self._kernels,
                  self._windows, values)
        labels = self._update_labels(self._codes.tolist())
        if self._votes is None:
            return list(labels)
        return [vote.update(label) for vote, label in zip(self._votes, labels)]

    def push_block(self, values: np.ndarray) -> list[list[str | None]]:
        """:meth:`push` for every row of ``values`` ``(n, width)``: one list of labels per row. One compiled call
        when every model runs compiled and nothing is smoothed."""
        if not self._block:
            return [self.push(row) for row in np.asarray(values, dtype=float)]
        values = np.ascontiguousarray(values, dtype=float)
        codes = np.empty((len(values), len(self.models_)), dtype=np.int64)
        ring_block(self._ring, self._cursor, self.models_, self._picks, self._scales, self._operators, self._kernels,
                   self._windows, values, codes)
        return [list(self._update_labels(row)) for row in codes.tolist()]

    def _update_labels(self, codes: list[int]) -> list[str | None]:
        """The held labels after one sample whose per-model ``codes`` :func:`ring_step` set (see :data:`MODEL`)."""
        labels = self._labels
        for m, code in enumerate(codes):
            if code >= 0:
                labels[m] = self._names[m][code]
            elif code == IN_PYTHON:
                labels[m] = self._predict[m](self._views[m])
            elif code == NOT_FINITE:
                raise InputError("streaming classification: a window holds NaN or infinity; give finite samples")
        return labels


def _window_predictor(classifier, model: DictionaryModel):
    """A function from one gathered window ``(d,)`` to its class name: the window in the model's representation
    (:meth:`DictionaryModel.inputs`, for a model that is not ``hankel``), then the classifier's single-window path
    (``predict_one``) when it has one, else ``predict`` on a one-row matrix."""
    one = getattr(classifier, "predict_one", None)
    if model.representation != "hankel":
        if one is not None:
            return lambda y: str(one(model.inputs(y[:, None])[0]))
        return lambda y: str(classifier.predict(model.inputs(y[:, None]))[0])
    if one is not None:
        return lambda y: str(one(y))
    return lambda y: str(classifier.predict(y[None, :])[0])
