"""Shared base of the residual classifiers (CRC_RLS, SRC, B_SRC).

With the dictionary ``A = [A_1, ..., A_C]`` (``d`` rows, one atom per column, ``A_i`` the atoms of class ``i``), a
classifier codes a window ``y`` (``d`` values) as coefficients ``x`` and ranks the classes by their residuals

    r_i(y) = || y - A_i x_i ||_2,   label(y) = argmin_i r_i(y),

``x_i`` being the coefficients of class ``i``. The coding is what tells the methods apart.

Rejection: a window that no class explains is labelled :data:`UNKNOWN`. Its score is the best class's share of
the window left unexplained,

    rho(y) = min_i r_i(y) / ||y||_2   (0: explained exactly, 1: explained no better than by zero),

and the window is rejected when ``rho(y) > reject``. This ratio measures distance to the class subspaces; the
alternative ``min_i r_i / second-smallest r_i`` measures ambiguity between known classes instead
(``benchmarks/classifier_timing.py`` compares the two).

Estimator convention (scikit-learn): ``fit(X, y)`` takes the atoms as rows, ``X`` of shape ``(n_atoms, d)``;
``predict`` and ``decision_function`` take windows as rows. ``decision_function`` returns the class residuals
``(n_windows, n_classes)`` (smaller is better), as the paper ranks classes, not scikit-learn's larger-is-better
scores.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.utils.multiclass import check_classification_targets
from sklearn.utils.validation import check_is_fitted, validate_data

from spotfree.errors import InputError

UNKNOWN = "unknown"
"""Label of a window that no class explains (rejection on)."""


class ResidualClassifier(ClassifierMixin, BaseEstimator):
    """Base of the residual classifiers; a subclass implements ``_fit_dictionary`` and ``_residuals``.

    Parameters
    ----------
    reject : float or None
        Rejection threshold on ``min_i r_i(y) / ||y||`` (module docstring); ``None`` (default) never rejects.
    """

    def __init__(self, reject: float | None = None):
        self.reject = reject

    def fit(self, X, y):
        """Learn the dictionary from atoms ``X`` ``(n_atoms, d)`` (rows) and their class labels ``y``."""
        X, y = validate_data(self, X, y, y_numeric=False)
        check_classification_targets(y)
        if self.reject is not None and not (np.isfinite(self.reject) and self.reject > 0):
            raise InputError(f"reject={self.reject!r}: give a residual ratio > 0 (e.g. 0.5) or None to turn it off")
        self.classes_, self.atom_class_ = np.unique(y, return_inverse=True)
        self._fit_dictionary(np.ascontiguousarray(X.T), self.atom_class_)
        return self

    def decision_function(self, X) -> np.ndarray:
        """Class residuals ``r_i(y)`` ``(n_windows, n_classes)``, in the windows' units; smaller is better."""
        return self._residuals(self._check_windows(X))

    def predict(self, X) -> np.ndarray:
        """Class of each window (row of ``X``), :data:`UNKNOWN` where rejected."""
        X = self._check_windows(X)
        ranking, best = self._ranked(X, self.reject is not None)
        labels = self.classes_[np.argmin(ranking, axis=1)]
        if self.reject is None:
            return labels
        if labels.dtype.kind not in "US":
            labels = labels.astype(object)
        return np.where(_ratio(best, self._window_norms(X)) > self.reject, UNKNOWN, labels)

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)``, for streaming."""
        return self.predict(np.asarray(y)[np.newaxis, :])[0]

    def rejection_score(self, X) -> np.ndarray:
        """``min_i r_i(y) / ||y||`` per window (``inf`` for an all-zero window)."""
        X = self._check_windows(X)
        return _ratio(self._residuals(X).min(axis=1), self._window_norms(X))

    def _check_windows(self, X) -> np.ndarray:
        check_is_fitted(self, "classes_")
        try:
            return validate_data(self, X, reset=False)
        except ValueError as err:
            raise InputError(
                f"{type(self).__name__} input: {err}. Give finite windows as rows of {self.n_features_in_} "
                "values (window length times channels, as the dictionary was trained)"
            ) from err

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        """Precompute what classification needs from the dictionary ``A`` ``(d, n_atoms)``."""
        raise NotImplementedError

    def _ranked(self, X: np.ndarray, best: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """What :meth:`predict` ranks the classes by ``(n, C)`` (argmin wins) and, when ``best`` (rejection on),
        ``min_i r_i`` ``(n,)``: by default the residuals themselves."""
        residuals = self._residuals(X)
        return residuals, residuals.min(axis=1) if best else None

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        """Class residuals of validated windows ``X`` ``(n, d)``."""
        raise NotImplementedError

    def _one_window(self, y, d: int) -> np.ndarray:
        """``y`` as one float window of ``d`` values for ``predict_one``, or a clear error."""
        y = np.asarray(y, dtype=float)
        if y.shape != (d,):
            raise InputError(f"{type(self).__name__}.predict_one takes one window of shape ({d},) (window length "
                             f"times channels, as the dictionary was trained), got shape {y.shape}")
        return y

    def _not_finite(self) -> InputError:
        """The error of ``predict_one`` for a window holding NaN or infinity."""
        return InputError(f"{type(self).__name__}.predict_one: the window holds NaN or infinity; give finite values "
                          "(cut windows inside gap-free stretches)")

    def _window_norms(self, X: np.ndarray) -> np.ndarray:
        """``||y||`` of each window in the space the residuals are measured in (the rejection ratio's divisor)."""
        return np.linalg.norm(X, axis=1)


def unit_atoms(A: np.ndarray) -> np.ndarray:
    """The atoms (columns of ``A`` ``(d, n_atoms)``) scaled to unit l2 norm, as rows ``(n_atoms, d)``; an all-zero
    atom stays zero (it can represent nothing and is never chosen)."""
    norms = np.linalg.norm(A, axis=0)
    return np.ascontiguousarray((A / np.where(norms > 0, norms, 1.0)).T)


def class_residuals(X: np.ndarray, code: np.ndarray, atoms: np.ndarray, atom_class: np.ndarray,
                    n_classes: int) -> np.ndarray:
    """``r_i = ||y - sum_{j in class i} x_j a_j||`` for windows ``X`` ``(n, d)``, codes ``(n, n_atoms)`` and
    atoms as rows ``(n_atoms, d)``; ``(n, n_classes)``."""
    return np.column_stack([
        np.linalg.norm(X - code[:, atom_class == i] @ atoms[atom_class == i], axis=1) for i in range(n_classes)
    ])


def _ratio(r_min: np.ndarray, norms: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(norms > 0, r_min / np.where(norms > 0, norms, 1.0), np.inf)
