"""Kernel collaborative representation classification (kernel CRC_RLS): CRC_RLS in the feature space of a
Gaussian kernel, so that a window is represented by atoms that lie near it, not by scaled copies of distant ones.

CRC_RLS codes a window linearly, so ``c a`` is represented by ``a`` for any factor ``c``: a soft stop is explained
by a scaled hard stop. In the feature space ``phi`` of ``k(u, v) = exp(-gamma ||u - v||^2)`` a scaled atom is no
longer a scaled feature vector, and the same regularised least squares (Zhang, Yang, Feng, ICCV 2011; in kernel
form: Li, Du, Xiong, "Kernel collaborative representation with Tikhonov regularization for hyperspectral image
classification", IEEE GRSL 12(1), 2015, here with the plain ridge) become, with ``K = k(A, A)`` ``(n, n)``, ``k_y = k(A, y)`` ``(n,)`` and ``K_ii`` the block of class ``i``:

    x = (K + lambda I)^{-1} k_y = P k_y                            (P computed once)
    r_i(y)^2 = ||phi(y) - Phi_i x_i||^2 = 1 - 2 k_{y,i}^T x_i + x_i^T K_ii x_i,     label = argmin_i r_i

``||phi(y)|| = 1``, so the rejection ratio ``min_i r_i / ||phi(y)||`` is ``min_i r_i`` itself. ``gamma`` is given
relative to the atoms' spread: ``gamma = gamma_scale / median_{j<l} ||a_j - a_l||^2``, so it does not depend on
the windows' units. Cost per window: ``n d`` for the kernel row, ``n^2`` for ``x``, ``sum_i n_i^2`` for the
residuals (``n`` atoms of ``d`` values).

Measured against CRC_RLS on the simulated braking tests (``benchmarks/evaluation_seeds.py``, BENCHMARKS.md): far
fewer sudden-braking labels inside normal-braking rides, because a normal stop no longer matches a scaled-down
sudden stop.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.spatial.distance import pdist
from sklearn.utils.validation import check_is_fitted

from spotfree.classify.base import UNKNOWN, ResidualClassifier
from spotfree.errors import InputError

CHUNK = 4096
"""Windows per block of the batch path (its kernel rows, ``CHUNK x n`` doubles, stay a few MiB)."""


class KernelCRCClassifier(ResidualClassifier):
    """Kernel CRC_RLS with a Gaussian kernel (module docstring).

    Parameters
    ----------
    gamma_scale : float
        Kernel width relative to the atoms' spread: ``gamma = gamma_scale / median pairwise ||a_j - a_l||^2``.
    alpha : float
        Ridge weight ``lambda`` (the kernel's diagonal is 1, so it is already relative).
    reject : float or None
        Rejection threshold on ``min_i r_i`` (in [0, 1]: 0 explained exactly, 1 explained no better than by zero).
    """

    def __init__(self, gamma_scale: float = 0.25, alpha: float = 1e-3, reject: float | None = None):
        super().__init__(reject=reject)
        self.gamma_scale = gamma_scale
        self.alpha = alpha

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if not (np.isfinite(self.gamma_scale) and self.gamma_scale > 0):
            raise InputError(f"gamma_scale={self.gamma_scale!r}: give a kernel width > 0 (e.g. 0.25)")
        if not (np.isfinite(self.alpha) and self.alpha > 0):
            raise InputError(f"alpha={self.alpha!r}: give a ridge weight > 0 (e.g. 1e-3)")
        order = np.argsort(atom_class, kind="stable")
        atoms = np.ascontiguousarray(A.T[order])  # rows, grouped by class
        spread = float(np.median(pdist(atoms, "sqeuclidean"))) if len(atoms) > 1 else 0.0
        self.gamma_ = self.gamma_scale / (spread if spread > 0 else 1.0)
        gram = _kernel(atoms, atoms, self.gamma_)
        self.projection_ = np.linalg.solve(gram + self.alpha * np.eye(len(atoms)), np.eye(len(atoms)))  # P
        self.atoms_ = atoms
        self.atom_norms_ = np.einsum("ij,ij->i", atoms, atoms)
        self.bounds_ = np.searchsorted(atom_class[order], np.arange(len(self.classes_) + 1))  # class i: [b_i, b_i+1)
        self.block_gram_ = np.zeros_like(gram)  # blockdiag(K_ii)
        for lo, hi in zip(self.bounds_[:-1], self.bounds_[1:]):
            self.block_gram_[lo:hi, lo:hi] = gram[lo:hi, lo:hi]
        self.indicator_ = np.zeros((len(atoms), len(self.classes_)))
        self.indicator_[np.arange(len(atoms)), atom_class[order]] = 1.0

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        out = np.empty((len(X), len(self.classes_)))
        for start in range(0, len(X), CHUNK):
            k = _kernel(X[start:start + CHUNK], self.atoms_, self.gamma_, self.atom_norms_)
            x = k @ self.projection_
            r2 = 1.0 + (x * (x @ self.block_gram_ - 2.0 * k)) @ self.indicator_
            out[start:start + CHUNK] = np.sqrt(np.maximum(r2, 0.0))
        return out

    def _window_norms(self, X: np.ndarray) -> np.ndarray:
        return np.ones(len(X))

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)`` (one compiled call); for streaming."""
        check_is_fitted(self, "projection_")
        y = np.asarray(y, dtype=float)
        if y.shape != (self.atoms_.shape[1],):
            raise InputError(f"KernelCRCClassifier.predict_one takes one window of shape ({self.atoms_.shape[1]},) "
                             f"(window length times channels, as the dictionary was trained), got shape {y.shape}")
        best, r = _one_window(self.atoms_, self.projection_, self.block_gram_, self.bounds_, self.gamma_, y)
        if best < 0:
            raise InputError("KernelCRCClassifier.predict_one: the window holds NaN or infinity; give finite values "
                             "(cut windows inside gap-free stretches)")
        if self.reject is not None and r > self.reject:
            return UNKNOWN
        return self.classes_[best]


def _kernel(X: np.ndarray, atoms: np.ndarray, gamma: float, atom_norms: np.ndarray | None = None) -> np.ndarray:
    """``exp(-gamma ||x - a||^2)`` for every row ``x`` of ``X`` and row ``a`` of ``atoms``."""
    if atom_norms is None:
        atom_norms = np.einsum("ij,ij->i", atoms, atoms)
    d2 = np.einsum("ij,ij->i", X, X)[:, None] + atom_norms[None, :] - 2.0 * (X @ atoms.T)
    return np.exp(-gamma * np.maximum(d2, 0.0))


@numba.njit(cache=True, nogil=True)
def _one_window(atoms, projection, block_gram, bounds, gamma, y):  # pragma: no cover - compiled
    """Best class of ``y`` and its residual ``min_i r_i``; ``-1`` if ``y`` is not finite."""
    n, d = atoms.shape
    for j in range(d):
        if not np.isfinite(y[j]):
            return -1, np.nan
    k = np.empty(n)
    for a in range(n):
        s = 0.0
        for j in range(d):
            e = y[j] - atoms[a, j]
            s += e * e
        k[a] = np.exp(-gamma * s)
    x = projection @ k
    best, best_r2 = 0, np.inf
    for c in range(len(bounds) - 1):
        r2 = 1.0
        for a in range(bounds[c], bounds[c + 1]):
            q = 0.0
            for b in range(bounds[c], bounds[c + 1]):
                q += block_gram[a, b] * x[b]
            r2 += x[a] * (q - 2.0 * k[a])
        if r2 < best_r2:
            best, best_r2 = c, r2
    return best, np.sqrt(max(best_r2, 0.0))
