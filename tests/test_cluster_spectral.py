"""Normalized cuts and the eigengap estimate on precomputed affinities."""

import numpy as np
import pytest
import scipy.sparse
from sklearn.cluster import SpectralClustering
from sklearn.metrics import adjusted_rand_score

from spotfree.cluster import spectral
from spotfree.cluster.spectral import estimate_n_clusters, laplacian_spectrum, normalized_cuts
from spotfree.errors import InputError


def block_affinity(sizes, within=1.0, between=0.02, seed=0):
    """Symmetric affinity with dense random blocks on the diagonal and weak random links between them."""
    rng = np.random.default_rng(seed)
    labels = np.repeat(np.arange(len(sizes)), sizes)
    n = labels.size
    W = rng.uniform(0.0, between, (n, n))
    same = labels[:, None] == labels[None, :]
    W[same] = rng.uniform(0.2 * within, within, same.sum())
    W = W + W.T
    np.fill_diagonal(W, 0.0)
    return W, labels


@pytest.fixture(params=["dense", "lanczos"])
def solver(request, monkeypatch):
    """Run each test through the dense eigensolver and through the Lanczos one (as for large n)."""
    if request.param == "lanczos":
        monkeypatch.setattr(spectral, "DENSE_LIMIT", 10)
    return request.param


def test_recovers_blocks_and_agrees_with_scikit_learn(solver):
    W, truth = block_affinity([40, 25, 60])
    labels = normalized_cuts(W, 3, random_state=0)
    assert adjusted_rand_score(truth, labels) == 1.0
    reference = SpectralClustering(3, affinity="precomputed", random_state=0).fit_predict(W)
    assert adjusted_rand_score(reference, labels) == 1.0


def test_sparse_affinity_gives_same_labels(solver):
    W, _ = block_affinity([30, 30, 30], seed=1)
    W[W < 0.05] = 0.0
    dense = normalized_cuts(W, 3, random_state=0)
    sparse = normalized_cuts(scipy.sparse.csr_matrix(W), 3, random_state=0)
    np.testing.assert_array_equal(dense, sparse)


def test_same_seed_same_labels(solver):
    W, _ = block_affinity([30, 30, 30, 30], between=0.3, seed=2)
    np.testing.assert_array_equal(normalized_cuts(W, 4, random_state=5), normalized_cuts(W, 4, random_state=5))


def test_laplacian_spectrum_matches_dense_formula(solver):
    W, _ = block_affinity([20, 30, 25], seed=3)
    d = W.sum(axis=1)
    L = np.eye(len(d)) - W / np.sqrt(np.outer(d, d))
    expected = np.linalg.eigvalsh(L)[:5]
    np.testing.assert_allclose(laplacian_spectrum(W, 5, random_state=0), expected, atol=1e-8)


@pytest.mark.parametrize("k", [2, 3, 5])
def test_eigengap_finds_the_number_of_blocks(k, solver):
    W, _ = block_affinity([25 + 5 * i for i in range(k)], seed=k)
    assert estimate_n_clusters(W, max_clusters=8, random_state=0) == k


def test_integer_affinity(solver):
    W, truth = block_affinity([30, 40], between=0.0)
    labels = normalized_cuts((W > 0).astype(int), 2, random_state=0)
    assert adjusted_rand_score(truth, labels) == 1.0


def test_one_cluster_and_degenerate_sizes():
    W, _ = block_affinity([10, 10])
    np.testing.assert_array_equal(normalized_cuts(W, 1), np.zeros(20, dtype=int))
    assert estimate_n_clusters(W[:2, :2]) == 2


@pytest.mark.parametrize(
    "W, match",
    [
        (np.ones((3, 4)), "square"),
        (-np.ones((3, 3)), "non-negative"),
        (np.full((3, 3), np.nan), "finite"),
    ],
)
def test_bad_affinity(W, match):
    with pytest.raises(InputError, match=match):
        normalized_cuts(W, 2)


def test_too_many_clusters():
    W, _ = block_affinity([3, 3])
    with pytest.raises(InputError, match="n_clusters=7"):
        normalized_cuts(W, 7)
