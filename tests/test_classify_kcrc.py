"""Kernel CRC_RLS: exact kernel CRC with every atom a landmark, landmarks per class, streaming equal to batch,
rejection and bad parameters (amplitude that CRC_RLS cannot see: test_classify_methods)."""

import numpy as np
import pytest
from scipy.spatial.distance import cdist, pdist

from spotfree.classify import UNKNOWN, KernelCRCClassifier, crc
from spotfree.errors import InputError
from spotfree.kernels import EXP_FLOOR, exp_nonpositive

from classify_fixtures import amplitude_data


def test_every_atom_a_landmark_is_exact_kernel_crc():
    rng = np.random.default_rng(0)
    atoms, windows = rng.normal(size=(12, 5)), rng.normal(size=(4, 5))
    labels = np.repeat(["a", "b", "c"], 4)
    clf = KernelCRCClassifier(gamma_scale=0.5, landmarks=None, alpha=0.1).fit(atoms, labels)
    gamma = 0.5 / np.median(pdist(atoms, "sqeuclidean"))
    phi = clf._features(atoms)
    np.testing.assert_allclose(phi @ phi.T, np.exp(-gamma * cdist(atoms, atoms, "sqeuclidean")), atol=1e-9)
    # exact kernel CRC_RLS in features where inner products are the kernel for atoms and windows together
    points = np.vstack([atoms, windows])
    values, vectors = np.linalg.eigh(np.exp(-gamma * cdist(points, points, "sqeuclidean")))
    exact = vectors * np.sqrt(np.clip(values, 0, None))
    Phi_A, Phi_Y = exact[:12].T, exact[12:].T
    lam = 0.1 * np.trace(Phi_A.T @ Phi_A) / 12
    ours = clf.decision_function(windows)
    for j in range(4):
        x = np.linalg.solve(Phi_A.T @ Phi_A + lam * np.eye(12), Phi_A.T @ Phi_Y[:, j])
        expected = [np.linalg.norm(Phi_Y[:, j] - Phi_A[:, labels == c] @ x[labels == c]) for c in "abc"]
        np.testing.assert_allclose(ours[j], expected, atol=1e-7)


def test_the_compiled_exp_is_within_an_ulp_of_the_c_library():
    rng = np.random.default_rng(0)
    x = np.concatenate([-rng.random(100_000) * 40, -rng.random(10_000) * 708, -rng.random(1_000) * 1e-9,
                        [0.0, -0.0, EXP_FLOOR, -np.log(2) / 2, -1.5 * np.log(2), -1e-300]])
    y = x.copy()
    exp_nonpositive(y)
    expected = np.exp(x)
    assert np.all(np.abs(y - expected) <= np.spacing(expected))
    assert np.mean(y == expected) > 0.9
    out_of_range = np.array([1.0, np.inf, -800.0, -np.inf])
    exp_nonpositive(out_of_range)  # kept <= 0, and above the subnormal results
    np.testing.assert_array_equal(out_of_range, [1.0, 1.0, y[x == EXP_FLOOR][0], y[x == EXP_FLOOR][0]])
    not_a_number = np.array([np.nan, -1.0])
    exp_nonpositive(not_a_number)  # a NaN stays NaN, so that a window that is not finite is refused, not labelled
    assert np.isnan(not_a_number[0])
    assert abs(not_a_number[1] - np.exp(-1.0)) <= np.spacing(np.exp(-1.0))


def test_landmarks_cover_every_class_and_label_like_every_atom():
    X, y, test, truth, _ = amplitude_data(4, atoms=80)
    X, y = np.vstack([X, X[:3] * 2.0]), np.r_[y, ["rare"] * 3]
    few = KernelCRCClassifier(landmarks=8).fit(X, y)
    assert len(few.landmarks_) <= 10
    # the rare class holds 3 of 163 atoms: one of them is its landmark
    assert np.min(np.linalg.norm(few.landmarks_[:, None, :] - X[None, -3:, :], axis=2)) == 0
    every = KernelCRCClassifier(landmarks=None).fit(X, y)
    assert np.mean(few.predict(test) == every.predict(test)) > 0.95


@pytest.mark.parametrize("landmarks", [None, 16])
def test_predict_one_equals_predict(landmarks):
    X, y, test, _, outside = amplitude_data(2)
    clf = KernelCRCClassifier(landmarks=landmarks, reject=0.5).fit(X, y)
    windows = np.vstack([test, outside])
    assert [clf.predict_one(w) for w in windows] == list(clf.predict(windows))
    with pytest.raises(InputError, match="NaN or infinity"):
        clf.predict_one(np.full(X.shape[1], np.nan))
    with pytest.raises(InputError, match="one window of shape"):
        clf.predict_one(test[0, :-1])


def test_labels_are_the_least_residuals_although_classes_are_pruned(monkeypatch):
    # three amplitudes of one shape; windows between them and of another shape, so that bounds are close
    rng = np.random.default_rng(5)
    shape = np.sin(np.linspace(0, np.pi, 30))
    atoms = np.vstack([np.outer(a * rng.uniform(0.8, 1.2, 40), shape) for a in (1.0, 2.0, 3.0)])
    atoms += 0.05 * rng.normal(size=atoms.shape)
    labels = np.repeat(["one", "two", "three"], 40)
    windows = np.vstack([np.outer(rng.uniform(0.5, 3.5, 300), shape) + 0.05 * rng.normal(size=(300, 30)),
                         rng.normal(size=(50, 30))])
    monkeypatch.setattr(crc, "CHUNK_BYTES", 1 << 14)  # windows in several chunks, shared out to two threads
    for reject in (None, 0.5):
        clf = KernelCRCClassifier(landmarks=24, reject=reject, n_jobs=2).fit(atoms, labels)
        assert len(windows) * clf._heads_t.itemsize * sum(clf._heads_t.shape) > 4 * crc.CHUNK_BYTES
        assert clf.head_ < len(clf.normalisation_)  # rows are left out of the bounds
        residuals = clf.decision_function(windows)  # every class completed
        expected = np.where(residuals.min(axis=1) > (reject or np.inf), UNKNOWN,
                            clf.classes_[np.argmin(residuals, axis=1)])
        assert list(clf.predict(windows)) == list(expected)
        assert [clf.predict_one(w) for w in windows] == list(expected)
        # the rotated, folded operators give CRC_RLS's residuals on the Nystroem features
        phi = clf._features(windows)
        inside = clf.crc_.decision_function(phi)
        np.testing.assert_allclose(residuals, np.sqrt(inside ** 2 + 1.0 - np.sum(phi ** 2, axis=1)[:, None]),
                                   atol=1e-7)


def test_windows_far_from_every_atom_are_rejected():
    X, y, test, _, outside = amplitude_data(3)
    clf = KernelCRCClassifier(reject=0.5).fit(X, y)
    assert (clf.predict(outside) == UNKNOWN).all()
    assert (clf.predict(test) != UNKNOWN).all()
    assert clf.rejection_score(outside).min() > 0.5 > clf.rejection_score(test).max()


@pytest.mark.parametrize("params", [{"gamma_scale": 0}, {"gamma_scale": np.nan}, {"landmarks": 0},
                                    {"landmarks": 2.5}, {"landmarks": True}])
def test_bad_parameters_are_a_clear_error(params):
    X, y, _, _, _ = amplitude_data(0)
    with pytest.raises(InputError, match="gamma_scale|landmarks"):
        KernelCRCClassifier(**params).fit(X, y)


def test_landmarks_are_atoms_near_the_middle_of_their_groups_not_outliers():
    from spotfree.classify.kcrc import _central_points

    rng = np.random.default_rng(0)
    centres = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0]])
    points = np.vstack([c + rng.normal(scale=0.5, size=(60, 2)) for c in centres] + [[[40.0, 40.0]]])  # one outlier
    chosen = _central_points(points, 3)
    assert len(chosen) == 3 and all((points == row).all(axis=1).any() for row in chosen)  # atoms, not means
    assert sorted(np.argmin(cdist(chosen, centres), axis=1)) == [0, 1, 2]  # one in every group
    assert cdist(chosen, centres).min(axis=1).max() < 1.0  # near its group's middle; the outlier is not taken
    np.testing.assert_array_equal(chosen, _central_points(points, 3))  # the same points, the same landmarks
    few = np.repeat(points[:2], 5, axis=0)  # two distinct atoms
    np.testing.assert_array_equal(_central_points(few, 3), np.unique(points[:2], axis=0))


def test_a_last_bit_difference_of_the_atoms_does_not_move_the_landmarks():
    """Atoms computed on another processor may differ in their last bits (numpy's exp and log): the landmarks are
    the same atoms when every atom value is one unit in the last place off."""
    from spotfree.classify.kcrc import _central_points

    for seed in range(3):
        rng = np.random.default_rng(seed)
        points = rng.normal(size=(300, 40))  # scattered groups: k-means near ties, as in a dictionary's windows
        off = np.where(rng.random(points.shape) < 0.5, np.nextafter(points, np.inf), points)
        chosen = [np.flatnonzero((cdist(p, _central_points(p, 60)) == 0).any(axis=1)) for p in (points, off)]
        np.testing.assert_array_equal(*chosen)


def test_the_kernel_width_comes_from_every_atom_or_from_an_even_spread_of_a_bounded_number(monkeypatch):
    import spotfree.classify.kcrc as kcrc

    rng = np.random.default_rng(3)
    atoms, labels = rng.normal(size=(200, 4)), np.repeat(["a", "b"], 100)
    every = KernelCRCClassifier(landmarks=8).fit(atoms, labels)
    assert every.gamma_ == pytest.approx(0.25 / np.median(pdist(atoms, "sqeuclidean")))
    monkeypatch.setattr(kcrc, "SPREAD_ATOMS", 50)
    spread = KernelCRCClassifier(landmarks=8).fit(atoms, labels)
    sample = atoms[np.linspace(0, 199, 50).round().astype(int)]
    assert spread.gamma_ == pytest.approx(0.25 / np.median(pdist(sample, "sqeuclidean")))
    assert spread.gamma_ != every.gamma_
