import numpy as np
import pytest

from spotfree.classify import CRCClassifier, crc
from spotfree.errors import InputError


def test_residuals_equal_the_explicit_ridge_solution():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(40, 10))
    y = np.repeat(["a", "b"], 20)
    clf = CRCClassifier(alpha=0.01).fit(X, y)
    A = X.T
    Y = rng.normal(size=(10, 5))
    x = np.linalg.solve(A.T @ A + clf.lambda_ * np.eye(40), A.T @ Y)
    expected = np.column_stack([np.linalg.norm(Y - A[:, y == k] @ x[y == k], axis=0) for k in "ab"])
    np.testing.assert_allclose(clf.decision_function(Y.T), expected, rtol=1e-10)


def ride_sized_problem(seed: int, n_windows: int):
    """A 60-dimensional window, 3 classes of 100 atoms near 5-dimensional subspaces, and windows near them."""
    rng = np.random.default_rng(seed)
    bases = [np.linalg.qr(rng.normal(size=(60, 5)))[0] for _ in range(3)]
    atoms = np.vstack([(b @ rng.normal(size=(5, 100))).T for b in bases]) + 0.05 * rng.normal(size=(300, 60))
    windows = np.vstack([(b @ rng.normal(size=(5, n_windows))).T for b in bases]) + 0.02 * rng.normal(
        size=(3 * n_windows, 60))
    return atoms, np.repeat(["c", "n", "s"], 100), windows


@pytest.mark.parametrize(("dtype", "rtol", "n_jobs"), [("float64", 1e-12, -1), ("float64", 1e-12, 1),
                                                       ("float32", 1e-5, 2)])
def test_chunked_batch_path_equals_the_plain_formula(dtype, rtol, n_jobs, monkeypatch):
    monkeypatch.setattr(crc, "CHUNK_BYTES", 1 << 18)
    atoms, labels, windows = ride_sized_problem(1, 1000)  # 3000 windows: several chunks
    assert len(windows) * 180 * 8 > 2 * crc.CHUNK_BYTES
    clf = CRCClassifier(dtype=dtype, n_jobs=n_jobs).fit(atoms, labels)
    plain = np.linalg.norm(np.einsum("cij,nj->nci", clf.residual_operators_, windows), axis=2)
    fast = clf.decision_function(windows)
    assert fast.dtype == np.float64
    np.testing.assert_allclose(fast, plain, rtol=rtol)
    # float32 rounding over d terms: within 1e-6 of the window norm
    assert np.max(np.abs(fast - plain) / np.linalg.norm(windows, axis=1)[:, None]) < 1e-6


def test_predict_one_equals_the_batch_labels():
    atoms, labels, windows = ride_sized_problem(2, 200)
    clf = CRCClassifier(reject=0.2).fit(atoms, labels)
    windows = np.vstack([windows, np.random.default_rng(3).normal(size=(50, 60))])  # noise: rejected
    batch = clf.predict(windows)
    assert (batch == "unknown").sum() >= 50
    assert [clf.predict_one(w) for w in windows] == list(batch)
    assert clf.predict_one(list(windows[0])) == batch[0]


def test_unfitted_and_wrong_width_are_errors():
    with pytest.raises(Exception, match="not fitted"):
        CRCClassifier().predict(np.zeros((1, 3)))
    with pytest.raises(Exception, match="not fitted"):
        CRCClassifier().predict_one(np.zeros(3))
    clf = CRCClassifier().fit(np.eye(4), ["a", "a", "b", "b"])
    with pytest.raises(ValueError, match="features"):
        clf.predict(np.zeros((1, 5)))
    with pytest.raises(InputError, match=r"shape \(4,\).*got shape \(2, 4\)"):
        clf.predict_one(np.zeros((2, 4)))
    with pytest.raises(InputError, match="float64, float32"):
        CRCClassifier(dtype="float16").fit(np.eye(4), ["a", "a", "b", "b"])
    with pytest.raises(InputError, match="n_jobs=0"):
        CRCClassifier(n_jobs=0).fit(np.eye(4), ["a", "a", "b", "b"])
