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
rejects it.

Computation: the normalisation is folded into CRC_RLS's residual operators ``E_i`` ``(f, f)`` (``f <= m`` features:
the eigenvalues of ``K_LL`` above ``1e-10`` of the largest) and each class's is rotated,

    F_i = U_i^T E_i K_LL^{-1/2}                                   ((f, m); ||F_i k(L, y)|| = ||phi(y) - Phi_i x_i||)

``U_i`` orthogonal: the eigenvectors of ``R_i R_i^T``, largest first, ``R_i = E_i phi(A)`` the class-``i`` residuals of
the atoms, so that the first rows of ``F_i`` carry most of a residual. The first ``h`` (:data:`HEAD`) rows of every
class bound its squared residual from below; the class of the least bound is completed, then only the classes whose
bound does not exceed its residual (a sum of squares only grows, so the argmin is exact).

In batch a chunk of windows takes matrix products (BLAS): the kernel rows' exponents ``-gamma ||y - l||^2`` from ``[y,
||y||^2, 1]`` times ``[2 gamma l, -gamma, -gamma ||l||^2]``; those rows times the head rows of every class, with the
rows of ``K_LL^{-1/2}`` appended when the part outside is needed (rejection); then, per class, the windows that need its
remaining rows times those rows (``decision_function`` completes every class). Chunks go to threads as in CRC_RLS. The
exponential is compiled (:func:`~spotfree.kernels.exp_nonpositive`, vectorised; numpy's calls the C library once per
value on processors without AVX-512). A window costs ``m (d + 2)`` multiply-adds for the kernel row, ``C h m`` for the
bounds, ``(f - h) m`` per completed class and ``f m`` for the part outside, against ``C f m`` without the bounds.
Streaming (:meth:`KernelCRCClassifier.predict_one`, the ring step) does the same in one compiled call
(:func:`~spotfree.kernels.kernel_window`), abandoning a class as soon as its sum exceeds the best. Float32 is not
offered: ``K_LL^{-1/2}`` amplifies rounding by its largest singular value, large when landmarks lie close together
(``K_LL`` near singular), enough to change labels.

Landmarks are taken per class, in proportion to its atoms (at least one): the class's atoms fall into as many k-means
groups, and each group gives its atom nearest its mean (all atoms when the class has no more). The Nystroem error is
bounded by how far the points lie from their nearest landmark, which k-means makes small (Zhang, Tsang and Kwok,
"Improved Nystroem low-rank approximation and error analysis", ICML 2008); landmarks spread as far apart as possible
would go to the outliers instead. The k-means runs on one thread from a fixed seed, so every process that fits the
same dictionary places the same landmarks. ``gamma = gamma_scale / median_{j<l} ||a_j - a_l||^2``, so the kernel does
not depend on the windows' units; over at most :data:`SPREAD_ATOMS` atoms, evenly spread over the dictionary's order
when it holds more, so that the pairs' memory stays bounded.

Compared with CRC_RLS, a normal stop no longer matches a scaled-down sudden stop. The number of landmarks is a
model's (``parameters["landmarks"]``, set by training; 32 for models without it).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy.spatial.distance import pdist
from sklearn.cluster import KMeans
from sklearn.exceptions import ConvergenceWarning
from sklearn.utils.validation import check_is_fitted
from threadpoolctl import threadpool_limits

from spotfree.classify.base import UNKNOWN, ResidualClassifier
from spotfree.classify.crc import CRCClassifier, check_n_jobs, in_chunks
from spotfree.kernels import exp_nonpositive, kernel_window
from spotfree.errors import InputError

HEAD = 8
"""Rows per class of the rotated operators that bound every class's residual (module docstring)."""
SPREAD_ATOMS = 8192
"""Most atoms whose pairwise distances give the kernel's width (module docstring): their ``n (n - 1) / 2`` squared
distances take 268 MB at this size."""


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
    n_jobs : int
        Threads of the batch path (``-1``: one per core).

    Attributes
    ----------
    landmarks_ : ndarray (m, d)
        The Nystroem landmarks.
    gamma_ : float
        Kernel width ``gamma``.
    normalisation_ : ndarray (f, m)
        The rows of ``K_LL^{-1/2}`` of the eigenvalues kept.
    operator_ : ndarray (C f, m)
        The folded, rotated operators ``F_i`` stacked by class; their first ``head_`` rows bound the residuals.
    live_ : ndarray
        ``landmarks_`` as columns ``(d, m)``, ``operator_`` and ``normalisation_``, flat, as the compiled live call
        reads them (:func:`~spotfree.kernels.kernel_window`).
    """

    def __init__(self, gamma_scale: float = 0.25, landmarks: int | None = 32, alpha: float = 1e-3,
                 reject: float | None = None, n_jobs: int = -1):
        super().__init__(reject=reject)
        self.gamma_scale = gamma_scale
        self.landmarks = landmarks
        self.alpha = alpha
        self.n_jobs = n_jobs

    def _fit_dictionary(self, A: np.ndarray, atom_class: np.ndarray) -> None:
        if not (np.isfinite(self.gamma_scale) and self.gamma_scale > 0):
            raise InputError(f"gamma_scale={self.gamma_scale!r}: give a kernel width > 0 (e.g. 0.25)")
        if self.landmarks is not None and not (isinstance(self.landmarks, (int, np.integer))
                                               and not isinstance(self.landmarks, bool) and self.landmarks >= 1):
            raise InputError(f"landmarks={self.landmarks!r}: give a number of landmarks >= 1, or None for every atom")
        check_n_jobs(self.n_jobs)
        atoms = A.T.astype(float)
        sample = (atoms if len(atoms) <= SPREAD_ATOMS else
                  atoms[np.linspace(0, len(atoms) - 1, SPREAD_ATOMS).round().astype(int)])
        spread = float(np.median(pdist(sample, "sqeuclidean"))) if len(sample) > 1 else 0.0
        self.gamma_ = self.gamma_scale / (spread if spread > 0 else 1.0)
        self.landmarks_ = self._place_landmarks(atoms, atom_class)
        values, vectors = np.linalg.eigh(_kernel(self.landmarks_, self.landmarks_, self.gamma_))
        keep = values > values.max() * 1e-10
        self.normalisation_ = np.ascontiguousarray((vectors[:, keep] / np.sqrt(values[keep])).T)  # K_LL^-1/2 rows
        phi = self._features(atoms)
        self.crc_ = CRCClassifier(alpha=self.alpha, reject=self.reject).fit(phi, atom_class)
        rotated = np.stack([_rotation(e @ phi.T).T @ e @ self.normalisation_ for e in self.crc_.residual_operators_])
        n_classes, f, m = rotated.shape
        self.head_ = min(HEAD, f)
        self.operator_ = np.ascontiguousarray(rotated.reshape(-1, m))  # F_i stacked, (C f, m)
        heads = rotated[:, :self.head_].reshape(-1, m)
        self._heads_t = np.ascontiguousarray(np.vstack([heads, self.normalisation_]).T)  # (m, C h + f)
        self._tails_t = np.ascontiguousarray(rotated[:, self.head_:].reshape(-1, m).T)  # (m, C (f - h))
        self.live_ = np.concatenate([self.landmarks_.T.ravel(), self.operator_.ravel(), self.normalisation_.ravel()])
        self._live_call = (self.live_, self.landmarks_.shape[1], m, f, n_classes, self.head_, self.gamma_)

    def _place_landmarks(self, atoms: np.ndarray, atom_class: np.ndarray) -> np.ndarray:
        if self.landmarks is None or self.landmarks >= len(atoms):
            return np.ascontiguousarray(atoms)
        counts = np.bincount(atom_class)
        share = np.maximum(1, np.round(self.landmarks * counts / counts.sum()).astype(int))
        return np.ascontiguousarray(np.vstack([_central_points(atoms[atom_class == i], m)
                                               for i, m in enumerate(share)]))

    def _features(self, X: np.ndarray) -> np.ndarray:
        """``phi`` of every row of ``X``, ``(n, m)``."""
        return _kernel(X, self.landmarks_, self.gamma_) @ self.normalisation_.T

    def _squares(self, X: np.ndarray, outside: bool, prune: bool) -> tuple[np.ndarray, np.ndarray | None]:
        """The squared class residuals inside the landmarks' span ``||phi(y) - Phi_i x_i||^2`` ``(n, C)`` (when
        ``prune``, inf for the classes whose bound shows they are not the least) and, when ``outside``, the squared
        part of ``phi(y)`` outside that span ``(n,)``: ``1 - ||phi||^2``, since ``||phi(y)||^2 = k(y, y) = 1`` in all
        (else None). Matrix products per chunk (module docstring)."""
        n_classes, f, h = len(self.classes_), len(self.normalisation_), self.head_
        heads = self._heads_t[:, :n_classes * h + outside * f]
        inside = np.empty((len(X), n_classes))
        rest = np.empty(len(X)) if outside else None

        def squares(rows: slice) -> None:
            k = _kernel(X[rows], self.landmarks_, self.gamma_)
            z = k @ heads
            bounds = _block_squares(z[:, :n_classes * h], h)
            if outside:
                np.maximum(1.0 - _block_squares(z[:, n_classes * h:], f)[:, 0], 0.0, out=rest[rows])
            if not prune:
                inside[rows] = bounds + _block_squares(k @ self._tails_t, f - h)
                return
            full = np.full_like(bounds, np.inf)
            self._complete(k, bounds, full, np.argmin(bounds, axis=1)[:, None] == np.arange(n_classes))
            self._complete(k, bounds, full, np.isinf(full) & (bounds <= full.min(axis=1)[:, None]))
            inside[rows] = full

        in_chunks(squares, len(X), heads.itemsize * (len(self.landmarks_) + heads.shape[1]), self.n_jobs)
        return inside, rest

    def _complete(self, k: np.ndarray, bounds: np.ndarray, full: np.ndarray, chosen: np.ndarray) -> None:
        """``full[j, i]`` = bound plus the squares of the remaining rows of class ``i`` for the kernel rows ``k[j]``
        where ``chosen[j, i]``: one matrix product per class."""
        width = len(self.normalisation_) - self.head_
        for i in range(len(self.classes_)):
            rows = np.flatnonzero(chosen[:, i])
            if len(rows):
                tail = k[rows] @ self._tails_t[:, i * width:(i + 1) * width]
                full[rows, i] = bounds[rows, i] + np.einsum("ij,ij->i", tail, tail)

    def _residuals(self, X: np.ndarray) -> np.ndarray:
        inside, outside = self._squares(X, True, False)
        return np.sqrt(inside + outside[:, None])

    def _ranked(self, X: np.ndarray, best: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """The squared residuals inside the landmarks' span rank the classes (the part outside is the same for every
        class; inf where pruned), so that a window far from every landmark, whose ``r_i`` all round to 1, is ranked
        as :meth:`predict_one` and the streaming step rank it; ``min_i r_i`` for the rejection when ``best``."""
        inside, outside = self._squares(X, best, True)
        return inside, np.sqrt(inside.min(axis=1) + outside) if best else None

    def _window_norms(self, X: np.ndarray) -> np.ndarray:
        return np.ones(len(X))

    def predict_one(self, y):
        """Class of one window ``y`` ``(d,)`` (one compiled call); for streaming."""
        try:
            call = self._live_call
        except AttributeError:
            check_is_fitted(self, "live_")
            raise
        best, residual = kernel_window(*call, self._one_window(y, call[1]), self.reject is not None)
        if best < 0:
            raise self._not_finite()
        if self.reject is not None and residual > self.reject:
            return UNKNOWN
        return self.classes_[best]


def _kernel(X: np.ndarray, landmarks: np.ndarray, gamma: float) -> np.ndarray:
    """``exp(-gamma ||x - l||^2)`` for every row ``x`` of ``X`` and row ``l`` of ``landmarks``: the exponents of all
    pairs from one matrix product, ``[x, ||x||^2, 1] . [2 gamma l, -gamma, -gamma ||l||^2]``, then exp in place
    (:func:`~spotfree.kernels.exp_nonpositive`, which keeps the exponents <= 0, as the live path does)."""
    left = np.empty((len(X), X.shape[1] + 2))
    left[:, :-2] = X
    left[:, -2] = np.einsum("ij,ij->i", X, X)
    left[:, -1] = 1.0
    right = np.empty((len(landmarks), landmarks.shape[1] + 2))
    np.multiply(landmarks, 2.0 * gamma, out=right[:, :-2])
    right[:, -2] = -gamma
    right[:, -1] = -gamma * np.einsum("ij,ij->i", landmarks, landmarks)
    k = left @ right.T
    exp_nonpositive(k.reshape(-1))
    return k


def _rotation(images: np.ndarray) -> np.ndarray:
    """The orthogonal ``U`` ``(f, f)`` whose columns are the eigenvectors of ``images images^T`` (``images``
    ``(f, n)``), largest eigenvalue first: the directions that carry most of the images' squared norm."""
    return np.linalg.eigh(images @ images.T)[1][:, ::-1]


def _block_squares(z: np.ndarray, width: int) -> np.ndarray:
    """The squared norm of every ``width``-wide block of every row of ``z`` ``(n, blocks width)``: ``(n, blocks)``;
    ``(n, 1)`` zeros for blocks of no width."""
    if width == 0:
        return np.zeros((len(z), 1))
    blocks = np.ascontiguousarray(z).reshape(-1, width)
    return np.einsum("ij,ij->i", blocks, blocks).reshape(len(z), -1)


def _central_points(points: np.ndarray, m: int) -> np.ndarray:
    """``m`` of ``points`` that represent them: the member nearest the mean of each of
    ``m`` k-means groups (k-means++ start from a fixed seed, one thread: the same points give the same choice); the
    distinct points when there are no more than ``m``. The groups and distances are computed on the points rounded
    to single precision, so that points that differ in their last bits (computed on another processor) give the same
    choice; the points returned are the float64 ones."""
    distinct = np.unique(points, axis=0)
    if len(distinct) <= m:
        return distinct
    single = points.astype(np.float32)
    with threadpool_limits(limits=1), warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)  # fewer groups than m: one landmark a group, as meant
        groups = KMeans(n_clusters=m, n_init=1, random_state=0).fit(single)
    distance = np.linalg.norm(single - groups.cluster_centers_[groups.labels_], axis=1)
    order = np.lexsort((distance, groups.labels_))  # by group, nearest its mean first
    first = order[np.r_[True, np.diff(groups.labels_[order]) != 0]]
    return points[np.sort(first)]
