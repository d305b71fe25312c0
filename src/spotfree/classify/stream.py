"""Streaming classification: one raw IMU sample in, the label of that instant out.

:class:`RideClassifier` runs, per sample, the causal ride features (:class:`~spotfree.signal.features.FeatureStream`:
attitude filter, gravity-free level accelerations, Butterworth low-pass, lean), the model's channels divided by
its scales into a ring buffer of ``window`` samples, the column normalisation and the affine row, and the
dictionary classifier; the label is the causal one of :func:`~spotfree.classify.batch.classify_recording`, which
it equals sample for sample on the same log (windows every ``step`` samples of a segment, the label held in
between; optional majority vote).

A segment ends, and the filters, buffer and vote start afresh, at :meth:`RideClassifier.reset`, at a sample that
is not finite (a gap of a Recording is NaN), and, when sample times are given, at a time step longer than
``max_gap`` seconds or a time that does not increase (a new ride whose clock restarts). Samples are taken to
arrive at the model's rate; shorter holes are not filled.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from spotfree.classify.batch import dictionary_classifier, model_affine
from spotfree.classify.smoothing import MajorityVote, check_smoothing
from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS, FeatureStream

MAX_GAP = 0.5
"""Longest time step (s) inside one segment; the readers bridge holes up to this long and report longer ones."""


class RideClassifier:
    """Label a ride sample by sample with a trained model (see the module docstring).

    Parameters
    ----------
    model : DictionaryModel
    method : str
        ``crc`` | ``src`` | ``bsrc`` (:data:`spotfree.classify.METHODS`).
    smoothing : int or None
        Causal majority vote over that many samples (:mod:`spotfree.classify.smoothing`); None for none.
    max_gap : float
        Seconds between two sample times beyond which a new segment starts.
    classifier : estimator, optional
        A classifier already fitted by :func:`~spotfree.classify.batch.dictionary_classifier` (e.g. with a
        rejection threshold); fitted here by ``method`` when None.
    """

    def __init__(self, model: DictionaryModel, method: str = "crc", smoothing: int | None = None,
                 max_gap: float = MAX_GAP, classifier=None):
        self.model = model
        self.method = method
        self.smoothing = check_smoothing(smoothing)
        self.max_gap = max_gap
        self.classifier_ = classifier if classifier is not None else dictionary_classifier(model, method)
        self._predict = _window_predictor(self.classifier_)
        self._features = None
        if model.features == "ride":
            produced = FEATURE_CHANNELS + DERIVED_CHANNELS
            unknown = [c for c in model.channels if c not in produced]
            if unknown:
                raise InputError(f"model channel(s) {', '.join(unknown)} are not ride features "
                                 f"({', '.join(produced)}); this model cannot run on raw IMU samples")
            self._features = FeatureStream(model.rate, model.orientation, derived=True)
            self._pick = np.array([produced.index(c) for c in model.channels])
        channels, length = len(model.channels), model.window
        self._own = np.arange(channels)
        self._scale = np.asarray(model.scale, dtype=float)
        self._buffer = np.zeros((channels, 2 * length))
        affine = model_affine(model)
        self._y = np.full(channels * length + (affine != 0), affine)
        self._unit = model.normalisation == "unit"
        self._vote = MajorityVote(self.smoothing) if self.smoothing else None
        self._time: float | None = None
        self.reset()

    def reset(self) -> None:
        """Start a new segment (at a gap or a new ride): no label until a full window has come in."""
        if self._features is not None:
            self._features.reset()
        if self._vote is not None:
            self._vote.reset()
        self._position = 0
        self._count = 0
        self._label: str | None = None

    def update(self, acc, gyr, t: float | None = None, speed: float = math.nan) -> str | None:
        """The label at this sample (None before the first full window of a segment).

        ``acc`` (m/s^2, gravity included) and ``gyr`` (rad/s): 3-vectors in the device frame (Android: x right,
        y up, z out of the screen); ``t``: sample time in seconds, optional; ``speed``: the GPS speed (m/s) on a
        sample where a fix arrived, NaN otherwise (it feeds the ``acc_long`` channel).
        """
        if self._features is None:
            raise InputError(f"this model was trained on channels {','.join(self.model.channels)}, not on ride "
                             "features; feed them with update_features")
        a0, a1, a2 = float(acc[0]), float(acc[1]), float(acc[2])
        w0, w1, w2 = float(gyr[0]), float(gyr[1]), float(gyr[2])
        if self._starts_segment(t, math.isfinite(a0 + a1 + a2 + w0 + w1 + w2)):
            return None
        return self._push(self._features.update((a0, a1, a2), (w0, w1, w2), speed), self._pick)

    def update_features(self, x, t: float | None = None) -> str | None:
        """The label at this sample from the model's channels ``x`` (in ``model.channels`` order and units)."""
        x = np.asarray(x, dtype=float)
        if x.shape != self._scale.shape:
            raise InputError(f"update_features needs {len(self._scale)} values "
                             f"({','.join(self.model.channels)}), got shape {x.shape}")
        if self._starts_segment(t, bool(np.isfinite(x).all())):
            return None
        return self._push(x, self._own)

    def _starts_segment(self, t: float | None, finite: bool) -> bool:
        """Reset when this sample starts a new segment (time step, see the module docstring) or is not finite;
        True when it is not finite (a gap: no label)."""
        jump = False
        if t is not None:
            previous, self._time = self._time, float(t)
            jump = previous is not None and not 0 < self._time - previous <= self.max_gap
        if jump or not finite:
            self.reset()
        return not finite

    def _push(self, values: np.ndarray, pick: np.ndarray) -> str | None:
        """Scale the model's channels ``values[pick]`` into the ring buffer, classify when a window is due, return
        the (held) label."""
        p = self._position
        self._count += 1
        due = self._count - self.model.window
        due = due >= 0 and due % self.model.step == 0
        _push_sample(values, pick, self._scale, self._buffer, p, due, self._unit, self._y)
        self._position = (p + 1) % self.model.window
        if due:
            self._label = self._predict(self._y)
        if self._vote is not None:
            return self._vote.update(self._label)
        return self._label


@numba.njit(cache=True, nogil=True)
def _push_sample(values, pick, scale, buffer, position, due, unit, y):  # pragma: no cover - compiled
    """Write ``values[pick] / scale`` into columns ``position`` and ``position + L`` of the ring ``buffer``
    ``(c, 2 L)``, so that columns ``position + 1 .. position + L`` always hold the last ``L`` samples in time order.
    When ``due``, copy that window channel by channel into ``y[:c L]`` (divided by its l2 norm when ``unit``)."""
    channels, length = buffer.shape[0], buffer.shape[1] // 2
    for i in range(channels):
        v = values[pick[i]] / scale[i]
        buffer[i, position] = v
        buffer[i, position + length] = v
    if not due:
        return
    k, norm2 = 0, 0.0
    for i in range(channels):
        for j in range(position + 1, position + 1 + length):
            y[k] = buffer[i, j]
            norm2 += y[k] * y[k]
            k += 1
    if unit and norm2 > 0:
        norm = np.sqrt(norm2)
        for k in range(channels * length):
            y[k] /= norm


def _window_predictor(classifier):
    """A function from one window ``(d,)`` to its class name: the classifier's single-window path
    (``predict_one``) when it has one, else ``predict`` on a one-row matrix."""
    one = getattr(classifier, "predict_one", None)
    if one is not None:
        return lambda y: str(one(y))
    return lambda y: str(classifier.predict(y[None, :])[0])
