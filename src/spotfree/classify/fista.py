"""Batched FISTA for the group lasso over a dictionary: the coding step of B_SRC.

Over unit-norm atoms ``Â`` (columns ``a_j / ||a_j||``) partitioned into groups ``g`` with weights ``w_g``:

    x(y) = argmin_x  1/2 ||y - Â x||_2^2 + lambda(y) sum_g w_g ||x_g||_2,
    lambda(y) = alpha * max_g ||Â_g^T y||_2 / w_g,

``lambda(y)`` being the smallest weight at which ``x = 0``, so ``alpha`` in ``(0, 1)`` is free of units and of the
window's amplitude. One group per class gives the block-sparse code of B_SRC.

FISTA (Beck & Teboulle 2009) with step ``1/L``, ``L = ||Â||_2^2`` (squared largest singular value of the
dictionary), the block soft-threshold as proximal map,

    x_g <- max(0, 1 - lambda w_g / (L ||v_g||)) v_g,      v = u - (Â^T Â u - Â^T y) / L,

and the gradient restart of O'Donoghue & Candès (2015): momentum is reset for a window whose step turns against
its last move. Stopping by the duality gap: with the residual ``rho = y - Â x`` the point ``theta = s rho``,
``s = min(1, lambda / max_g ||Â_g^T rho|| / w_g)``, is dual feasible, and

    gap = 1/2 ||rho||^2 + lambda sum_g w_g ||x_g|| - (1/2 ||y||^2 - 1/2 ||y - theta||^2)  >= 0

bounds the distance to the optimum; a window is done when ``gap <= tol * 1/2 ||y||^2``. All windows are iterated
together, one matrix product per iteration for those not yet done.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from sklearn.exceptions import ConvergenceWarning

from spotfree.errors import InputError

GAP_EVERY = 10
"""Iterations between two duality-gap checks."""


@dataclass
class GroupLasso:
    """The group lasso over unit atoms ``(n_atoms, d)`` (rows); ``groups`` ``(n_atoms,)`` numbers each atom's group
    ``0..G-1``, ``weights`` ``(G,)`` are the ``w_g``."""

    atoms: np.ndarray
    groups: np.ndarray
    weights: np.ndarray
    tol: float = 1e-4
    max_iter: int = 1000
    lipschitz: float = field(init=False)

    def __post_init__(self):
        if not (self.tol > 0 and self.max_iter >= 1):
            raise InputError(f"tol={self.tol!r}, max_iter={self.max_iter!r}: give tol > 0 and max_iter >= 1")
        self.lipschitz = float(np.linalg.norm(self.atoms, 2) ** 2)
        self.weights = np.asarray(self.weights, dtype=float)
        self._membership = (self.groups[np.newaxis, :] == np.arange(len(self.weights))[:, np.newaxis]).astype(float)

    def codes(self, X: np.ndarray, alpha: float) -> np.ndarray:
        """Codes ``x(y)`` ``(n, n_atoms)`` of the windows ``X`` ``(n, d)`` (rows)."""
        corr = X @ self.atoms.T  # Â^T y per window
        lam = alpha * self._dual_norm(corr)
        code = np.zeros_like(corr)
        active = np.flatnonzero(lam > 0)  # lambda_max = 0: y is orthogonal to every atom, x = 0
        Y, threshold = X[active], lam[active] / self.lipschitz
        w = v = np.zeros((len(active), corr.shape[1]))
        t = np.ones(len(active))
        for it in range(1, self.max_iter + 1):
            gradient = (v @ self.atoms - Y) @ self.atoms.T  # Â^T (Â v - y), cheaper than through the Gram matrix
            w_new = self._shrink(v - gradient / self.lipschitz, threshold)
            restart = np.einsum("ij,ij->i", v - w_new, w_new - w) > 0
            t_new = np.where(restart, 1.0, (1 + np.sqrt(1 + 4 * t * t)) / 2)
            v = w_new + ((t - 1) / t_new * ~restart)[:, np.newaxis] * (w_new - w)
            w, t = w_new, t_new
            if it % GAP_EVERY and it != self.max_iter:
                continue
            done = self._gap(Y, w, threshold * self.lipschitz) <= self.tol * 0.5 * np.einsum("ij,ij->i", Y, Y)
            code[active] = w
            keep = ~done
            w, v, t, active, Y, threshold = w[keep], v[keep], t[keep], active[keep], Y[keep], threshold[keep]
            if not len(active):
                break
        else:
            warnings.warn(f"{len(active)} window(s) not converged in max_iter={self.max_iter} FISTA iterations "
                          f"(duality gap above tol={self.tol}); raise max_iter or tol", ConvergenceWarning,
                          stacklevel=4)
        return code

    def _group_norms(self, z: np.ndarray) -> np.ndarray:
        """``||z_g||_2`` per group for rows ``z`` ``(n, n_atoms)``; ``(n, G)``."""
        return np.sqrt((z * z) @ self._membership.T)

    def _dual_norm(self, corr: np.ndarray) -> np.ndarray:
        """``max_g ||z_g|| / w_g`` per row."""
        return (self._group_norms(corr) / self.weights).max(axis=1)

    def _shrink(self, z: np.ndarray, threshold: np.ndarray) -> np.ndarray:
        """Block soft-threshold: ``z_g * max(0, 1 - threshold w_g / ||z_g||)`` per row."""
        norms = self._group_norms(z)
        with np.errstate(divide="ignore", invalid="ignore"):
            keep = np.nan_to_num(np.clip(1 - threshold[:, np.newaxis] * self.weights / norms, 0.0, None))
        return z * keep[:, self.groups]

    def _gap(self, Y: np.ndarray, w: np.ndarray, lam: np.ndarray) -> np.ndarray:
        """Duality gap of codes ``w`` for windows ``Y`` (module docstring)."""
        rho = Y - w @ self.atoms
        scale = np.minimum(1.0, lam / np.maximum(self._dual_norm(rho @ self.atoms.T), np.finfo(float).tiny))
        primal = 0.5 * np.einsum("ij,ij->i", rho, rho) + lam * (self._group_norms(w) @ self.weights)
        diff = Y - scale[:, np.newaxis] * rho
        dual = 0.5 * np.einsum("ij,ij->i", Y, Y) - 0.5 * np.einsum("ij,ij->i", diff, diff)
        return primal - dual
