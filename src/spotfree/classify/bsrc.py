"""Block-sparse representation-based classification (B_SRC) with one block per class.

The paper's B_SRC codes a window with few whole classes instead of few atoms. Here the code is the group lasso
(Yuan & Lin 2006) over the unit-norm dictionary ``Â = [Â_1, ..., Â_C]`` (atoms ``a_j / ||a_j||``; block ``i``
holds the ``n_i`` atoms of class ``i``):

    x(y) = argmin_x  1/2 ||y - Â x||_2^2 + lambda(y) sum_i w_i ||x_i||_2,      w_i = sqrt(n_i / mean_k n_k),
    lambda(y) = alpha * max_i ||Â_i^T y||_2 / w_i,

``lambda(y)`` being the smallest weight at which ``x = 0`` (so ``alpha`` in ``(0, 1)`` is free of units and of
amplitude); ``w_i`` keeps a class with more atoms from being favoured. Class residuals ``r_i(y) = ||y - Â_i x_i||``.
Solved by FISTA with a duality-gap stop (:mod:`spotfree.classify.fista`).
"""

from __future__ import annotations

import numpy as np

from spotfree.classify.base import ResidualClassifier, class_residuals, unit_atoms
from spotfree.classify.fista import GroupLasso
from spotfree.errors import InputError


class BlockSparseClassifier(ResidualClassifier):
    """B_SRC: group lasso with one block per class (module docstring).

    Parameters
    ----------
    alpha : float
        Block weight relative to ``max_i ||Â_i^T y|| / w_i`` (module docstring), in ``(0, 1)``.
    tol : float
        Duality gap at which a window is done, relative to ``1/2 ||y||^2``.
    max_iter : int
        FISTA iteration limit; windows not done by then keep their last iterate, with a ``ConvergenceWarning``.
    reject : float or None
        Rejection threshold on ``min_i r_i / ||y||`` (see :mod:`spotfree.classify.base`); ``None`` is off.
    """

    def __init__(self, alpha: float = 0.02, tol: float = 1e-4, max_iter: int = 1000, reject: float | None = None):
        super().__init__(reject=reject)
        self.alpha = alpha
        self.tol = tol
        self.max_iter = max_iter

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if not 0 < self.alpha < 1:
            raise InputError(f"alpha={self.alpha!r}: give the block weight as a fraction of lambda_max in (0, 1)")
        sizes = np.bincount(atom_class)
        self.solver_ = GroupLasso(unit_atoms(A), groups=atom_class, weights=np.sqrt(sizes / sizes.mean()),
                                  tol=self.tol, max_iter=self.max_iter)

    def code(self, X) -> np.ndarray:
        """Block-sparse codes ``x(y)`` ``(n_windows, n_atoms)`` of the windows (rows of ``X``) over the unit atoms."""
        return self.solver_.codes(self._check_windows(X), self.alpha)

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        code = self.solver_.codes(X, self.alpha)
        return class_residuals(X, code, self.solver_.atoms, self.atom_class_, len(self.classes_))
