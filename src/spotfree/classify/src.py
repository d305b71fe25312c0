"""Sparse representation-based classification (SRC).

Wright, Yang, Ganesh, Sastry, Ma, "Robust face recognition via sparse representation", IEEE TPAMI 2009; the
paper's eq. (5) with ``q = 2, p = 1``. Atoms are scaled to unit l2 norm, ``a_j / ||a_j||`` (the columns of
``Â``), and every window ``y`` is coded over the whole dictionary by the lasso

    x(y) = argmin_x  1/2 ||y - Â x||_2^2 + lambda(y) ||x||_1,   lambda(y) = alpha * ||Â^T y||_inf.

``||Â^T y||_inf`` is the smallest weight at which ``x = 0``, so ``alpha`` in ``(0, 1)`` is free of units and of the
window's amplitude: the same ``alpha`` gives the same support for ``y`` and ``10 y``. Class residuals
``r_i(y) = ||y - Â_i x_i||`` (``Â_i, x_i``: the atoms and coefficients of class ``i``).

Solver: scikit-learn's ``sparse_encode``, one window at a time, by least-angle regression (``"lasso_lars"``, the
homotopy path: exact) or coordinate descent (``"lasso_cd"``).
``sparse_encode`` solves ``1/2 ||y - Â x||^2 + alpha' ||x||_1``; each window is divided by its ``||Â^T y||_inf``
so that ``alpha' = alpha``, and its code multiplied back. (Proximal gradient, as B_SRC uses, needed more than 1000
iterations for most ride windows: the atoms of a block-Hankel dictionary are nearly collinear.)
"""

from __future__ import annotations

import numpy as np
from sklearn.decomposition import sparse_encode

from spotfree.classify.base import ResidualClassifier, class_residuals, unit_atoms
from spotfree.errors import InputError

ALGORITHMS = ("lasso_lars", "lasso_cd")


class SRCClassifier(ResidualClassifier):
    """SRC: an l1 code of each window over the whole (unit-norm) dictionary (module docstring).

    Parameters
    ----------
    alpha : float
        l1 weight relative to ``||Â^T y||_inf`` (module docstring), in ``(0, 1)``.
    algorithm : {"lasso_lars", "lasso_cd"}
        The lasso solver (module docstring).
    max_iter : int
        Iteration limit of the solver.
    reject : float or None
        Rejection threshold on ``min_i r_i / ||y||`` (see :mod:`spotfree.classify.base`); ``None`` is off.
    """

    def __init__(self, alpha: float = 0.05, algorithm: str = "lasso_lars", max_iter: int = 1000,
                 reject: float | None = None):
        super().__init__(reject=reject)
        self.alpha = alpha
        self.algorithm = algorithm
        self.max_iter = max_iter

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if not 0 < self.alpha < 1:
            raise InputError(f"alpha={self.alpha!r}: give the l1 weight as a fraction of ||A^T y||_inf in (0, 1)")
        if self.algorithm not in ALGORITHMS:
            raise InputError(f"algorithm={self.algorithm!r}: use one of {', '.join(ALGORITHMS)}")
        self.atoms_ = unit_atoms(A)
        self.gram_ = self.atoms_ @ self.atoms_.T

    def code(self, X) -> np.ndarray:
        """Sparse codes ``x(y)`` ``(n_windows, n_atoms)`` of the windows (rows of ``X``) over the unit atoms."""
        return self._code(self._check_windows(X))

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        return class_residuals(X, self._code(X), self.atoms_, self.atom_class_, len(self.classes_))

    def _code(self, X: np.ndarray) -> np.ndarray:
        cov = self.atoms_ @ X.T  # Â^T y per window, (n_atoms, n)
        scale = np.abs(cov).max(axis=0)
        scale = np.where(scale > 0, scale, 1.0)
        code = sparse_encode(X / scale[:, None], self.atoms_, gram=self.gram_, cov=cov / scale,
                             algorithm=self.algorithm, alpha=self.alpha, max_iter=self.max_iter)
        return code * scale[:, None]
