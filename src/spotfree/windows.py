"""Sliding windows and block-Hankel matrices.

A window of length ``L`` samples over ``c`` channels ending at sample ``t`` is the column

    y_t = [x_1[t-L+1 .. t], x_2[t-L+1 .. t], ..., x_c[t-L+1 .. t]]  in R^{cL}

(channels stacked, each channel's samples in time order). Windows taken every ``step`` samples, side by side, form
the block-Hankel matrix of the paper (section IV-B): neighbouring columns are shifted copies of each other.

Scaling: each channel is divided by a scale learned in training (:class:`ChannelScaling`), so that channels of
different units weigh alike while a hard stop keeps its larger amplitude than a soft one. The paper's unit-norm
columns (every window divided by its own l2 norm, which discards amplitude) are available as an option.

Affine term: :func:`with_affine_row` appends one constant row ``c`` to every column, ``[y_t; c]``. Subspace
clustering and collaborative representation see a window and its negative as the same 1-D subspace (a braking
window is about ``-1`` times an accelerating one); with the constant row, ``-[y; c] = [-y; -c]`` is no longer a
window, so sign and offset count.

Windows never span a gap or two experiments: they are cut from each gap-free segment of a Recording.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from spotfree.errors import InputError
from spotfree.io.recording import Recording

NORMALISATIONS = ("scale", "unit")


def block_hankel(x: np.ndarray, length: int, step: int = 1) -> np.ndarray:
    """Block-Hankel matrix ``(c * length, m)`` of the windows of ``x`` ``(n, c)``, one column per window.

    Column ``j`` is the window ending at sample ``(length - 1) + j * step``; ``m = (n - length) // step + 1``
    (zero when ``n < length``).
    """
    x = np.asarray(x, dtype=float)
    if x.ndim != 2:
        raise InputError(f"windows need a 2-D (samples, channels) array, got shape {x.shape}")
    n, c = x.shape
    if length < 1 or step < 1:
        raise InputError(f"window length and step must be >= 1, got length={length}, step={step}")
    if n < length:
        return np.empty((c * length, 0))
    view = sliding_window_view(x, length, axis=0)[::step]  # (m, c, length)
    return np.ascontiguousarray(view.reshape(view.shape[0], c * length).T)


def window_ends(n: int, length: int, step: int = 1) -> np.ndarray:
    """Index of the last sample of every window of :func:`block_hankel` over ``n`` samples."""
    if n < length:
        return np.empty(0, dtype=int)
    return np.arange(length - 1, n, step)


@dataclass
class ChannelScaling:
    """Per-channel scale ``s_c`` (channel units) learned in training; windows are ``x_c / s_c``.

    ``s_c`` is the standard deviation of channel ``c`` over all training samples (floored at ``1e-9`` times the
    largest scale so that a constant channel cannot divide by zero; such a channel is reported by
    :meth:`fit`).
    """

    channels: tuple[str, ...]
    scale: np.ndarray | None = None

    def fit(self, recordings: list[Recording]) -> "ChannelScaling":
        """Learn ``scale`` from the finite samples of ``recordings``; raise on a channel that never varies."""
        stacked = np.vstack([r.array(self.channels) for r in recordings])
        stacked = stacked[np.all(np.isfinite(stacked), axis=1)]
        if len(stacked) < 2:
            raise InputError("training data has fewer than two finite samples; check the recordings for NaN")
        scale = stacked.std(axis=0)
        constant = [c for c, s in zip(self.channels, scale) if not s > 1e-12 * max(scale.max(), 1.0)]
        if constant:
            raise InputError(
                f"channel(s) {', '.join(constant)} are constant in the training data and cannot separate "
                "classes; drop them with --channels"
            )
        self.scale = scale
        return self

    def transform(self, x: np.ndarray) -> np.ndarray:
        """``x`` ``(n, c)`` divided by the learned scales."""
        if self.scale is None:
            raise InputError("channel scaling is not fitted")
        return np.asarray(x, dtype=float) / self.scale


def normalise_columns(windows: np.ndarray, normalisation: str) -> np.ndarray:
    """Apply the column normalisation: ``"scale"`` keeps columns as they are, ``"unit"`` divides each by its l2 norm."""
    if normalisation == "scale":
        return windows
    if normalisation == "unit":
        norms = np.linalg.norm(windows, axis=0)
        return windows / np.where(norms > 0, norms, 1.0)
    raise InputError(f"unknown window normalisation '{normalisation}'; use one of {', '.join(NORMALISATIONS)}")


def with_affine_row(windows: np.ndarray, affine: float) -> np.ndarray:
    """``windows`` ``(d, m)`` with the constant row ``affine`` appended, ``(d + 1, m)``; unchanged when ``affine``
    is 0."""
    if affine == 0:
        return windows
    return np.vstack([windows, np.full((1, windows.shape[1]), float(affine))])


@dataclass
class WindowedRecording:
    """The windows of a Recording: matrix ``(c * length, m)`` and, per column, the sample index its window ends at."""

    matrix: np.ndarray
    ends: np.ndarray
    experiment: np.ndarray


def recording_windows(
    rec: Recording,
    channels: tuple[str, ...],
    length: int,
    step: int = 1,
    scaling: ChannelScaling | None = None,
    normalisation: str = "scale",
) -> WindowedRecording:
    """All windows of ``rec`` that lie inside one gap-free segment of one experiment, as a block-Hankel matrix."""
    x = rec.array(channels)
    if scaling is not None:
        x = scaling.transform(x)
    experiments = rec.experiment_numbers()
    blocks, ends = [], []
    for start, stop in rec.segments():
        blocks.append(block_hankel(x[start:stop], length, step))
        ends.append(start + window_ends(stop - start, length, step))
    if not blocks or sum(b.shape[1] for b in blocks) == 0:
        raise InputError(
            f"{rec.source}: no gap-free stretch is as long as one window ({length} samples = "
            f"{length / rec.rate:.2f} s); use a shorter --window or a longer recording"
        )
    matrix = normalise_columns(np.hstack(blocks), normalisation)
    ends_all = np.concatenate(ends)
    return WindowedRecording(matrix=matrix, ends=ends_all, experiment=experiments[ends_all])
