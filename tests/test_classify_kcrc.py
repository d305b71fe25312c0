"""Kernel CRC_RLS: residuals against an explicit feature map, amplitude that linear CRC_RLS cannot see, streaming
equal to batch, rejection and bad parameters."""

import numpy as np
import pytest
from scipy.spatial.distance import cdist, pdist

from spotfree.classify import UNKNOWN, CRCClassifier, KernelCRCClassifier
from spotfree.errors import InputError

from classify_fixtures import amplitude_data


def test_residuals_equal_ridge_regression_in_an_explicit_feature_space():
    rng = np.random.default_rng(0)
    atoms, windows = rng.normal(size=(12, 5)), rng.normal(size=(4, 5))
    labels = np.repeat(["a", "b", "c"], 4)
    clf = KernelCRCClassifier(gamma_scale=0.5, alpha=0.1).fit(atoms, labels)
    gamma = 0.5 / np.median(pdist(atoms, "sqeuclidean"))
    # features in which inner products are the kernel, for atoms and windows together: K = V L V^T, phi = V L^1/2
    points = np.vstack([atoms, windows])
    values, vectors = np.linalg.eigh(np.exp(-gamma * cdist(points, points, "sqeuclidean")))
    phi = vectors * np.sqrt(np.clip(values, 0, None))
    Phi_A, Phi_Y = phi[:12].T, phi[12:].T
    for j in range(4):
        x = np.linalg.solve(Phi_A.T @ Phi_A + 0.1 * np.eye(12), Phi_A.T @ Phi_Y[:, j])
        expected = [np.linalg.norm(Phi_Y[:, j] - Phi_A[:, labels == c] @ x[labels == c]) for c in "abc"]
        np.testing.assert_allclose(clf.decision_function(windows[j:j + 1])[0], expected, atol=1e-6)


def test_amplitude_separates_classes_that_crc_confuses():
    X, y, test, truth, _ = amplitude_data(1)
    kernel = KernelCRCClassifier().fit(X, y).predict(test)
    crc = CRCClassifier().fit(X, y).predict(test)
    assert (kernel == truth).all()
    assert np.mean(crc == truth) < 0.9  # one shape at two amplitudes is one subspace


def test_predict_one_equals_predict():
    X, y, test, _, outside = amplitude_data(2)
    clf = KernelCRCClassifier(reject=0.9).fit(X, y)
    windows = np.vstack([test, outside])
    assert [clf.predict_one(w) for w in windows] == list(clf.predict(windows))
    with pytest.raises(InputError, match="NaN or infinity"):
        clf.predict_one(np.full(X.shape[1], np.nan))
    with pytest.raises(InputError, match="one window of shape"):
        clf.predict_one(test[0, :-1])


def test_windows_far_from_every_atom_are_rejected():
    X, y, test, _, outside = amplitude_data(3)
    clf = KernelCRCClassifier(reject=0.9).fit(X, y)
    assert (clf.predict(outside) == UNKNOWN).all()
    assert (clf.predict(test) != UNKNOWN).all()
    assert clf.rejection_score(outside).min() > 0.9 > clf.rejection_score(test).max()


@pytest.mark.parametrize("params", [{"gamma_scale": 0}, {"gamma_scale": np.nan}, {"alpha": -1.0}, {"alpha": 0}])
def test_bad_parameters_are_a_clear_error(params):
    X, y, _, _, _ = amplitude_data(0)
    with pytest.raises(InputError, match="gamma_scale|alpha"):
        KernelCRCClassifier(**params).fit(X, y)
