"""Kernel collaborative representation classification (kernel CRC_RLS): CRC_RLS in the feature space of a
Gaussian kernel, so that a window is represented by atoms that lie near it, not by scaled copies of distant ones.

CRC_RLS codes a window linearly, so ``c a`` is represented by ``a`` for any factor ``c``: a soft stop is explained
by a scaled hard stop. In the feature space ``phi`` of ``k(u, v) = exp(-gamma ||u - v||^2)`` a scaled atom is no
longer a scaled feature vector. The same regularised least squares (Zhang, Yang, Feng, ICCV 2011; in kernel form:
Li, Du, Xiong, "Kernel collaborative representation with Tikhonov regularization for hyperspectral image
classification", IEEE GRSL 12(1), 2015, here with the plain ridge) are solved on explicit Nystroem features
(Williams and Seeger, NIPS 2000) of ``m`` landmarks ``L``:

    phi(y) = K_LL^{-1/2} k(L, y)                                   (m values; K_LL = k(L, L))
    CRC_RLS (:class:`~spotfree.classify.crc.CRCClassifier`) on the atoms phi(a_j), applied to phi(y)

``phi(y)`` is the projection of the window's feature vector on the landmarks' span; the part outside it, of squared
norm ``1 - ||phi(y)||^2`` (``k(y, y) = 1``), is left unexplained by every class and is added to each residual:
``r_i = sqrt(||phi(y) - Phi_i x_i||^2 + 1 - ||phi(y)||^2)``. With every atom a landmark these are the residuals of exact
kernel CRC_RLS. A window far from every landmark keeps ``r_i`` near 1, so the rejection ratio ``min_i r_i / 1``
rejects it. Fewer landmarks make a window cost ``m d`` for the kernel row and ``2 C m^2`` for the residuals, instead of
the ``2 C d^2`` of CRC_RLS on windows of ``d`` values: with ``m`` near ``d`` about the same. Landmarks are taken per
class, in proportion to its atoms (at least one), by farthest-point sampling of its atoms (all of them when it has
no more; deterministic, so every process labels alike);
``gamma = gamma_scale / median_{j<l} ||a_j - a_l||^2``, so the kernel does not depend on the windows' units.

Compared with CRC_RLS, a normal stop no longer matches a scaled-down sudden stop. The number of landmarks is a
model's (``parameters["landmarks"]``, set by training; 32 for models without it).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.distance import pdist
from sklearn.utils.validation import check_is_fitted

from spotfree.classify.base import UNKNOWN, ResidualClassifier
from spotfree.classify.crc import CRCClassifier
from spotfree.classify.kernels import crc_window, kernel_features, kernel_residual
from spotfree.errors import InputError


class KernelCRCClassifier(ResidualClassifier):
    """Kernel CRC_RLS with a Gaussian kernel on Nystroem features (module docstring).

    Parameters
    ----------
    gamma_scale : float
        Kernel width relative to the atoms' spread: ``gamma = gamma_scale / median pairwise ||a_j - a_l||^2``.
    landmarks : int or None
        Number of Nystroem landmarks ``m``; ``None`` (or at least the number of atoms): every atom, exact kernel
        CRC_RLS.
    alpha : float
        Ridge weight of the CRC_RLS on the features, relative to their mean squared norm (as in CRC_RLS).
    reject : float or None
        Rejection threshold on ``min_i r_i`` (in [0, 1]: the feature vector's norm is 1).
    """

    def __init__(self, gamma_scale: float = 0.25, landmarks: int | None = 32, alpha: float = 1e-3,
                 reject: float | None = None):
        super().__init__(reject=reject)
        self.gamma_scale = gamma_scale
        self.landmarks = landmarks
        self.alpha = alpha

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if not (np.isfinite(self.gamma_scale) and self.gamma_scale > 0):
            raise InputError(f"gamma_scale={self.gamma_scale!r}: give a kernel width > 0 (e.g. 0.25)")
        if self.landmarks is not None and not (isinstance(self.landmarks, (int, np.integer))
                                               and not isinstance(self.landmarks, bool) and self.landmarks >= 1):
            raise InputError(f"landmarks={self.landmarks!r}: give a number of landmarks >= 1, or None for every atom")
        atoms = A.T
        spread = float(np.median(pdist(atoms, "sqeuclidean"))) if len(atoms) > 1 else 0.0
        self.gamma_ = self.gamma_scale / (spread if spread > 0 else 1.0)
        self.landmarks_ = self._place_landmarks(atoms, atom_class)
        values, vectors = np.linalg.eigh(_kernel(self.landmarks_, self.landmarks_, self.gamma_))
        keep = values > values.max() * 1e-10
        self.normalisation_ = np.ascontiguousarray((vectors[:, keep] / np.sqrt(values[keep])).T)  # K_LL^-1/2 rows
        self.crc_ = CRCClassifier(alpha=self.alpha, reject=self.reject).fit(self._features(atoms), atom_class)

    def _place_landmarks(self, atoms: np.ndarray, atom_class: np.ndarray) -> np.ndarray:
        if self.landmarks is None or self.landmarks >= len(atoms):
            return np.ascontiguousarray(atoms)
        counts = np.bincount(atom_class)
        share = np.maximum(1, np.round(self.landmarks * counts / counts.sum()).astype(int))
        return np.ascontiguousarray(np.vstack([_farthest_points(atoms[atom_class == i], m)
                                               for i, m in enumerate(share)]))

    def _features(self, X: np.ndarray) -> np.ndarray:
        """``phi`` of every row of ``X``, ``(n, m)``."""
        return _kernel(X, self.landmarks_, self.gamma_) @ self.normalisation_.T

    def _parts(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residuals of CRC_RLS on the features ``(n, C)`` and the squared part of ``phi(y)`` outside the
        landmarks' span ``(n,)``: ``1 - ||phi||^2``, since ``||phi(y)||^2 = k(y, y) = 1`` in all."""
        phi = self._features(X)
        return self.crc_._residuals(phi), np.maximum(1.0 - np.einsum("ij,ij->i", phi, phi), 0.0)

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        inside, outside = self._parts(X)
        return np.sqrt(inside ** 2 + outside[:, None])

    def _ranked(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The residuals inside the landmarks' span rank the classes (the part outside is the same for every class),
        so that a window far from every landmark, whose ``r_i`` all round to 1, is ranked as :meth:`predict_one` and
        the streaming step rank it; ``min_i r_i`` for the rejection."""
        inside, outside = self._parts(X)
        return inside, np.sqrt(inside.min(axis=1) ** 2 + outside)

    def _window_norms(self, X: np.ndarray) -> np.ndarray:
        return np.ones(len(X))

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)`` (two compiled calls); for streaming."""
        try:
            landmarks, crc = self.landmarks_, self.crc_
        except AttributeError:
            check_is_fitted(self, "crc_")
            raise
        phi = np.empty(len(self.normalisation_))
        norm2 = kernel_features(landmarks, self.normalisation_, self.gamma_, self._one_window(y, landmarks.shape[1]),
                                phi)
        if norm2 < 0:
            raise self._not_finite()
        best, ratio = crc_window(crc._operator, len(self.classes_), phi)
        if self.reject is not None and kernel_residual(ratio, norm2) > self.reject:
            return UNKNOWN
        return self.classes_[best]


def _kernel(X: np.ndarray, landmarks: np.ndarray, gamma: float) -> np.ndarray:
    """``exp(-gamma ||x - l||^2)`` for every row ``x`` of ``X`` and row ``l`` of ``landmarks``."""
    d2 = (np.einsum("ij,ij->i", X, X)[:, None] + np.einsum("ij,ij->i", landmarks, landmarks)[None, :]
          - 2.0 * (X @ landmarks.T))
    return np.exp(-gamma * np.maximum(d2, 0.0))


def _farthest_points(points: np.ndarray, m: int) -> np.ndarray:
    """``m`` of ``points`` (all when there are no more) spread over them: the one nearest their mean, then each time
    the one farthest from those chosen (deterministic: no random start, ties to the first)."""
    if len(points) <= m:
        return points
    chosen = [int(np.argmin(np.linalg.norm(points - points.mean(axis=0), axis=1)))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    while len(chosen) < m:
        chosen.append(int(np.argmax(distance)))
        distance = np.minimum(distance, np.linalg.norm(points - points[chosen[-1]], axis=1))
    return points[chosen]
