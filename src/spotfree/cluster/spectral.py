"""Normalized cuts (Shi & Malik 2000) on a precomputed affinity, and the eigengap estimate of the cluster count.

For a symmetric non-negative affinity ``W`` (``n x n``) with degrees ``d_i = sum_j W_ij``, the relaxed normalized
cut of ``k`` groups is spanned by the ``k`` leading eigenvectors ``u`` of ``M = D^{-1/2} W D^{-1/2}`` (equivalently
the ``k`` smallest of the normalized Laplacian ``L = I - M``); the generalized eigenvectors ``D^{-1/2} u`` embed the
samples in ``R^k`` and k-means (``n_init`` restarts from a seeded generator) assigns the labels. This is
scikit-learn's ``SpectralClustering(affinity='precomputed')`` with its k-means labelling; the eigenvectors are
computed here without shift-invert, whose dense ``O(n^3)`` factorization dominates for 10,000 windows:
a dense symmetric eigensolver below ``DENSE_LIMIT`` samples, Lanczos (ARPACK to ``EIGEN_TOL``, start vector from
the seed) above, with single-threaded BLAS (on a loaded 2-core machine a threaded matrix-vector product was 5x
slower). A sample with no affinity (``d_i = 0``) gets a zero row in ``M``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse
from scipy.sparse.linalg import LinearOperator, eigsh
from sklearn.cluster import KMeans
from threadpoolctl import threadpool_limits

from spotfree.errors import InputError

DENSE_LIMIT = 500
EIGEN_TOL = 1e-6


def normalized_cuts(W, n_clusters: int, random_state=None, n_init: int = 10) -> np.ndarray:
    """Labels ``0..n_clusters-1`` of the samples of affinity ``W`` (dense or scipy sparse, symmetric, >= 0)."""
    n = _check_affinity(W)
    if not 1 <= n_clusters <= n:
        raise InputError(f"affinity: n_clusters={n_clusters} must be between 1 and the number of samples {n}")
    if n_clusters == 1:
        return np.zeros(n, dtype=int)
    _, vectors, inv_sqrt_degree = _leading_eigenpairs(W, n_clusters, random_state)
    embedding = vectors * inv_sqrt_degree[:, None]
    kmeans = KMeans(n_clusters, n_init=n_init, random_state=_seed(random_state))
    return kmeans.fit_predict(embedding)


def laplacian_spectrum(W, k: int, random_state=None) -> np.ndarray:
    """The ``k`` smallest eigenvalues of the normalized Laplacian ``I - D^{-1/2} W D^{-1/2}``, ascending."""
    n = _check_affinity(W)
    k = min(k, n)
    values, _, _ = _leading_eigenpairs(W, k, random_state)
    return np.sort(1.0 - values)


def estimate_n_clusters(W, max_clusters: int = 10, random_state=None) -> int:
    """Eigengap estimate: the ``k <= max_clusters`` after which the normalized Laplacian's spectrum jumps most.

    With ``0 = l_1 <= l_2 <= ...`` the smallest eigenvalues, returns ``argmax_k (l_{k+1} - l_k)``: ``k`` nearly
    disconnected groups give ``k`` eigenvalues near 0 and a gap after them (von Luxburg 2007, sec. 8.3).
    """
    n = _check_affinity(W)
    if max_clusters < 1:
        raise InputError(f"affinity: max_clusters must be >= 1, got {max_clusters}")
    if n <= 2:
        return n
    spectrum = laplacian_spectrum(W, min(max_clusters + 1, n), random_state)
    return int(np.argmax(np.diff(spectrum))) + 1


def _leading_eigenpairs(W, k: int, random_state):
    """Largest ``k`` eigenpairs of ``M = D^{-1/2} W D^{-1/2}`` and the vector ``D^{-1/2}``."""
    n = W.shape[0]
    degree = np.asarray(W.sum(axis=1), dtype=float).ravel()
    inv_sqrt = np.divide(1.0, np.sqrt(degree), out=np.zeros(n), where=degree > 0)
    if n <= DENSE_LIMIT or k >= n - 1:
        dense = W.toarray() if scipy.sparse.issparse(W) else np.asarray(W, dtype=float)
        M = inv_sqrt[:, None] * dense * inv_sqrt[None, :]
        with threadpool_limits(1, user_api="blas"):
            values, vectors = scipy.linalg.eigh(M, subset_by_index=[n - k, n - 1])
        return values, vectors, inv_sqrt
    real = W.dtype if W.dtype in (np.float32, np.float64) else np.dtype(np.float64)
    scale = inv_sqrt.astype(real)

    def matvec(v):
        return scale * (W @ (scale * v.ravel().astype(real)))

    def matmat(V):
        return scale[:, None] * (W @ (scale[:, None] * V.astype(real)))

    operator = LinearOperator((n, n), matvec=matvec, matmat=matmat, dtype=float)
    v0 = np.random.default_rng(_seed(random_state)).uniform(-1.0, 1.0, n)
    with threadpool_limits(1, user_api="blas"):
        values, vectors = eigsh(operator, k=k, which="LA", v0=v0, tol=EIGEN_TOL)
    return values, vectors, inv_sqrt


def _check_affinity(W) -> int:
    if W.ndim != 2 or W.shape[0] != W.shape[1]:
        raise InputError(f"affinity: must be a square matrix, got shape {W.shape}")
    values = W.data if scipy.sparse.issparse(W) else np.asarray(W)
    if not np.all(np.isfinite(values)) or np.any(values < 0):
        raise InputError("affinity: entries must be finite and non-negative; build it as |Z| + |Z^T|")
    return W.shape[0]


def _seed(random_state):
    """An integer seed for k-means and the Lanczos start vector (``None`` draws one)."""
    if isinstance(random_state, np.random.RandomState):
        return random_state.randint(np.iinfo(np.int32).max)
    if isinstance(random_state, np.random.Generator):
        return int(random_state.integers(np.iinfo(np.int32).max))
    return random_state
