"""The nearest-columns rule: exact residuals, streaming equal to batch, rejection (amplitude that CRC_RLS cannot see:
test_classify_methods)."""

import numpy as np
import pytest

from spotfree.classify import UNKNOWN, NearestColumnsClassifier
from spotfree.errors import InputError

from classify_fixtures import amplitude_data


def test_residuals_are_the_mean_distance_to_the_k_nearest_atoms_of_each_class():
    X, y, test, _, _ = amplitude_data(0)
    clf = NearestColumnsClassifier(n_neighbors=3).fit(X, y)
    distance = np.linalg.norm(test[:, None, :] - X[None, :, :], axis=2)
    expected = np.column_stack([np.sort(distance[:, y == c], axis=1)[:, :3].mean(axis=1) for c in clf.classes_])
    np.testing.assert_allclose(clf.decision_function(test), expected, rtol=1e-9, atol=1e-9)


def test_predict_one_equals_predict():
    X, y, test, _, _ = amplitude_data(2)
    clf = NearestColumnsClassifier(n_neighbors=4).fit(X, y)
    assert [clf.predict_one(w) for w in test] == list(clf.predict(test))


def test_windows_far_from_every_atom_are_rejected():
    X, y, test, truth, outside = amplitude_data(3)
    clf = NearestColumnsClassifier(reject=0.5).fit(X, y)
    assert (clf.predict(outside) == UNKNOWN).all()
    assert (clf.predict(test) == truth).all()
    assert clf.predict_one(outside[0]) == UNKNOWN


@pytest.mark.parametrize("k", [0, -2, 1.5, True])
def test_bad_neighbour_count_is_a_clear_error(k):
    X, y, _, _, _ = amplitude_data(4)
    with pytest.raises(InputError, match="n_neighbors"):
        NearestColumnsClassifier(n_neighbors=k).fit(X, y)
