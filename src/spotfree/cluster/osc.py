"""Ordered Subspace Clustering (Tierney, Gao & Guo, CVPR 2014; eq. 9 of the paper) solved by ADMM.

**Problem.** The paper's data matrix ``X_p`` is ``d x n``: one sliding window (a block-Hankel column, ``d`` =
window length x channels) per column. OSC finds the self-representation ``X_p ~ X_p Z``:

    min_Z  1/2 ||X_p - X_p Z||_F^2 + l1 ||Z||_1 + l2 ||Z R||_{1,2}

with ``||M||_1`` the sum of absolute entries, ``||M||_{1,2}`` the sum of the l2 norms of the columns, and ``R``
the ``n x n`` lower bidiagonal matrix of eq. 10 (``-1`` on the diagonal, ``+1`` below it), so that

    (Z R)[:, j] = Z[:, j+1] - Z[:, j]   for j < n-1,        (Z R)[:, n-1] = -Z[:, n-1].

The last column is kept as eq. 10 writes it: it adds ``l2 ||Z[:, n-1]||_2`` (Tierney et al. use the
``n x (n-1)`` R without it). With ``l2 = 0`` the problem is Sparse Subspace Clustering (Elhamifar & Vidal 2013) in
its noisy form. ``diag(Z) = 0`` may be imposed (``zero_diagonal``): SSC needs it to rule out the trivial ``Z = I``;
the OSC papers drop it because the ordering term already penalises an isolated self-representation. It is on by
default here: with block-Hankel windows, a window then has to be explained by its neighbours in time, not by itself.

**Layout.** The code follows scikit-learn: ``X`` is ``n x d`` (one window per row, ``X = X_p^T``) and works with
``C = Z^T`` (row ``j`` holds the coefficients of sample ``j``). The problem reads

    min_C  1/2 ||X - C X||_F^2 + l1 ||C||_1 + l2 sum_j ||(D C)[j]||_2,   D = R^T,
    (D C)[j] = C[j+1] - C[j],   (D C)[n-1] = -C[n-1]        (forward difference of rows).

Neither ``R`` nor any Kronecker product is ever built: ``D`` and ``D^T`` are row differences.

**ADMM.** Split ``C = A`` (data term), ``C = B`` (l1 term) and ``D C = U`` (ordering term), scaled duals
``W1, W2, W3``, one penalty ``rho``. With ``T = 2 I + D^T D`` (tridiagonal: 3, 4, 4, ... on the diagonal, -1 off it):

    C  <- T^{-1} [ (A - W1) + (B - W2) + D^T (U - W3) ]                 banded Cholesky, O(n^2)
    A  <- (C + W1) + (I - C - W1) P diag(s/(s + rho)) P^T               X X^T = P diag(s) P^T, rank <= d
    B  <- soft(C + W2, l1/rho)        (diagonal set to 0 if zero_diagonal)
    U  <- rows of (D C + W3) shrunk by l2/rho in l2 norm                group soft threshold
    W1 += C - A,   W2 += C - B,   W3 += D C - U

The A-step is the Woodbury identity in the thin eigenbasis ``P`` of the Gram matrix (``n x r``, ``r <= d``): it
costs ``O(r n^2)`` instead of the ``O(n^3)`` of ``(X X^T + rho I)^{-1}``. ``W1`` stays of the form ``-N P^T``
(``N`` is ``n x r``), so ``A`` and ``W1`` are never stored, and ``B`` and ``U`` are recovered from ``W2`` and ``W3``
when needed: three ``n x n`` arrays are kept (``C``, ``W2``, ``W3``), in float32 by default.

**Implementation.** An iteration is three compiled passes over the rows (numba, parallel): statistics and the
group shrink factors; the A-, B- and dual updates with the C-step's right-hand side, by row blocks whose products
with ``P`` run on BLAS in a small thread pool; the tridiagonal solve, by column chunks. Each BLAS call is limited to
one thread and OpenMP workers wait passively (``OMP_WAIT_POLICY``, unless set by the user): on a shared 2-core
machine, spinning workers of one pool stall the other.

Residuals (Boyd et al. 2011, sec. 3.3): primal ``r = ||(C - A, C - B, D C - U)||_F``; dual
``s = rho ||A' - A + B' - B + D^T (U' - U)||_F``, which for this splitting equals ``rho ||W1 + W2 + D^T W3||_F``.
Stop when ``r <= tol ||(C, C, D C)||_F`` and ``s <= tol rho ||(W1, W2, W3)||_F``. ``rho`` is adapted by residual
balancing (factor 2 when one relative residual exceeds the other threefold, checked every 5 iterations during the
first ``ADAPT_UNTIL`` iterations, fixed afterwards so that the usual convergence guarantee holds). The recorded
objective is evaluated at ``B``, the iterate with exact zeros (and exact zero diagonal), which is also the returned
coefficient matrix.
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # read when numba starts its OpenMP workers; see above

import numpy as np  # noqa: E402
import numba  # noqa: E402
from numba import njit, prange  # noqa: E402
from sklearn.base import BaseEstimator, ClusterMixin  # noqa: E402
from sklearn.utils.validation import validate_data  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

from spotfree.cluster.spectral import normalized_cuts  # noqa: E402
from spotfree.errors import InputError  # noqa: E402

ADAPT_EVERY = 5
ADAPT_UNTIL = 100
ADAPT_RATIO = 3.0
ADAPT_FACTOR = 2.0
"""Residual balancing: every ADAPT_EVERY iterations before ADAPT_UNTIL, rho is multiplied (divided) by ADAPT_FACTOR
when the relative primal (dual) residual exceeds the other ADAPT_RATIO-fold."""
DEFAULT_RHO_PER_LAMBDA = 30.0
"""Initial rho as a multiple of max(lambda1, lambda2); residual balancing corrects a poor start within the first
iterations."""
BLOCK_ELEMENTS = 1 << 20
"""Entries of one row block of the update pass (rows = BLOCK_ELEMENTS // n): small enough for the cache."""


@dataclass
class OSCResult:
    """Solution of :func:`osc_admm`.

    ``coef`` is the paper's ``Z`` (``n x n``; column ``j`` holds the coefficients that represent sample ``j``).
    ``history`` maps ``objective``, ``primal_residual``, ``dual_residual`` (absolute, as defined in the module
    docstring), ``primal_tolerance``, ``dual_tolerance`` and ``rho`` to one value per iteration.
    """

    coef: np.ndarray
    n_iter: int
    converged: bool
    history: dict[str, np.ndarray]
    rho: float


def row_difference(C: np.ndarray) -> np.ndarray:
    """``D C``: ``C[j+1] - C[j]`` for ``j < n-1`` and ``-C[n-1]`` last (``(Z R)^T`` for ``Z = C^T``)."""
    out = np.empty_like(C)
    np.subtract(C[1:], C[:-1], out=out[:-1])
    np.negative(C[-1], out=out[-1])
    return out


def row_difference_adjoint(V: np.ndarray) -> np.ndarray:
    """``D^T V``: ``-V[0]`` first, ``V[j-1] - V[j]`` for ``j > 0`` (``(V R^T)^T`` in the paper's layout)."""
    out = np.negative(V)
    out[1:] += V[:-1]
    return out


def osc_objective(X: np.ndarray, Z: np.ndarray, lambda1: float, lambda2: float) -> float:
    """Eq. 9 at ``Z`` (paper's layout, ``n x n``) for data ``X`` (``n x d``, one sample per row)."""
    C = np.asarray(Z, dtype=float).T
    X = np.asarray(X, dtype=float)
    data = 0.5 * float(np.sum((X - C @ X) ** 2))
    return data + lambda1 * float(np.abs(C).sum()) + lambda2 * float(np.linalg.norm(row_difference(C), axis=1).sum())


def penalty_scale(X: np.ndarray) -> float:
    """``mu = max_{i != j} |x_i . x_j|`` over the samples (rows) of ``X``, in units of X^2.

    Below ``l1 = mu`` some sample gets a non-zero coefficient; the default penalties are fractions of ``mu``
    (as SSC's ``lambda = alpha / mu``), so that they follow the scale of the data. Computed by row blocks,
    ``O(d n^2)`` time and ``O(n)`` extra memory per block row.
    """
    X = np.asarray(X, dtype=float)
    n = X.shape[0]
    rows = max(1, BLOCK_ELEMENTS // max(n, 1))
    mu = 0.0
    for a in range(0, n, rows):
        G = np.abs(X[a:a + rows] @ X.T)
        G[np.arange(G.shape[0]), np.arange(a, a + G.shape[0])] = 0.0
        mu = max(mu, float(G.max()))
    return mu



def _cholesky_coefficients(n: int):
    """Coefficients of ``T = 2 I + D^T D = L L^T`` (diagonal 3, 4, ..., 4; off-diagonal -1).

    ``L[j, j] = d_j``, ``L[j, j-1] = -1/d_{j-1}``, ``d_0 = sqrt 3``, ``d_j = sqrt(4 - 1/d_{j-1}^2)``. Forward
    substitution ``y_j = rhs_j/d_j + y_{j-1}/(d_j d_{j-1})``, back substitution ``x_j = y_j/d_j + x_{j+1}/d_j^2``.
    Returns ``1/d``, the forward and the backward coefficients (0 where the neighbour row does not exist).
    """
    d = np.empty(n)
    d[0] = np.sqrt(3.0)
    for j in range(1, n):
        d[j] = np.sqrt(4.0 - 1.0 / d[j - 1] ** 2)
    return 1.0 / d, np.r_[0.0, 1.0 / (d[1:] * d[:-1])], np.r_[1.0 / d[:-1] ** 2, 0.0]


FASTMATH = {"reassoc", "contract"}
"""Reassociation lets the compiler vectorise the sums of squares; no NaN/inf assumptions are made."""


@njit(inline="always", fastmath=FASTMATH)
def _soft(x, t):
    return x - min(max(x, -t), t)


@njit(inline="always", fastmath=FASTMATH)
def _b_terms(c, b, b_next):
    """One entry's share of ``||B||_1``, ``||C - B||^2``, ``||C||^2`` and ``||D B||^2`` (one row's part)."""
    return abs(b), (c - b) * (c - b), c * c, (b_next - b) * (b_next - b)


@njit(parallel=True, cache=True, fastmath=FASTMATH)
def _statistics_pass(C, W2, W3, t1, t2, zero_diagonal, ordered, keep, stats):
    """Read-only pass over rows (the one write turns ``W3[i]`` into ``S3[i] = (D C)[i] + W3[i]``).

    Per row ``i``: the group shrink factor ``keep[i] = max(0, 1 - t2/||S3[i]||)`` (``U[i] = keep[i] S3[i]``) and,
    in ``stats[i]``: ``||(D C - U)[i]||^2 + ||(C - B)[i]||^2``, ``||(K C)[i]||^2``, ``||B[i]||_1`` and
    ``||(D B)[i]||_2`` with ``B = soft(C + W2, t1)`` (``soft(x) = x - clip(x, -t1, t1)``). Row sums are in the
    arrays' precision.
    """
    n = C.shape[0]
    zero = C.dtype.type(0.0)
    for i in prange(n):
        nxt = min(i + 1, n - 1)
        has_next = C.dtype.type(0.0 if i + 1 == n else 1.0)  # the last row of D C is -C[n-1]
        c, w2, c_next, w2_next = C[i], W2[i], C[nxt], W2[nxt]
        primal = zero
        kc = zero
        if ordered:
            w3 = W3[i]
            norm2 = zero
            for j in range(n):
                s3 = has_next * c_next[j] - c[j] + w3[j]
                w3[j] = s3
                norm2 += s3 * s3
            norm = np.sqrt(norm2)
            k = C.dtype.type(1.0 - t2 / norm if norm > t2 else 0.0)
            keep[i] = k
            for j in range(n):
                dc = has_next * c_next[j] - c[j]
                primal += (dc - k * w3[j]) * (dc - k * w3[j])
                kc += dc * dc
        l1 = zero
        c2 = zero
        group = zero
        for j in range(n):
            t = _b_terms(c[j], _soft(c[j] + w2[j], t1), has_next * _soft(c_next[j] + w2_next[j], t1))
            l1 += t[0]
            primal += t[1]
            c2 += t[2]
            group += t[3]
        if zero_diagonal:  # B[i, i] = 0 and B[i + 1, i + 1] = 0: swap those entries' shares
            for j in range(i, min(i + 2, n)):
                b = _soft(c[j] + w2[j], t1)
                b_next = has_next * _soft(c_next[j] + w2_next[j], t1)
                wrong = _b_terms(c[j], b, b_next)
                right = _b_terms(c[j], zero, b_next) if j == i else _b_terms(c[j], b, zero)
                l1 += right[0] - wrong[0]
                primal += right[1] - wrong[1]
                group += right[3] - wrong[3]
        stats[i, 0] = primal
        stats[i, 1] = kc + 2.0 * c2
        stats[i, 2] = l1
        stats[i, 3] = np.sqrt(max(group, zero)) if ordered else 0.0


@njit(parallel=True, cache=True, fastmath=FASTMATH)
def _update_pass(C, W2, W3, low_rank, w1, a, g, h, rescale, t1, zero_diagonal, ordered, B, stats):
    """Rows ``a .. a + len(low_rank) - 1``: B-step (rows of ``B`` written to ``B``) and W2 update, the C-step's
    right-hand side into ``C``.

    ``low_rank = (A - W1') - C`` and ``w1 = W1'`` on these rows (from the eigenbasis), ``W3`` holds ``S3``,
    and per row ``U - W3' = g S3``, ``W3' = h S3``. Writes ``(A - W1') + (B - W2') + D^T (U - W3')`` (halved when
    not ordered, where ``T = 2 I``) and ``stats[i] = (||W2'[i]||^2 + ||W3'[i]||^2, ||(W1' + W2' + D^T W3')[i]||^2)``.
    """
    n = C.shape[1]
    for ii in prange(low_rank.shape[0]):
        i = a + ii
        c, w2, lr, kt, b = C[i], W2[i], low_rank[ii], w1[ii], B[ii]
        c_ii, s2_ii = c[i], c[i] + w2[i]
        for j in range(n):
            s2 = c[j] + w2[j]
            clipped = min(max(s2, -t1), t1)
            b[j] = s2 - clipped
            w2[j] = rescale * clipped
            c[j] += lr[j] + b[j] - w2[j]
            kt[j] += w2[j]
        if zero_diagonal:  # B[i, i] = 0: the whole of S2[i, i] goes to the dual
            b[i] = 0.0
            kt[i] += rescale * s2_ii - w2[i]
            w2[i] = rescale * s2_ii
            c[i] = c_ii + lr[i] - w2[i]
        duals = C.dtype.type(0.0)
        if ordered:
            s3, s3_prev = W3[i], W3[max(i - 1, 0)]
            gi, hi = g[i], h[i]
            gp = g[max(i - 1, 0)] if i > 0 else g.dtype.type(0.0)
            hp = h[max(i - 1, 0)] if i > 0 else h.dtype.type(0.0)
            for j in range(n):
                c[j] += gp * s3_prev[j] - gi * s3[j]
                kt[j] += hp * s3_prev[j] - hi * s3[j]
                duals += (hi * s3[j]) * (hi * s3[j])
        else:
            half = C.dtype.type(0.5)
            for j in range(n):
                c[j] *= half
        dual = C.dtype.type(0.0)
        for j in range(n):
            duals += w2[j] * w2[j]
            dual += kt[j] * kt[j]
        stats[i, 0] = duals
        stats[i, 1] = dual


@njit(inline="always", fastmath=FASTMATH)
def _scale_add(x, dx, y, dy):
    """``x <- dx x + dy y`` for two row pieces of equal length (loops from 0 so that they vectorise)."""
    for j in range(x.shape[0]):
        x[j] = dx * x[j] + dy * y[j]


@njit(parallel=True, cache=True, fastmath=FASTMATH)
def _solve_pass(C, W3, h, inv, forward, backward, width):
    """``C <- T^{-1} C`` column chunk by column chunk (rows in sequence), and ``W3 <- h S3`` on the way."""
    n, m = C.shape
    for chunk in prange((m + width - 1) // width):
        j0 = chunk * width
        j1 = min(m, j0 + width)
        for i in range(n):
            w3 = W3[i, j0:j1]
            for j in range(w3.shape[0]):
                w3[j] *= h[i]
            _scale_add(C[i, j0:j1], inv[i], C[max(i - 1, 0), j0:j1], forward[i])
        for i in range(n - 1, -1, -1):
            _scale_add(C[i, j0:j1], inv[i], C[min(i + 1, n - 1), j0:j1], backward[i])


@dataclass
class _Step:
    """Norms gathered by one iteration (squares unless named otherwise)."""

    primal: float  # ||C - A||^2 + ||C - B||^2 + ||D C - U||^2
    dual: float  # ||W1 + W2 + D^T W3||^2, duals after the step
    kc: float  # 2 ||C||^2 + ||D C||^2
    duals: float  # ||W1||^2 + ||W2||^2 + ||W3||^2
    objective: float  # eq. 9 at B


class _FusedADMM:
    """State and iteration of the ADMM of the module docstring, in the sample-major layout ``C = Z^T``.

    Kept: ``C``, the scaled duals ``W2``, ``W3`` (``n x n``) and ``N`` (``n x r``, ``W1 = -N P^T``). An iteration
    is :func:`_statistics_pass`, the product ``C P``, :func:`_update_pass` by row blocks (with the products
    ``((A - W1') - C)``, ``W1'`` and ``B P`` of each block on BLAS) and :func:`_solve_pass`.
    """

    def __init__(self, X, lambda1: float, lambda2: float, zero_diagonal: bool, dtype: np.dtype, workers: int):
        n = X.shape[0]
        self.pool, self.workers = ThreadPoolExecutor(workers), workers
        U, s, _ = np.linalg.svd(X, full_matrices=False)
        keep = s > s[0] * max(X.shape) * np.finfo(float).eps
        self.n, self.dtype = n, dtype
        self.P = np.ascontiguousarray(U[:, keep], dtype=dtype)
        self.PT = np.ascontiguousarray(self.P.T)
        self.sv = s[keep]
        self.lambda1, self.lambda2 = lambda1, lambda2
        self.ordered = lambda2 > 0
        self.zero_diagonal = zero_diagonal
        self.C = np.zeros((n, n), dtype)
        self.W2 = np.zeros((n, n), dtype)
        self.W3 = np.zeros((n, n) if self.ordered else (1, 1), dtype)
        self.N = np.zeros((n, self.P.shape[1]))
        self.keep = np.zeros(n)
        self.cholesky = tuple(v.astype(dtype) for v in _cholesky_coefficients(n))
        self.rows = max(1, min(n, BLOCK_ELEMENTS // n))
        self.buffers = np.empty((4, self.rows, n), dtype)  # (A - W1) - C, W1, and B twice (products overlap)

    def step(self, rho: float, rescale: float) -> _Step:
        """One iteration at penalty ``rho``; the new scaled duals are multiplied by ``rescale`` (next penalty
        ``rho / rescale``)."""
        n, C, W2, W3, P, PT = self.n, self.C, self.W2, self.W3, self.P, self.PT
        real = self.dtype.type
        t1, t2 = real(self.lambda1 / rho), real(self.lambda2 / rho)
        stats = np.empty((n, 4))
        _statistics_pass(C, W2, W3, t1, t2, self.zero_diagonal, self.ordered, self.keep, stats)
        primal, kc, l1, group = stats.sum(axis=0)
        # A-step in the eigenbasis: N' = (P - (C + W1) P) diag(s/(s + rho)), A = C + (N' - N) P^T
        damp = self.sv**2 / (self.sv**2 + rho)
        n_old = self.N
        n_new = (P - self._projection(C) + n_old) * damp
        primal += float(np.sum((n_new - n_old) ** 2))
        self.N = rescale * n_new
        g = (self.keep * (1.0 + rescale) - rescale).astype(self.dtype)
        h = (rescale * (1.0 - self.keep)).astype(self.dtype)
        low_coef = ((1.0 + rescale) * n_new - n_old).astype(self.dtype)
        w1_coef = (-self.N).astype(self.dtype)
        out = np.empty((n, 2))
        data, pending = 0.0, None
        for k, a in enumerate(range(0, n, self.rows)):
            b = min(a + self.rows, n)
            low_rank, w1, b_rows = (buffer[: b - a] for buffer in (*self.buffers[:2], self.buffers[2 + k % 2]))
            products = [
                self.pool.submit(np.matmul, coef[a:b], PT, out=product)
                for coef, product in ((low_coef, low_rank), (w1_coef, w1))
            ]
            data += self._data_term(pending)
            for task in products:
                task.result()
            _update_pass(
                C, W2, W3, low_rank, w1, a, g, h, real(rescale), t1, self.zero_diagonal, self.ordered, b_rows, out
            )
            pending = (a, b, self.pool.submit(np.matmul, b_rows, P))  # B P, collected during the next block
        data += self._data_term(pending)
        duals, dual = out.sum(axis=0)
        if self.ordered:
            _solve_pass(C, W3, h, *self.cholesky, -(-n // numba.get_num_threads()))
        objective = 0.5 * data + self.lambda1 * l1 + self.lambda2 * group
        return _Step(primal, dual, kc, duals + float(np.sum(self.N**2)), objective)

    def _data_term(self, pending) -> float:
        """``||(P - B P) diag(s)||^2`` on the rows of a finished block (``= ||X - B X||^2`` there)."""
        if pending is None:
            return 0.0
        a, b, task = pending
        return float(np.sum(((self.P[a:b] - task.result()) * self.sv) ** 2))

    def _projection(self, C: np.ndarray) -> np.ndarray:
        """``C P`` (``n x r``, float64) with the rows shared among the pool's threads."""
        parts = np.array_split(np.arange(self.n), self.workers)
        tasks = [self.pool.submit(np.matmul, C[p[0]:p[-1] + 1], self.P) for p in parts if p.size]
        return np.vstack([task.result() for task in tasks])

    def coefficients(self, rho: float) -> np.ndarray:
        """``B = soft(C + W2, l1/rho)`` (zero diagonal if asked), computed in place of ``W2``; sample-major."""
        t1 = self.lambda1 / rho
        B, n = self.W2, self.n
        for a in range(0, n, self.rows):
            b = min(a + self.rows, n)
            s2 = B[a:b]
            s2 += self.C[a:b]
            s2 -= np.clip(s2, -t1, t1, out=self.buffers[0, : b - a])
            if self.zero_diagonal:
                s2.reshape(-1)[np.arange(b - a) * (n + 1) + a] = 0.0
        return B


def osc_admm(
    X: np.ndarray,
    lambda1: float,
    lambda2: float,
    *,
    rho: float | None = None,
    max_iter: int = 300,
    tol: float = 1e-2,
    zero_diagonal: bool = True,
    dtype: str = "float32",
) -> OSCResult:
    """Solve eq. 9 for ``X`` (``n x d``, one sample per row; the paper's ``X`` is ``X.T``) by ADMM.

    ``lambda1``, ``lambda2`` and ``rho`` are absolute (units of X^2); ``lambda2 = 0`` gives SSC (the ordering
    block is then dropped from the splitting). ``rho=None`` starts at ``DEFAULT_RHO_PER_LAMBDA * max(lambda1,
    lambda2)``. ``dtype`` ``"float32"`` halves memory and time (three ``n x n`` arrays are kept); the tests check
    float64 against a conic solver. Validation of ``X`` is the caller's job (see :func:`check_samples`).
    """
    X = np.asarray(X, dtype=float)
    dt = np.dtype(dtype)
    rho = DEFAULT_RHO_PER_LAMBDA * max(lambda1, lambda2) if rho is None else float(rho)
    if not (lambda1 > 0 and lambda2 >= 0 and rho > 0):
        raise InputError(f"osc: need lambda1 > 0, lambda2 >= 0 and rho > 0, got {lambda1}, {lambda2}, {rho}")
    # single-threaded BLAS calls, spread over our own threads: spinning BLAS workers would stall numba's passes
    with threadpool_limits(1, user_api="blas"):
        state = _FusedADMM(X, lambda1, lambda2, zero_diagonal, dt, numba.get_num_threads())
        with state.pool:
            return _run(state, rho, max_iter, tol)


def _run(state: _FusedADMM, rho: float, max_iter: int, tol: float) -> OSCResult:
    """The iteration loop of :func:`osc_admm`: stopping test, history and residual balancing."""
    names = ("objective", "primal_residual", "dual_residual", "primal_tolerance", "dual_tolerance", "rho")
    history: dict[str, list[float]] = {k: [] for k in names}
    rescale, converged, k = 1.0, False, 0
    for k in range(1, max_iter + 1):
        st = state.step(rho, rescale)
        rho /= rescale
        r, s = np.sqrt(st.primal), rho * np.sqrt(st.dual)
        eps_r, eps_s = tol * np.sqrt(st.kc), tol * rho * np.sqrt(st.duals)
        for key, value in zip(names, (st.objective, r, s, eps_r, eps_s, rho)):
            history[key].append(float(value))
        if r <= eps_r and s <= eps_s:
            converged = True
            break
        rescale = _balance(r / max(eps_r, 1e-300), s / max(eps_s, 1e-300)) if _adapts(k) else 1.0
    B = state.coefficients(rho)
    return OSCResult(B.T, k, converged, {key: np.array(v) for key, v in history.items()}, rho)


def _adapts(k: int) -> bool:
    return k < ADAPT_UNTIL and k % ADAPT_EVERY == 0


def _balance(primal: float, dual: float) -> float:
    """Dual rescale factor of residual balancing: ``< 1`` raises rho (primal lags), ``> 1`` lowers it."""
    if primal > ADAPT_RATIO * dual:
        return 1.0 / ADAPT_FACTOR
    if dual > ADAPT_RATIO * primal:
        return ADAPT_FACTOR
    return 1.0


def affinity(Z: np.ndarray) -> np.ndarray:
    """Symmetric affinity ``W = |Z| + |Z|^T`` of a coefficient matrix (``n x n``, dimensionless)."""
    A = np.abs(Z)
    return A + A.T


def check_samples(X, n_clusters: int, name: str = "X") -> np.ndarray:
    """``X`` as a float array ``(n_samples, n_features)``, or :class:`InputError` saying what to fix."""
    try:
        X = np.asarray(X, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{name}: values must be numeric; convert the window matrix to numbers") from None
    if X.ndim != 2:
        raise InputError(f"{name}: expected a 2-D array (one window per row), got shape {X.shape}")
    n = X.shape[0]
    bad = ~np.isfinite(X)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise InputError(
            f"{name}: NaN or infinite value at sample {row}, feature {col}; "
            "drop or interpolate missing samples before windowing"
        )
    if n < max(n_clusters, 2):
        raise InputError(
            f"{name}: {n} samples (windows, the paper's columns) for n_clusters={n_clusters}; "
            "ask for fewer clusters or give more windows"
        )
    if X.shape[1] == 0 or not np.any(np.ptp(X, axis=0) > 0):
        raise InputError(f"{name}: all {n} samples are identical (constant data); check the input channels")
    return X


class _SelfExpressiveClustering(ClusterMixin, BaseEstimator):
    """Shared ``fit``: coefficients by :func:`osc_admm`, affinity ``|Z| + |Z|^T``, labels by normalized cuts."""

    def fit(self, X, y=None):
        """Cluster the rows of ``X`` (``n_samples x n_features``: one window per row, the paper's ``X``
        transposed). ``y`` is ignored."""
        try:  # a TypeError (sparse input, objects that are not numbers) is a programming error and propagates
            X = validate_data(self, X, dtype=np.float64, ensure_all_finite=False)
        except ValueError as error:
            raise InputError(f"X: {str(error).splitlines()[0]}") from None
        X = check_samples(X, self.n_clusters)
        scale = penalty_scale(X)
        if scale <= 0:
            raise InputError("X: no two samples are correlated (all pairwise products are 0); nothing to cluster")
        self.lambda1_ = self.lambda1 * scale
        self.lambda2_ = self.lambda2 * scale if self.ordered else 0.0
        rho = None if self.rho is None else self.rho * scale
        result = osc_admm(
            X, self.lambda1_, self.lambda2_, rho=rho, max_iter=self.max_iter, tol=self.tol,
            zero_diagonal=self.zero_diagonal, dtype=self.dtype,
        )
        self.coef_ = result.coef
        self.affinity_ = affinity(result.coef)
        self.labels_ = normalized_cuts(self.affinity_, self.n_clusters, self.random_state)
        self.history_ = result.history
        self.n_iter_ = result.n_iter
        self.converged_ = result.converged
        self.rho_ = result.rho
        return self


class OrderedSubspaceClustering(_SelfExpressiveClustering):
    """Ordered Subspace Clustering (eq. 9; math in the module docstring) followed by normalized cuts.

    Parameters
    ----------
    n_clusters : number of groups for normalized cuts.
    lambda1, lambda2 : weights of ``||Z||_1`` and ``||Z R||_{1,2}`` as fractions of
        :func:`penalty_scale` ``mu = max_{i != j} |x_i . x_j|`` (so that they follow the scale of the data;
        ``lambda1 >= 1`` gives ``Z = 0``). The defaults 0.01 / 0.1 are the best of a grid on the synthetic
        switching block-Hankel windows of ``benchmarks/osc_speed.py`` (mean adjusted Rand index).
    rho : initial ADMM penalty as a fraction of ``mu``; ``None`` uses ``DEFAULT_RHO_PER_LAMBDA`` times the larger
        weight. It is adapted by residual balancing during the first iterations.
    max_iter, tol : iteration cap and relative tolerance of both residuals.
    zero_diagonal : impose ``diag(Z) = 0``.
    dtype : ``"float64"`` or ``"float32"`` (half the memory: three ``n x n`` arrays during the solve).
    random_state : seed of normalized cuts (Lanczos start vector and k-means); same seed, same labels.
    ordered : ``False`` drops the ordering term (plain SSC).

    Attributes
    ----------
    coef_ : ``(n, n)`` the paper's ``Z``: column ``j`` holds the coefficients that represent sample ``j``.
    affinity_ : ``(n, n)`` ``|Z| + |Z|^T``.
    labels_ : ``(n,)`` cluster of every sample.
    history_ : dict of per-iteration arrays ``objective``, ``primal_residual``, ``dual_residual``,
        ``primal_tolerance``, ``dual_tolerance``, ``rho``.
    n_iter_, converged_, rho_ : iterations run, whether both residuals met ``tol``, final penalty (absolute).
    lambda1_, lambda2_ : the absolute weights used (units of X^2).
    """

    def __init__(
        self,
        n_clusters: int = 2,
        *,
        lambda1: float = 0.01,
        lambda2: float = 0.1,
        rho: float | None = None,
        max_iter: int = 300,
        tol: float = 1e-2,
        zero_diagonal: bool = True,
        dtype: str = "float32",
        random_state=None,
        ordered: bool = True,
    ):
        self.n_clusters = n_clusters
        self.lambda1 = lambda1
        self.lambda2 = lambda2
        self.rho = rho
        self.max_iter = max_iter
        self.tol = tol
        self.zero_diagonal = zero_diagonal
        self.dtype = dtype
        self.random_state = random_state
        self.ordered = ordered


class SparseSubspaceClustering(_SelfExpressiveClustering):
    """Sparse Subspace Clustering (Elhamifar & Vidal 2013, noisy form): eq. 9 without the ordering term.

    Same solver and parameters as :class:`OrderedSubspaceClustering` with ``lambda2 = 0``.
    """

    lambda2 = 0.0
    ordered = False

    def __init__(
        self,
        n_clusters: int = 2,
        *,
        lambda1: float = 0.01,
        rho: float | None = None,
        max_iter: int = 300,
        tol: float = 1e-2,
        zero_diagonal: bool = True,
        dtype: str = "float32",
        random_state=None,
    ):
        self.n_clusters = n_clusters
        self.lambda1 = lambda1
        self.rho = rho
        self.max_iter = max_iter
        self.tol = tol
        self.zero_diagonal = zero_diagonal
        self.dtype = dtype
        self.random_state = random_state
