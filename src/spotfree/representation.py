"""Window representations: what the learner and the classifier see of one window.

A window is ``L`` samples of ``c`` channels, each channel already divided by its training scale
(:class:`~spotfree.windows.ChannelScaling`). It is stored as a column of the block-Hankel matrix
(:func:`~spotfree.windows.block_hankel`: channels stacked, each in time order). A representation maps that column to
the vector the dictionary holds and the classifier compares:

``hankel``
    The window itself, ``c L`` values: the paper's representation. It keeps the shape and the phase of a signal, so
    two cycles of one periodic motion taken at different phases are far apart.

``summary``
    Per channel ``x`` (``L`` samples), ``6 + B`` numbers: the level and spread ``mean(x)``, ``std(x)``, ``min(x)``,
    ``max(x)``; their change across the window, ``mean(x'') - mean(x')`` and ``std(x'') - std(x')`` with ``x'`` the
    older and ``x''`` the newer ``L // 2`` samples; and the log power of the Hann-tapered, mean-removed window in
    ``B`` frequency bands,

        P_b = log(1 + sum_{k in band b} |X_k|^2 / L)     X = rfft(hann * (x - mean(x)))

    the bins ``1 .. L // 2`` split into ``B`` bands of (about) equal width on a log scale. These do not change when a
    periodic motion is shifted in phase, and keep a level (a hard stop against a soft one) and a short peak (a
    kerb strike's ``max``). The two changes are the only ones that see the order of the samples: without them a
    window that leaves one class for another is the same as one that enters it, and a live label, which a window
    gives its newest sample, could not tell which of the two classes that sample belongs to.

Both are computed for a whole matrix at once and for one window (streaming) by the same compiled kernel
(:func:`~spotfree.kernels.summary_features`, with the tables of :func:`summary_tables`).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from spotfree.kernels import summary_matrix
from spotfree.errors import InputError

REPRESENTATIONS = ("summary", "hankel")
BANDS = 4
"""Frequency bands of the ``summary`` representation (fewer when the window has fewer spectral bins)."""


def band_edges(length: int, bands: int = BANDS) -> np.ndarray:
    """Edges (rfft bin indices, ``bands' + 1`` increasing values from 1 to ``length // 2 + 1``) of the log-spaced
    bands of a window of ``length`` samples; ``bands' <= bands`` when there are fewer bins than bands (none for a
    window of one sample)."""
    top = length // 2 + 1
    if top <= 1:
        return np.array([1])
    edges = np.unique(np.round(np.geomspace(1, top, bands + 1)).astype(int))
    edges[0], edges[-1] = 1, top
    return np.unique(edges)


@lru_cache(maxsize=64)
def summary_tables(length: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    """The tables of the ``summary`` representation of windows of ``length`` samples: the Hann taper ``(L,)``, the
    cosines and sines ``(bins, L)`` of the spectral bins ``k = 1 .. L // 2`` (``cos(2 pi k t / L)``,
    ``-sin(2 pi k t / L)``), the band of each bin ``(bins,)`` (:func:`band_edges`) and the number of bands. Read
    only."""
    edges = band_edges(length)
    bins = np.arange(1, edges[-1]) if len(edges) > 1 else np.arange(0)
    angle = 2 * np.pi * np.outer(bins, np.arange(length)) / length
    band = np.searchsorted(edges, bins, side="right") - 1
    tables = (np.hanning(length + 2)[1:-1], np.cos(angle), -np.sin(angle), band.astype(np.int64), len(edges) - 1)
    for table in tables[:4]:
        table.setflags(write=False)
    return tables


def represent(windows: np.ndarray, channels: int, representation: str) -> np.ndarray:
    """Representation of every column of ``windows`` ``(channels * L, m)``, as rows: ``(m, p)``.

    ``p = channels * L`` for ``hankel`` and ``channels * (6 + B')`` for ``summary`` (module docstring).
    """
    windows = np.asarray(windows, dtype=float)
    if windows.ndim == 1:
        windows = windows[:, None]
    if representation == "hankel":
        return np.ascontiguousarray(windows.T)
    if representation != "summary":
        raise InputError(f"unknown representation {representation!r}; use one of {', '.join(REPRESENTATIONS)}")
    d, m = windows.shape
    if channels < 1 or d % channels:
        raise InputError(f"windows of {d} values do not split into {channels} channels")
    length = d // channels
    taper, cos, sin, band, bands = summary_tables(length)
    out = np.empty((m, channels * (6 + bands)))
    summary_matrix(np.ascontiguousarray(windows.T), channels, taper, cos, sin, band, bands, out)
    return out


def representation_size(channels: int, length: int, representation: str) -> int:
    """Length ``p`` of one represented window."""
    if representation == "hankel":
        return channels * length
    return channels * (6 + len(band_edges(length)) - 1)
