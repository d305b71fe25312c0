"""Streaming windows of several models over one ring buffer of feature samples, classified in compiled code.

:class:`ModelRing` keeps the last ``L_max`` feature vectors of a segment (``L_max`` the longest window among its
models) in a ring buffer stored twice over, columns ``p`` and ``p + L_max`` holding the newest sample, so that the
last ``L`` samples of any model are the contiguous columns ``p + L_max - L + 1 .. p + L_max``. Per sample one
compiled call (:func:`ring_step`) stores the sample and, for every model whose window is due (the segment holds
``n >= L`` samples and ``(n - L) % step == 0``), gathers its window channel by channel, divides each channel by its
scale, divides the whole by its l2 norm for ``unit`` models, appends the affine row, and -- for CRC_RLS -- takes the
class residuals and their argmin (:func:`crc_window`); for kernel CRC_RLS it first maps the window to its Nystroem
features (:func:`kernel_features`). Windows and labels are those of
:func:`~spotfree.classify.batch.classify_recording` (same scaling, same order, causal alignment); other classifiers,
and models whose representation is not the raw window (``summary``), get the gathered window in Python.

:func:`crc_window` and :func:`kernel_features` are the single-window kernels of the classifiers' ``predict_one``
too; they live here because numba's disk cache only notices changes in the file of the function it caches, so a
compiled call chain stays inside one module.
"""

from __future__ import annotations

from typing import Sequence

import numba
import numpy as np

from spotfree.classify.base import UNKNOWN
from spotfree.classify.smoothing import MajorityVote
from spotfree.errors import InputError
from spotfree.model import DictionaryModel

# Reassociation lets the compiler vectorise the sums; no finite-math flags, so NaN checks stay.
_FAST = {"reassoc", "contract", "nsz", "arcp"}

MODEL = np.dtype([
    ("window", "i8"), ("step", "i8"), ("first", "i8"), ("channels", "i8"), ("d", "i8"), ("y", "i8"),
    ("affine", "f8"), ("unit", "?"), ("compiled", "?"), ("classes", "i8"), ("operator", "i8"), ("reject", "f8"),
    ("kernel", "?"), ("landmarks", "i8"), ("m", "i8"), ("features", "i8"), ("phi", "i8"), ("gamma", "f8"),
    ("code", "i8"),
])
"""One row per model of :func:`ring_step`'s table: window ``L`` and ``step`` (samples); ``first``, ``channels``: its
slice of the flat ``picks`` / ``scales``; ``d`` and ``y``: its window length (``channels L`` plus the affine row when
``affine != 0``) and offset in the flat ``windows``; ``unit``: l2-normalised columns; ``compiled``: CRC_RLS in the
kernel, with ``classes``, its operator's offset in the flat ``operators`` and the ``reject`` threshold (inf: off);
``kernel``: kernel CRC_RLS, its ``m`` landmarks (``m d``) and then its normalisation (``features m``) at offset
``landmarks`` of the flat ``kernels``, ``gamma``, and ``phi`` the offset of its features in ``windows``.
``code`` is the result of the last sample (:data:`NOT_DUE`, :data:`IN_PYTHON`, :data:`NOT_FINITE`, or the class index,
``classes`` meaning rejected)."""
NOT_DUE, IN_PYTHON, NOT_FINITE = -1, -2, -3


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def crc_window(operator, n_classes, y):  # pragma: no cover - compiled
    """Best class of ``y`` under the stacked operator ``(C d, d)`` and ``min_i r_i / ||y||``; ``-1`` if not finite."""
    d = y.shape[0]
    norm2 = 0.0
    for j in range(d):
        norm2 += y[j] * y[j]
    if not np.isfinite(norm2):
        return -1, np.nan
    best, best_r2 = 0, np.inf
    for c in range(n_classes):
        r2 = 0.0
        for i in range(c * d, (c + 1) * d):
            row = operator[i]
            e = 0.0
            for j in range(d):
                e += row[j] * y[j]
            r2 += e * e
        if r2 < best_r2:
            best, best_r2 = c, r2
    ratio = np.sqrt(best_r2 / norm2) if norm2 > 0 else np.inf
    return best, ratio


@numba.njit(cache=True, nogil=True, fastmath=_FAST)
def kernel_features(landmarks, normalisation, gamma, y, phi):  # pragma: no cover - compiled
    """``phi = normalisation exp(-gamma ||y - l_a||^2)_a`` (Nystroem features of ``y``); returns ``||phi||^2``, or
    -1 if ``y`` is not finite."""
    m, d = landmarks.shape
    for j in range(d):
        if not np.isfinite(y[j]):
            return -1.0
    k = np.empty(m)
    for a in range(m):
        s = 0.0
        for j in range(d):
            e = y[j] - landmarks[a, j]
            s += e * e
        k[a] = np.exp(-gamma * s)
    norm2 = 0.0
    for r in range(normalisation.shape[0]):
        s = 0.0
        for a in range(m):
            s += normalisation[r, a] * k[a]
        phi[r] = s
        norm2 += s * s
    return norm2


@numba.njit(cache=True, nogil=True)
def kernel_residual(ratio, norm2):  # pragma: no cover - compiled
    """Kernel CRC_RLS's ``min_i r_i`` from CRC_RLS's ``min_i r_i / ||phi||`` on the features and ``||phi||^2``: the
    feature vector's part outside the landmarks' span (``1 - ||phi||^2``) added (``spotfree.classify.kcrc``)."""
    return np.sqrt(max(ratio * ratio * norm2 + 1.0 - norm2, 0.0))


@numba.njit(cache=True, nogil=True)
def ring_step(ring, cursor, models, picks, scales, operators, kernels, windows, values):  # pragma: no cover - compiled
    """Store ``values`` ``(F,)`` in ``ring`` ``(F, 2 L_max)`` and set every model's ``code`` (see :data:`MODEL`);
    ``cursor`` is ``[position, samples in the segment]``, advanced here."""
    length = ring.shape[1] // 2
    p = cursor[0]
    for i in range(values.shape[0]):
        ring[i, p] = values[i]
        ring[i, p + length] = values[i]
    n = cursor[1] + 1
    cursor[0] = (p + 1) % length
    cursor[1] = n
    for m in range(models.shape[0]):
        model = models[m]
        window = model.window
        if n < window or (n - window) % model.step != 0:
            model.code = NOT_DUE
            continue
        y = windows[model.y:model.y + model.d]
        k, norm2 = 0, 0.0
        for i in range(model.channels):
            row, scale = ring[picks[model.first + i]], scales[model.first + i]
            for j in range(p + length - window + 1, p + length + 1):
                y[k] = row[j] / scale
                norm2 += y[k] * y[k]
                k += 1
        if model.unit and norm2 > 0:
            norm = np.sqrt(norm2)
            for k in range(model.channels * window):
                y[k] /= norm
        if model.affine != 0:
            y[model.d - 1] = model.affine
        if not model.compiled:
            model.code = IN_PYTHON
            continue
        d = model.d
        if model.kernel:
            size = model.m * model.d
            landmarks = kernels[model.landmarks:model.landmarks + size].reshape(model.m, model.d)
            normalisation = kernels[model.landmarks + size:model.landmarks + size + model.features * model.m]
            phi = windows[model.phi:model.phi + model.features]
            norm2 = kernel_features(landmarks, normalisation.reshape(model.features, model.m), model.gamma, y, phi)
            if norm2 < 0:
                model.code = NOT_FINITE
                continue
            y, d = phi, model.features
        size = model.classes * d * d
        operator = operators[model.operator:model.operator + size].reshape(model.classes * d, d)
        best, ratio = crc_window(operator, model.classes, y)
        if model.kernel:
            ratio = kernel_residual(ratio, norm2)
        if best < 0:
            model.code = NOT_FINITE
        elif ratio > model.reject:
            model.code = model.classes
        else:
            model.code = best


@numba.njit(cache=True, nogil=True)
def ring_block(ring, cursor, models, picks, scales, operators, kernels, windows, values, codes):  # pragma: no cover
    """:func:`ring_step` for every row of ``values`` ``(n, F)``; ``codes`` ``(n, models)`` receives each model's
    ``code`` after each row."""
    for k in range(values.shape[0]):
        ring_step(ring, cursor, models, picks, scales, operators, kernels, windows, values[k])
        for m in range(models.shape[0]):
            codes[k, m] = models[m].code


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
        from spotfree.classify.crc import CRCClassifier  # here: crc and kcrc import their kernels from this module
        from spotfree.classify.kcrc import KernelCRCClassifier

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
            raw = model.representation == "hankel"  # other representations are computed in Python
            kernel = raw and type(clf) is KernelCRCClassifier
            compiled = kernel or (raw and type(clf) is CRCClassifier)
            d = len(pick) * model.window + (affine != 0)
            row["window"], row["step"], row["channels"], row["d"], row["y"] = model.window, model.step, len(pick), d, y
            row["affine"], row["unit"], row["compiled"] = affine, model.normalisation == "unit", compiled
            row["reject"] = np.inf if getattr(clf, "reject", None) is None else clf.reject
            y += d
            if kernel:
                row["kernel"], row["gamma"], row["landmarks"] = True, clf.gamma_, sum(k.size for k in kernels)
                row["m"], row["features"], row["phi"] = len(clf.landmarks_), len(clf.normalisation_), y
                kernels += [clf.landmarks_.reshape(-1), clf.normalisation_.reshape(-1)]
                y += len(clf.normalisation_)
                clf = clf.crc_
            if compiled:
                row["classes"], row["operator"] = len(clf.classes_), sum(o.size for o in operators)
                operators.append(np.ascontiguousarray(clf.residual_operators_, dtype=float).reshape(-1))
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
