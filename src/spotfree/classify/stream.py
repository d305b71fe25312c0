"""Streaming classification: one raw IMU sample in, the label of that instant out.

:class:`RideClassifier` runs, per sample, the causal ride features (:class:`~spotfree.signal.features.FeatureStream`:
attitude filter, gravity-free level accelerations, Butterworth low-pass, derived channels; one compiled call) and
the model's window over a ring buffer of feature samples (:class:`~spotfree.classify.ring.ModelRing`: channels
divided by the model's scales, column normalisation, affine row and, for CRC_RLS, the classification; a second
compiled call); the label is the causal one of :func:`~spotfree.classify.batch.classify_recording`, which it equals
sample for sample on the same log (windows every ``step`` samples of a segment, the label held in between; optional
majority vote).

A segment ends, and the filters, buffer and vote start afresh, at :meth:`RideClassifier.reset`, at a sample that
is not finite (a gap of a Recording is NaN), and, when sample times are given, at a time step longer than
``max_gap`` seconds or a time that does not increase (a new ride whose clock restarts). Samples are taken to
arrive at the model's rate; shorter holes are not filled.
"""

from __future__ import annotations

import math

import numpy as np

from spotfree.classify import DEFAULT_METHOD
from spotfree.classify.batch import dictionary_classifier
from spotfree.classify.ring import ModelRing
from spotfree.classify.smoothing import check_smoothing
from spotfree.errors import InputError
from spotfree.model import DictionaryModel
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS, FeatureStream, imu_floats

PRODUCED = FEATURE_CHANNELS + DERIVED_CHANNELS
"""The channels of one ride feature pass, in :meth:`FeatureStream.step` order."""

MAX_GAP = 0.5
"""Longest time step (s) inside one segment; the readers bridge holes up to this long and report longer ones."""


class RideClassifier:
    """Label a ride sample by sample with a trained model (see the module docstring).

    Parameters
    ----------
    model : DictionaryModel
    method : str
        ``kcrc`` (default) | ``crc`` | ``src`` | ``bsrc`` | ``nearest`` (:data:`spotfree.classify.METHODS`).
    smoothing : int or None
        Causal majority vote over that many samples (:mod:`spotfree.classify.smoothing`); None for none.
    max_gap : float
        Seconds between two sample times beyond which a new segment starts.
    classifier : estimator, optional
        A classifier already fitted by :func:`~spotfree.classify.batch.dictionary_classifier` (e.g. with a
        rejection threshold); fitted here by ``method`` when None.
    """

    def __init__(self, model: DictionaryModel, method: str = DEFAULT_METHOD, smoothing: int | None = None,
                 max_gap: float = MAX_GAP, classifier=None):
        self.model = model
        self.method = method
        self.smoothing = check_smoothing(smoothing)
        self.max_gap = max_gap
        self.classifier_ = classifier if classifier is not None else dictionary_classifier(model, method, causal=True)
        self._features = None
        self._pick = np.arange(len(model.channels))  # where the model's channels sit in a feature vector
        if model.features == "ride":
            unknown = [c for c in model.channels if c not in PRODUCED]
            if unknown:
                raise InputError(f"model channel(s) {', '.join(unknown)} are not ride features "
                                 f"({', '.join(PRODUCED)}); this model cannot run on raw IMU samples")
            self._features = FeatureStream(model.rate, model.orientation, derived=True)
            self._pick = np.array([PRODUCED.index(c) for c in model.channels])
        self._values = np.zeros(len(PRODUCED) if self._features is not None else len(self._pick))
        self._ring = ModelRing([model], [self._pick], len(self._values), [self.classifier_], self.smoothing)
        self._time: float | None = None
        self.reset()

    def reset(self) -> None:
        """Start a new segment (at a gap or a new ride): no label until a full window has come in."""
        if self._features is not None:
            self._features.reset()
        self._ring.reset()

    def update(self, acc, gyr, t: float | None = None, speed: float = math.nan) -> str | None:
        """The label at this sample (None before the first full window of a segment).

        ``acc`` (m/s^2, gravity included) and ``gyr`` (rad/s): 3-vectors in the device frame (Android: x right,
        y up, z out of the screen); ``t``: sample time in seconds, optional; ``speed``: the GPS speed (m/s) on a
        sample where a fix arrived, NaN otherwise (it feeds the ``acc_long`` channel).
        """
        if self._features is None:
            raise InputError(f"this model was trained on channels {','.join(self.model.channels)}, not on ride "
                             "features; feed them with update_features")
        a0, a1, a2, w0, w1, w2 = imu_floats(acc, gyr)
        if self._starts_segment(t, math.isfinite(a0 + a1 + a2 + w0 + w1 + w2)):
            return None
        self._features.step(a0, a1, a2, w0, w1, w2, float(speed), self._values)
        return self._ring.push(self._values)[0]

    def update_features(self, x, t: float | None = None) -> str | None:
        """The label at this sample from the model's channels ``x`` (in ``model.channels`` order and units)."""
        x = np.asarray(x, dtype=float)
        if x.shape != self._pick.shape:
            raise InputError(f"update_features needs {len(self._pick)} values "
                             f"({','.join(self.model.channels)}), got shape {x.shape}")
        if self._starts_segment(t, bool(np.isfinite(x).all())):
            return None
        self._values[self._pick] = x
        return self._ring.push(self._values)[0]

    def update_features_block(self, x: np.ndarray, t: np.ndarray) -> list[str | None]:
        """:meth:`update_features` for every row of ``x`` ``(n, channels)`` at the times ``t`` ``(n,)`` (s): the label
        at each row, from one compiled call per segment when every value is finite."""
        x = np.asarray(x, dtype=float)
        t = np.asarray(t, dtype=float)
        if x.ndim != 2 or x.shape[1:] != self._pick.shape or t.shape != x.shape[:1]:
            raise InputError(f"update_features_block needs rows of {len(self._pick)} values "
                             f"({','.join(self.model.channels)}) and one time per row, got shapes {x.shape}, "
                             f"{t.shape}")
        if not np.isfinite(x).all():
            return [self.update_features(row, s) for row, s in zip(x, t.tolist())]
        values = np.zeros((len(x), len(self._values)))
        values[:, self._pick] = x
        return self.update_produced_block(values, t)

    def update_produced_block(self, values: np.ndarray, t: np.ndarray,
                              runs: list[tuple[slice, bool]] | None = None) -> list[str | None]:
        """The label at each row of ``values`` ``(n, len(PRODUCED))`` (finite feature vectors of every
        :data:`PRODUCED` channel, as :class:`~spotfree.signal.features.FeatureStream` gives them with ``derived``)
        at the times ``t`` (s); ``runs``: :func:`segment_runs` of ``t`` if the caller has them."""
        labels: list[str | None] = []
        for rows, fresh in runs if runs is not None else segment_runs(t, self._time, self.max_gap):
            if fresh:
                self.reset()
            labels += [row[0] for row in self._ring.push_block(values[rows])]
        self._time = float(t[-1])
        return labels

    def _starts_segment(self, t: float | None, finite: bool) -> bool:
        """Reset when this sample starts a new segment (time step, see the module docstring) or is not finite;
        True when it is not finite (a gap: no label)."""
        jump = False
        if t is not None:
            previous, self._time = self._time, float(t)
            jump = starts_segment(previous, self._time, self.max_gap)
        if jump or not finite:
            self.reset()
        return not finite


def starts_segment(previous: float | None, t: float, max_gap: float) -> bool:
    """Whether a sample at ``t`` (s) after one at ``previous`` (None: none yet) starts a new segment: a time step
    that is not in ``(0, max_gap]``."""
    return previous is not None and not 0 < t - previous <= max_gap


def segment_runs(t: np.ndarray, previous: float | None, max_gap: float) -> list[tuple[slice, bool]]:
    """The rows of the sample times ``t`` split where a new segment starts (a step from the sample before, or from
    ``previous`` for the first row, that is not in ``(0, max_gap]`` s): ``(rows, starts a new segment)`` per run."""
    times = t.tolist()  # a batch is a few samples: plain floats beat array calls
    starts = [k for k in range(1, len(times)) if starts_segment(times[k - 1], times[k], max_gap)]
    first = starts_segment(previous, times[0], max_gap)
    bounds = [0, *starts, len(times)]
    return [(slice(a, b), first if a == 0 else True) for a, b in zip(bounds, bounds[1:])]
