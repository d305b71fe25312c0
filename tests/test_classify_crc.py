import numpy as np
import pytest
from sklearn.utils.estimator_checks import check_estimator

from spotfree.classify import CRCClassifier

# decision_function returns residuals (smaller is better), as the paper ranks classes; scikit-learn's checks of
# larger-is-better scores therefore do not apply.
RESIDUAL_CONVENTION = {
    "check_classifiers_classes": "decision_function returns class residuals, smaller is better",
    "check_classifiers_train": "decision_function returns class residuals, smaller is better",
}


def test_scikit_learn_estimator_checks():
    check_estimator(CRCClassifier(), expected_failed_checks=RESIDUAL_CONVENTION)


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


def test_windows_from_one_class_subspace_get_that_class():
    rng = np.random.default_rng(1)
    bases = [np.linalg.qr(rng.normal(size=(30, 3)))[0] for _ in range(3)]
    atoms = np.vstack([(b @ rng.normal(size=(3, 25))).T for b in bases])
    labels = np.repeat(["cruising", "normal-braking", "sudden-braking"], 25)
    clf = CRCClassifier().fit(atoms, labels)
    test = np.vstack([(b @ rng.normal(size=(3, 10))).T for b in bases]) + 0.01 * rng.normal(size=(30, 30))
    assert (clf.predict(test) == np.repeat(clf.classes_, 10)).all()


def test_unfitted_and_wrong_width_are_errors():
    with pytest.raises(Exception, match="not fitted"):
        CRCClassifier().predict(np.zeros((1, 3)))
    clf = CRCClassifier().fit(np.eye(4), ["a", "a", "b", "b"])
    with pytest.raises(ValueError, match="features"):
        clf.predict(np.zeros((1, 5)))
