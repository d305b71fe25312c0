"""Nearest-columns classification over the same dictionary: an amplitude-aware rule beside CRC_RLS.

Not in the paper. A class residual of CRC_RLS, ``||y - A_i x_i||``, is blind to amplitude: once a class has about
as many atoms as the window has dimensions it represents a soft stop as well as a hard one by scaling its
coefficients. Here the residual of class ``i`` is the mean Euclidean distance from the window to its ``k`` nearest
atoms of that class,

    r_i(y) = (1 / k_i) sum_{j in N_k(y, A_i)} ||y - a_j||_2,    k_i = min(k, n_i),

and the label is ``argmin_i r_i`` like the other residual classifiers (rejection, ``predict_one`` included).

Distances come from ``||y||^2 + ||a||^2 - 2 y.a`` (one matrix product per chunk of windows); one window is
classified by a compiled loop (a few microseconds for a few hundred atoms).
"""

from __future__ import annotations

import numba
import numpy as np

from spotfree.classify.base import ResidualClassifier
from spotfree.errors import InputError

CHUNK = 4096
"""Windows per matrix product in batch classification."""


class NearestColumnsClassifier(ResidualClassifier):
    """Mean distance to the ``n_neighbors`` nearest atoms of each class (module docstring).

    Parameters
    ----------
    n_neighbors : int
        ``k``, atoms per class averaged (fewer when a class has fewer atoms).
    reject : float or None
        As :class:`~spotfree.classify.base.ResidualClassifier`.
    """

    def __init__(self, n_neighbors: int = 5, reject: float | None = None):
        super().__init__(reject=reject)
        self.n_neighbors = n_neighbors

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if isinstance(self.n_neighbors, bool) or not isinstance(self.n_neighbors, (int, np.integer)) \
                or self.n_neighbors < 1:
            raise InputError(f"n_neighbors={self.n_neighbors!r}: give a whole number of atoms >= 1")
        order = np.argsort(atom_class, kind="stable")
        self.atoms_ = np.ascontiguousarray(A.T[order])  # (n_atoms, d), grouped by class
        self.atom_norms_ = np.einsum("ij,ij->i", self.atoms_, self.atoms_)
        counts = np.bincount(atom_class, minlength=len(self.classes_))
        self.class_start_ = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        out = np.empty((len(X), len(self.classes_)))
        for start in range(0, len(X), CHUNK):
            Y = X[start:start + CHUNK]
            squared = np.einsum("ij,ij->i", Y, Y)[:, None] + self.atom_norms_[None, :] - 2.0 * (Y @ self.atoms_.T)
            distance = np.sqrt(np.maximum(squared, 0.0))
            for i in range(len(self.classes_)):
                block = distance[:, self.class_start_[i]:self.class_start_[i + 1]]
                k = min(self.n_neighbors, block.shape[1])
                out[start:start + CHUNK, i] = np.partition(block, k - 1, axis=1)[:, :k].mean(axis=1)
        return out

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)`` by the compiled loop (same residuals as :meth:`predict`)."""
        y = self._one_window(y, self.atoms_.shape[1])
        if not np.all(np.isfinite(y)):
            raise self._not_finite()
        if self.reject is not None:
            return super().predict_one(y)
        return self.classes_[_nearest_class(y, self.atoms_, self.class_start_, int(self.n_neighbors))]


@numba.njit(cache=True, nogil=True)
def _nearest_class(y, atoms, class_start, k):  # pragma: no cover - compiled
    best, best_class = np.inf, 0
    nearest = np.empty(k)
    for i in range(len(class_start) - 1):
        start, stop = class_start[i], class_start[i + 1]
        m = min(k, stop - start)
        filled = 0
        for j in range(start, stop):
            d = 0.0
            for t in range(y.shape[0]):
                diff = y[t] - atoms[j, t]
                d += diff * diff
            d = np.sqrt(d)
            if filled < m:  # insertion into the sorted list of the m nearest so far
                p = filled
                filled += 1
            elif d < nearest[m - 1]:
                p = m - 1
            else:
                continue
            while p > 0 and nearest[p - 1] > d:
                nearest[p] = nearest[p - 1]
                p -= 1
            nearest[p] = d
        mean = nearest[:m].mean()
        if mean < best:
            best, best_class = mean, i
    return best_class
