"""Collaborative representation classification with regularised least squares (CRC_RLS).

Zhang, Yang, Feng, "Sparse representation or collaborative representation: which helps face recognition?",
ICCV 2011; the paper's eqs. (6)-(7). With the dictionary ``A = [A_1, ..., A_C]`` (one atom per column, ``d`` rows):

    x = P y,   P = (A^T A + lambda I)^{-1} A^T                  (computed once, independent of y)
    r_i(y) = || y - A_i x_i ||_2,   label(y) = argmin_i r_i(y)

``x_i`` are the coefficients of class ``i``. Since ``A_i x_i = A_i P_i y`` is linear in ``y``, each class residual is
``r_i(y) = || E_i y ||`` with ``E_i = I - A_i P_i`` (``d x d``), so residuals never need ``x``.

Estimator convention (scikit-learn): ``fit(X, y)`` takes the atoms as rows, ``X`` of shape ``(n_atoms, d)``;
``predict`` and ``decision_function`` take windows as rows. ``decision_function`` returns the class residuals
(smaller is better), as the paper ranks classes, not scikit-learn's larger-is-better scores.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data


class CRCClassifier(ClassifierMixin, BaseEstimator):
    """CRC_RLS.

    Parameters
    ----------
    alpha : float
        Ridge weight relative to the dictionary's mean squared atom norm: ``lambda = alpha * mean_j ||a_j||^2``,
        so that the regularisation does not depend on the units of the windows.
    """

    def __init__(self, alpha: float = 1e-3):
        self.alpha = alpha

    def fit(self, X, y):
        X, y = validate_data(self, X, y, y_numeric=False)
        check_classification_targets(y)
        self.classes_, column_class = np.unique(y, return_inverse=True)
        A = X.T  # (d, n_atoms)
        gram = A.T @ A
        self.lambda_ = float(self.alpha * max(np.trace(gram) / max(A.shape[1], 1), np.finfo(float).tiny))
        self.projection_ = np.linalg.solve(gram + self.lambda_ * np.eye(gram.shape[0]), A.T)  # P, (n_atoms, d)
        eye = np.eye(A.shape[0])
        self.residual_operators_ = np.stack(
            [eye - A[:, column_class == i] @ self.projection_[column_class == i] for i in range(len(self.classes_))]
        )  # E_i, (C, d, d)
        return self

    def decision_function(self, X) -> np.ndarray:
        """Class residuals ``r_i(y)`` ``(n_windows, n_classes)``; smaller is better."""
        check_is_fitted(self, "residual_operators_")
        X = validate_data(self, X, reset=False)
        return np.linalg.norm(np.einsum("cij,nj->nci", self.residual_operators_, X), axis=2)

    def predict(self, X) -> np.ndarray:
        check_is_fitted(self, "residual_operators_")
        return self.classes_[np.argmin(self.decision_function(X), axis=1)]
