"""Collaborative representation classification with regularised least squares (CRC_RLS).

Zhang, Yang, Feng, "Sparse representation or collaborative representation: which helps face recognition?",
ICCV 2011; the paper's eqs. (6)-(7). With the dictionary ``A = [A_1, ..., A_C]`` (one atom per column, ``d`` rows):

    x = P y,   P = (A^T A + lambda I)^{-1} A^T                  (computed once, independent of y)
    r_i(y) = || y - A_i x_i ||_2,   label(y) = argmin_i r_i(y)

``x_i`` are the coefficients of class ``i``. Since ``A_i x_i = A_i P_i y`` is linear in ``y``, each class residual is
``r_i(y) = || E_i y ||`` with ``E_i = I - A_i P_i`` (``d x d``), so residuals never need ``x``. The rows of ``P``
that belong to class ``i`` are ``P_i = A_i^T (A A^T + lambda I)^{-1}`` (push-through identity), so

    E_i = I - A_i A_i^T (A A^T + lambda I)^{-1}

takes ``d x d`` systems only: fitting costs ``O(n d^2 + C d^3)`` for ``n`` atoms, not the ``O(n^3)`` of ``P``.

Batch: the ``C`` operators stacked, ``E = [E_1; ...; E_C]`` ``(C d, d)``, turn a chunk of windows into one matrix
product ``Z = Y E^T`` (``2 C d^2`` flops per window, BLAS), then the norm of each ``d``-block of each row of ``Z``
is taken, chunk by chunk (:data:`CHUNK_BYTES`); threads take whole chunks, each with a single-threaded BLAS, so that the
threads do not contend for the cores inside one BLAS call (``benchmarks/crc_speed.py`` times it). Streaming
(:meth:`CRCClassifier.predict_one`): one compiled kernel (:func:`~spotfree.kernels.crc_window`) computes
the ``C`` norms of ``E y`` and the argmin for a single window, without numpy's per-call overhead.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from functools import lru_cache
from typing import Callable

import numpy as np
from sklearn.utils.validation import check_is_fitted
from threadpoolctl import ThreadpoolController

from spotfree.classify.base import UNKNOWN, ResidualClassifier
from spotfree.kernels import crc_window
from spotfree.errors import InputError

DTYPES = ("float64", "float32")
CHUNK_BYTES = 1 << 22
"""Size of one chunk's product ``Z`` (bytes). Each chunk costs, besides its matrix products, a fixed amount of Python
between them and a hand-over between threads (which hold the interpreter's lock there); chunks of a few thousand
windows make that small against the products, which then run from the shared L3 cache rather than from a core's
L2 (``benchmarks/crc_speed.py`` measures the throughput)."""


class CRCClassifier(ResidualClassifier):
    """CRC_RLS.

    Parameters
    ----------
    alpha : float
        Ridge weight relative to the dictionary's mean squared atom norm: ``lambda = alpha * mean_j ||a_j||^2``,
        so that the regularisation does not depend on the units of the windows.
    reject : float or None
        Rejection threshold on ``min_i r_i / ||y||`` (see :mod:`spotfree.classify.base`); ``None`` is off.
    dtype : {"float64", "float32"}
        Arithmetic of the batch path (:meth:`decision_function`, :meth:`predict`). ``"float32"`` roughly doubles
        the matrix-product rate; its residuals differ from double precision by about ``1e-6`` of the window norm
        (float32 rounding over ``d`` terms). :meth:`predict_one` always computes in double precision.
    n_jobs : int
        Threads of the batch path (``-1``: one per core).
    """

    def __init__(self, alpha: float = 1e-3, reject: float | None = None, dtype: str = "float64", n_jobs: int = -1):
        super().__init__(reject=reject)
        self.alpha = alpha
        self.dtype = dtype
        self.n_jobs = n_jobs

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if self.dtype not in DTYPES:
            raise InputError(f"dtype={self.dtype!r}: use one of {', '.join(DTYPES)}")
        check_n_jobs(self.n_jobs)
        outer = A @ A.T  # (d, d)
        self.lambda_ = float(self.alpha * max(np.trace(outer) / max(A.shape[1], 1), np.finfo(float).tiny))
        eye = np.eye(A.shape[0])
        regularised = outer + self.lambda_ * eye
        blocks = [A[:, atom_class == i] for i in range(len(self.classes_))]
        self.residual_operators_ = np.stack(
            [eye - np.linalg.solve(regularised, A_i @ A_i.T).T for A_i in blocks]
        )  # E_i = I - A_i A_i^T (A A^T + lambda I)^{-1}, (C, d, d)
        stacked = self.residual_operators_.reshape(-1, A.shape[0])  # E, (C d, d)
        self._operator = np.ascontiguousarray(stacked)
        self._operator_t = np.ascontiguousarray(stacked.T, dtype=self.dtype)

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        n_classes, d = self.residual_operators_.shape[:2]
        operator = self._operator_t
        out = np.empty((len(X), n_classes), dtype=operator.dtype)

        def residuals(rows: slice) -> None:
            block = np.matmul(X[rows].astype(operator.dtype, copy=False), operator).reshape(-1, d)  # E_i y, stacked
            squares = out[rows].reshape(-1)
            np.sqrt(np.einsum("ij,ij->i", block, block, out=squares), out=squares)

        in_chunks(residuals, len(X), n_classes * d * operator.itemsize, self.n_jobs)
        return out.astype(float, copy=False)

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)`` (double precision, one compiled call); for streaming."""
        try:
            operator = self._operator
        except AttributeError:
            check_is_fitted(self, "residual_operators_")
            raise
        best, ratio = crc_window(operator, len(self.classes_), self._one_window(y, operator.shape[1]))
        if best < 0:
            raise self._not_finite()
        if self.reject is not None and ratio > self.reject:
            return UNKNOWN
        return self.classes_[best]


def in_chunks(work: Callable[[slice], None], n_rows: int, row_bytes: int, n_jobs: int) -> None:
    """``work(rows)`` over consecutive slices of ``n_rows`` rows of about :data:`CHUNK_BYTES` / ``row_bytes`` rows each
    (at least 16): in this thread when there is one slice, else shared out to ``n_jobs`` threads (``-1``: one per
    core) that each run a single-threaded BLAS."""
    chunk = max(16, CHUNK_BYTES // max(row_bytes, 1))
    starts = range(0, n_rows, chunk)
    if len(starts) <= 1:
        work(slice(0, n_rows))
        return
    threads = min(len(starts), (os.cpu_count() or 1) if n_jobs == -1 else n_jobs)
    with _blas().limit(limits=1, user_api="blas"), ThreadPoolExecutor(threads) as pool:
        list(pool.map(work, (slice(start, start + chunk) for start in starts)))


def check_n_jobs(n_jobs) -> None:
    """A clear error unless ``n_jobs`` is ``-1`` or a number of threads >= 1."""
    if not (n_jobs == -1 or (isinstance(n_jobs, (int, np.integer)) and n_jobs >= 1)):
        raise InputError(f"n_jobs={n_jobs!r}: give a number of threads >= 1, or -1 for one per core")


@lru_cache(maxsize=1)
def _blas() -> ThreadpoolController:
    """The process's thread pools (found once: the search takes milliseconds)."""
    return ThreadpoolController()
