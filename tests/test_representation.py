import numpy as np
import pytest

from spotfree.representation import band_edges, represent, representation_size


def _numpy_summary(x: np.ndarray) -> np.ndarray:
    """The ``summary`` of one channel's window, written out with numpy (the representation's docstring)."""
    length, half = len(x), len(x) // 2
    older, newer = x[:half], x[length - half:]
    spectrum = np.fft.rfft(np.hanning(length + 2)[1:-1] * (x - x.mean()))
    edges = band_edges(length)
    power = [np.log1p(np.sum(np.abs(spectrum[a:b]) ** 2) / length) for a, b in zip(edges[:-1], edges[1:])]
    return np.r_[x.mean(), x.std(), x.min(), x.max(), newer.mean() - older.mean(), newer.std() - older.std(), power]


@pytest.mark.parametrize("length", [7, 20])
def test_summary_is_level_spread_their_change_and_band_powers(length):
    rng = np.random.default_rng(length)
    channels = rng.normal(size=(2, length)) * [[1.0], [3.0]] + [[0.0], [2.0]]
    rows = represent(channels.reshape(-1, 1), 2, "summary")
    assert rows.shape == (1, representation_size(2, length, "summary"))
    np.testing.assert_allclose(rows[0], np.r_[_numpy_summary(channels[0]), _numpy_summary(channels[1])], atol=1e-9)


def test_only_the_change_features_see_the_order_of_the_samples():
    """A window that leaves one level and spread for another differs from the one that enters it (reversed in
    time) in the sign of its two changes, and in nothing else."""
    x = np.r_[np.full(10, 0.0), 2.0 + np.sin(np.arange(10.0))]  # still, then moving at a higher level
    forward, backward = represent(np.c_[x, x[::-1]], 1, "summary")
    change = [4, 5]
    assert forward[4] > 1.5 and forward[5] > 0.5
    np.testing.assert_allclose(backward[change], -forward[change])
    np.testing.assert_allclose(np.delete(backward, change), np.delete(forward, change), atol=1e-9)


def test_a_window_of_one_sample_has_no_change():
    row = represent(np.array([[3.0]]), 1, "summary")[0]
    np.testing.assert_array_equal(row, [3.0, 0.0, 3.0, 3.0, 0.0, 0.0])
