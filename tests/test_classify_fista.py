"""The coding steps: B_SRC's batched group lasso against cvxpy, SRC's lasso by its optimality conditions."""

import cvxpy as cp
import numpy as np
import pytest

from spotfree.classify import BlockSparseClassifier, SRCClassifier
from spotfree.classify.base import unit_atoms
from spotfree.classify.fista import GroupLasso


def problem(seed: int, d: int = 15, per_group: int = 8, n: int = 6):
    rng = np.random.default_rng(seed)
    atoms = unit_atoms(rng.normal(size=(d, 3 * per_group)))
    groups = np.repeat([0, 1, 2], per_group)
    return atoms, groups, rng.normal(size=(n, d))


def cvxpy_codes(atoms, groups, weights, Y, alpha):
    codes = []
    for y in Y:
        corr = atoms @ y
        lam = alpha * max(np.linalg.norm(corr[groups == g]) / weights[g] for g in range(len(weights)))
        x = cp.Variable(len(atoms))
        penalty = sum(weights[g] * cp.norm(x[groups == g], 2) for g in range(len(weights)))
        cp.Problem(cp.Minimize(0.5 * cp.sum_squares(y - atoms.T @ x) + lam * penalty)).solve()
        codes.append(x.value)
    return np.array(codes)


def test_group_lasso_equals_cvxpy():
    atoms, groups, Y = problem(0)
    weights = np.array([1.0, 0.8, 1.3])
    solver = GroupLasso(atoms, groups=groups, weights=weights, tol=1e-10, max_iter=20000)
    np.testing.assert_allclose(solver.codes(Y, 0.2), cvxpy_codes(atoms, groups, weights, Y, 0.2), atol=1e-4)


def test_src_code_is_the_lasso_with_weight_relative_to_lambda_max():
    atoms, groups, Y = problem(1)
    clf = SRCClassifier(alpha=0.1).fit(atoms, groups)
    code = clf.code(Y)
    for y, x in zip(Y, code):  # optimality: a_j^T r = lambda sign(x_j) on the support, |a_j^T r| <= lambda off it
        lam = 0.1 * np.abs(atoms @ y).max()
        corr = atoms @ (y - atoms.T @ x)
        support = x != 0
        assert support.any()
        np.testing.assert_allclose(corr[support], lam * np.sign(x[support]), rtol=1e-6)
        assert np.all(np.abs(corr[~support]) <= lam * (1 + 1e-6))


def test_weight_is_relative_to_lambda_max():
    atoms, groups, Y = problem(2)
    solver = GroupLasso(atoms, groups=groups, weights=np.ones(3))
    assert np.abs(solver.codes(Y, 1.0)).max() < 1e-12  # lambda = lambda_max: x = 0 (up to rounding)
    assert (np.abs(solver.codes(Y, 0.9)).reshape(len(Y), 3, -1).max(axis=2) > 0).any(axis=1).all()
    np.testing.assert_allclose(solver.codes(10 * Y, 0.3), 10 * solver.codes(Y, 0.3), rtol=1e-6, atol=1e-9)


def test_gap_is_positive_and_closes():
    atoms, groups, Y = problem(3)
    solver = GroupLasso(atoms, groups=groups, weights=np.ones(3), tol=1e-9, max_iter=20000)
    lam = 0.3 * solver._dual_norm(Y @ atoms.T)
    rng = np.random.default_rng(4)
    assert (solver._gap(Y, rng.normal(size=(len(Y), len(atoms))), lam) > 0).all()
    assert (solver._gap(Y, solver.codes(Y, 0.3), lam) <= 1e-9 * 0.5 * (Y * Y).sum(axis=1) + 1e-15).all()


def test_block_code_uses_whole_classes():
    rng = np.random.default_rng(5)
    basis = np.linalg.qr(rng.normal(size=(20, 3)))[0]
    atoms = np.vstack([(basis @ rng.normal(size=(3, 10))).T, rng.normal(size=(20, 20))])
    clf = BlockSparseClassifier(alpha=0.3).fit(atoms, np.repeat(["in", "out"], [10, 20]))
    code = clf.code((basis @ rng.normal(size=(3, 5))).T)
    assert np.abs(code[:, 10:]).max() == 0 and (np.abs(code[:, :10]).max(axis=1) > 0).all()


def test_unconverged_windows_warn():
    atoms, groups, Y = problem(6)
    with pytest.warns(Warning, match="not converged in max_iter=3"):
        GroupLasso(atoms, groups=groups, weights=np.ones(3), tol=1e-12, max_iter=3).codes(Y, 0.05)
