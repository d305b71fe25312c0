"""The residual classifiers together: CRC_RLS, SRC and B_SRC on union-of-subspaces data, rejection, bad input
(every method of METHODS, kernel CRC_RLS and the nearest-columns rule included, for the estimator checks and bad
input)."""

import numpy as np
import pytest
from sklearn.utils.estimator_checks import check_estimator

from spotfree.classify import METHODS, UNKNOWN, make_classifier
from spotfree.errors import InputError

from classify_fixtures import amplitude_data

# decision_function returns residuals (smaller is better), as the paper ranks classes; scikit-learn's checks of
# larger-is-better scores therefore do not apply.
RESIDUAL_CONVENTION = {
    "check_classifiers_classes": "decision_function returns class residuals, smaller is better",
    "check_classifiers_train": "decision_function returns class residuals, smaller is better",
}
PREDICT_TIME_ITERATIONS = {
    "check_non_transformer_estimators_n_iter": "max_iter bounds the coding of each window in predict; fit does "
    "not iterate, so there is no n_iter_",
}
EXPECTED_FAILURES = {"crc": RESIDUAL_CONVENTION, "src": RESIDUAL_CONVENTION | PREDICT_TIME_ITERATIONS,
                     "bsrc": RESIDUAL_CONVENTION | PREDICT_TIME_ITERATIONS, "nearest": RESIDUAL_CONVENTION,
                     "kcrc": RESIDUAL_CONVENTION}
CLASSES = ("cruising", "normal-braking", "sudden-braking")
SUBSPACE_METHODS = ["bsrc", "crc", "src"]
"""The residual classifiers that model a class as a subspace (the nearest-columns rule measures distance instead:
tests/test_classify_neighbours.py)."""


def subspace_data(seed: int, d: int = 40, rank: int = 3, atoms: int = 30, windows: int = 20, noise: float = 0.05):
    """Atoms and test windows drawn from one random ``rank``-dimensional subspace per class, plus a fourth
    subspace no class owns (the out-of-class windows)."""
    rng = np.random.default_rng(seed)
    bases = [np.linalg.qr(rng.normal(size=(d, rank)))[0] for _ in range(len(CLASSES) + 1)]

    def draw(basis, n):
        return (basis @ rng.normal(size=(rank, n))).T + noise * rng.normal(size=(n, d))

    X = np.vstack([draw(b, atoms) for b in bases[:-1]])
    y = np.repeat(CLASSES, atoms)
    test = np.vstack([draw(b, windows) for b in bases[:-1]])
    return X, y, test, np.repeat(CLASSES, windows), draw(bases[-1], windows)


@pytest.mark.parametrize("method", sorted(METHODS))
def test_scikit_learn_estimator_checks(method):
    check_estimator(make_classifier(method), expected_failed_checks=EXPECTED_FAILURES[method])


@pytest.mark.parametrize("method", SUBSPACE_METHODS)
def test_windows_from_one_class_subspace_get_that_class(method):
    X, y, test, truth, _ = subspace_data(1)
    clf = make_classifier(method).fit(X, y)
    assert (clf.predict(test) == truth).all()
    assert clf.decision_function(test).shape == (len(test), 3)
    assert [clf.predict_one(w) for w in test[:5]] == list(truth[:5])


def test_sparse_methods_agree_with_crc_on_easy_data():
    X, y, test, _, _ = subspace_data(2, noise=0.02)
    labels = {m: make_classifier(m).fit(X, y).predict(test) for m in SUBSPACE_METHODS}
    assert (labels["src"] == labels["crc"]).all() and (labels["bsrc"] == labels["crc"]).all()


@pytest.mark.parametrize("method", SUBSPACE_METHODS)
def test_windows_of_an_unknown_subspace_are_rejected(method):
    X, y, test, truth, outside = subspace_data(3)
    clf = make_classifier(method, reject=0.5).fit(X, y)
    assert (clf.predict(outside) == UNKNOWN).all()
    assert (clf.predict(test) == truth).all()
    scores = clf.rejection_score(np.vstack([test, outside]))
    assert scores[: len(test)].max() < 0.5 < scores[len(test):].min()
    assert clf.predict_one(outside[0]) == UNKNOWN


def test_rejection_with_integer_classes_gives_object_labels():
    X, _, test, _, outside = subspace_data(4)
    clf = make_classifier("crc", reject=0.5).fit(X, np.repeat([0, 1, 2], 30))
    labels = clf.predict(np.vstack([test[:1], outside[:1]]))
    assert labels.tolist() == [0, UNKNOWN]


@pytest.mark.parametrize("method", sorted(METHODS))
def test_bad_input_is_a_clear_error(method):
    X, y, test, _, _ = subspace_data(5)
    clf = make_classifier(method).fit(X, y)
    with pytest.raises(InputError, match="40 features.*rows of 40 values"):
        clf.predict(test[:, :30])
    bad = test[:2].copy()
    bad[1, 3] = np.nan
    with pytest.raises(InputError, match="NaN"):
        clf.predict(bad)
    with pytest.raises(InputError, match="NaN"):
        clf.predict_one(bad[1])
    with pytest.raises(InputError, match="40"):
        clf.predict_one(test[0, :39])
    with pytest.raises(InputError, match="reject"):
        make_classifier(method, reject=-1).fit(X, y)


@pytest.mark.parametrize("method", ["kcrc", "nearest"])
def test_amplitude_aware_methods_separate_classes_that_crc_confuses(method):
    X, y, test, truth, _ = amplitude_data(1)
    assert (make_classifier(method).fit(X, y).predict(test) == truth).all()
    crc = make_classifier("crc").fit(X, y).predict(test)
    assert np.mean(crc == truth) < 0.9  # one shape at two amplitudes is one subspace


def test_unknown_method_names_the_valid_ones():
    with pytest.raises(InputError, match="'lda' is unknown: use one of bsrc, crc, kcrc, nearest, src"):
        make_classifier("lda")


@pytest.mark.parametrize("method", ["src", "bsrc"])
def test_sparse_weights_outside_the_unit_interval_are_refused(method):
    X, y, _, _, _ = subspace_data(6)
    with pytest.raises(InputError, match="alpha=1.5"):
        make_classifier(method, alpha=1.5).fit(X, y)
