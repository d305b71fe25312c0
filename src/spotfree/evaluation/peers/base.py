"""The interface every peer shares: trained on feature Recordings, it labels every sample of a test Recording.

A peer is a method the paper's spotting-free classifier is compared against in the evaluation. It

* ``fit(recordings)``: learns from Recordings that carry per-sample ground truth ``truth["label"]`` (the peers are
  given the hand-marked boundaries, the "spotting", that the paper's training does without);
* ``predict(recording)``: returns one label per sample, an array of ``str`` with ``""`` where the peer gives none;
* records its wall-clock cost: ``fit_time_`` (s, the last ``fit``) and ``predict_time_`` (s, the last ``predict``).

BLAS runs on one thread inside ``fit`` and ``predict``, as in :mod:`spotfree.cluster`: on shared 2-core machines,
OpenBLAS's two threads made the ``eigh`` of MiniRocket's ridge cross-validation many times slower than one
thread.

Channels are divided by their standard deviation over the training samples
(:class:`spotfree.windows.ChannelScaling`), as for the dictionary. A window of ``L = window`` samples ending at
sample ``e`` is aligned with the label stream as in :mod:`spotfree.classify.batch`: ``causal`` labels ``e`` (what
a live stream can do), ``centred`` labels ``e - L // 2`` (offline). Training windows take the ground-truth label of
that same sample, so a peer is trained and scored on one alignment. Windows never span a gap or two experiments.
Centred labels then get the vote spotfree's own offline labels get, over ``vote`` seconds
(:func:`~spotfree.classify.smoothing.vote_samples`; the learner's default ``smoothing`` unless set to the model's),
so that every method is scored after the same post-processing.
"""

from __future__ import annotations

import importlib
import time
from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np
from sklearn.base import BaseEstimator
from threadpoolctl import threadpool_limits

from spotfree.classify.smoothing import VOTE_SECONDS, alignment_smoothing, majority_vote, vote_samples
from spotfree.errors import InputError, SpotfreeError
from spotfree.io.recording import Recording
from spotfree.windows import ChannelScaling, recording_windows

ALIGNMENTS = ("causal", "centred")
DEFAULT_CHANNELS = ("lean", "acc_x")
CHUNK = 4096
"""Windows classified at once in predict (10,000 MiniRocket features of float32 each: about 160 MB)."""
RATE_TOLERANCE = 1e-6
"""Relative difference between the training rate and a test recording's that still counts as the same rate."""


class Peer(ABC, BaseEstimator):
    """Common parameters and checks of the peers.

    Parameters
    ----------
    channels : tuple of str
        Feature channels the peer reads (``Recording.array`` names).
    window : int
        Window length in samples (20 samples = 1 s at 20 Hz).
    """

    def __init__(self, channels=DEFAULT_CHANNELS, window: int = 20):
        self.channels = channels
        self.window = window

    def fit(self, recordings: Sequence[Recording]) -> "Peer":
        """Learn from ``recordings`` (each with ``truth["label"]``); sets ``fit_time_`` (s)."""
        start = time.perf_counter()
        recordings = self._check_training(recordings)
        self.scaling_ = ChannelScaling(tuple(self.channels)).fit(recordings)
        with threadpool_limits(1, user_api="blas"):
            self._fit(recordings)
        self.fit_time_ = time.perf_counter() - start
        return self

    def predict(self, recording: Recording) -> np.ndarray:
        """One label per sample of ``recording`` (``""`` where none); sets ``predict_time_`` (s)."""
        if not hasattr(self, "scaling_"):
            raise InputError(f"{type(self).__name__} is not fitted: call fit(recordings) before predict")
        start = time.perf_counter()
        self._check_rate(recording)
        with threadpool_limits(1, user_api="blas"):
            labels = self._predict(recording)
        self.predict_time_ = time.perf_counter() - start
        return labels

    @abstractmethod
    def _fit(self, recordings: list[Recording]) -> None:
        """Learn from the checked training recordings (``scaling_`` and ``rate_`` are set)."""

    @abstractmethod
    def _predict(self, recording: Recording) -> np.ndarray:
        """Per-sample labels of a recording at the training rate."""

    def _check_params(self) -> None:
        if not isinstance(self.window, (int, np.integer)) or self.window < 2:
            raise InputError(f"window must be an integer number of samples >= 2, got {self.window!r}")
        if isinstance(self.channels, str) or not len(self.channels):
            raise InputError(f"channels must be a non-empty tuple of channel names, got {self.channels!r}")

    def _check_training(self, recordings: Sequence[Recording]) -> list[Recording]:
        self._check_params()
        recordings = [recordings] if isinstance(recordings, Recording) else list(recordings)
        if not recordings:
            raise InputError("no training recordings: give at least one Recording with a 'label' truth column")
        for rec in recordings:
            if "label" not in rec.truth:
                raise InputError(
                    f"{rec.source}: no 'label' column; peers are trained on per-sample ground truth, so give "
                    "recordings that carry it (a simulated log, or a log with a label column)"
                )
        rates = sorted({rec.rate for rec in recordings})
        if rates[-1] > rates[0] * (1 + RATE_TOLERANCE):
            raise InputError(
                "training recordings have different rates ("
                + ", ".join(f"{rec.source}: {rec.rate:g} Hz" for rec in recordings)
                + "); resample them to one rate"
            )
        self.rate_ = float(rates[0])
        return recordings

    def _check_rate(self, recording: Recording) -> None:
        if abs(recording.rate - self.rate_) > RATE_TOLERANCE * self.rate_:
            raise InputError(
                f"{recording.source}: sampled at {recording.rate:g} Hz but the peer was trained at "
                f"{self.rate_:g} Hz; resample the recording to {self.rate_:g} Hz"
            )


class WindowClassifierPeer(Peer):
    """A peer that classifies every window with a supervised estimator (:meth:`_make_estimator`).

    ``estimator_`` is fitted on the training windows (:meth:`_features` of the ``(m, c, L)`` array) and their
    ground-truth labels; a test recording's windows are classified in chunks of :data:`CHUNK` windows to bound
    memory, and each label is written to the sample its window labels.

    Parameters
    ----------
    channels, window
        As for every peer (:class:`Peer`).
    alignment : {"causal", "centred"}
        Which sample of a window its label belongs to (module docstring).
    train_step : int
        Every ``train_step``-th training window of a recording is fitted on (1: every window; consecutive windows
        overlap in all but one sample, so a larger step bounds the fit's cost on long training rides).
    vote : float
        Span (s) of the majority vote of centred labels: that of the spotfree model compared with (its
        ``smoothing``), so that both are scored after the same vote.
    """

    def __init__(self, channels=DEFAULT_CHANNELS, window: int = 20, alignment: str = "causal", train_step: int = 1,
                 vote: float = VOTE_SECONDS):
        super().__init__(channels=channels, window=window)
        self.alignment = alignment
        self.train_step = train_step
        self.vote = vote

    @property
    def offset(self) -> int:
        """Samples between a window's last sample and the sample it labels."""
        return 0 if self.alignment == "causal" else int(self.window) // 2

    def _check_params(self) -> None:
        super()._check_params()
        if self.alignment not in ALIGNMENTS:
            raise InputError(f"alignment {self.alignment!r} is unknown: use one of {', '.join(ALIGNMENTS)}")
        if not isinstance(self.train_step, (int, np.integer)) or self.train_step < 1:
            raise InputError(f"train_step must be an integer >= 1, got {self.train_step!r}")
        if isinstance(self.vote, bool) or not isinstance(self.vote, (int, float, np.number)) \
                or not np.isfinite(self.vote) or self.vote < 0:
            raise InputError(f"vote must be seconds >= 0 (0: no vote), got {self.vote!r}")

    @abstractmethod
    def _make_estimator(self):
        """An unfitted scikit-learn style classifier of :meth:`_features` rows."""

    def _features(self, windows: np.ndarray) -> np.ndarray:
        """What the estimator sees of windows ``(m, c, L)``; the windows themselves unless overridden."""
        return windows

    def _windows(self, recording: Recording) -> tuple[np.ndarray, np.ndarray]:
        """Scaled windows ``(m, c, L)`` of ``recording`` and the index of the sample each one labels."""
        win = recording_windows(recording, tuple(self.channels), int(self.window), scaling=self.scaling_)
        c = len(self.channels)
        return win.matrix.T.reshape(-1, c, int(self.window)), win.ends - self.offset

    def _training_windows(self, recordings: list[Recording]) -> tuple[np.ndarray, np.ndarray]:
        """Windows ``(m, c, L)`` of all training recordings and the ground-truth label of the sample each labels.

        Windows whose labelled sample has no ground truth (``""``) are left out. Raises when fewer than two
        classes remain.
        """
        blocks, labels = [], []
        for rec in recordings:
            windows, labelled = self._windows(rec)
            windows, labelled = windows[::self.train_step], labelled[::self.train_step]
            truth = np.asarray(rec.truth["label"], dtype=str)[labelled]
            keep = truth != ""
            blocks.append(windows[keep])
            labels.append(truth[keep])
        X, y = np.concatenate(blocks), np.concatenate(labels)
        if len(np.unique(y)) < 2:
            raise InputError(
                f"training labels hold {len(np.unique(y))} class(es) ({', '.join(np.unique(y))}); a peer needs "
                "recordings with at least two classes"
            )
        return X, y

    def _fit(self, recordings: list[Recording]) -> None:
        X, y = self._training_windows(recordings)
        self.estimator_ = self._make_estimator().fit(self._features(X), y)
        self.classes_ = np.asarray(self.estimator_.classes_)

    def _predict(self, recording: Recording) -> np.ndarray:
        windows, labelled = self._windows(recording)
        labels = np.concatenate([
            self.estimator_.predict(self._features(windows[i:i + CHUNK])) for i in range(0, len(windows), CHUNK)
        ])
        out = per_sample(len(recording), labelled, labels)
        smoothing = alignment_smoothing(None, self.alignment == "centred", vote_samples(self.vote, recording.rate))
        if smoothing:  # the vote spotfree's own labels of this alignment get, so that both are scored alike
            for start, stop in recording.segments():
                out[start:stop] = majority_vote(out[start:stop], smoothing, centred=True)
        return out


def from_aeon(module: str, name: str):
    """``module.name`` from aeon, or an error that says how to install it."""
    try:
        return getattr(importlib.import_module(module), name)
    except ImportError as err:
        raise SpotfreeError(f"{name} comes from aeon, which is not installed ({err}); "
                            "install it with pip install -e '.[eval]'") from None


def per_sample(n: int, index: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """An ``(n,)`` array of ``str``: ``labels[j]`` at sample ``index[j]``, ``""`` elsewhere."""
    out = np.full(n, "", dtype=object)
    out[index] = labels
    return out.astype(str)
