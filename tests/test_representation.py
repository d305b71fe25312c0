import numpy as np
import pytest

from spotfree.representation import BLOCKS, band_edges, represent, representation_size


def _numpy_summary(x: np.ndarray) -> np.ndarray:
    """The ``summary`` of one channel's window, written out with numpy (the representation's docstring)."""
    length, half = len(x), len(x) // 2
    older, newer = x[:half], x[length - half:]
    blocks = min(BLOCKS, length)
    block = np.arange(length) * blocks // length
    course = [x[block == k].mean() - x.mean() for k in range(blocks)]
    spectrum = np.fft.rfft(np.hanning(length + 2)[1:-1] * (x - x.mean()))
    edges = band_edges(length)
    power = [np.log1p(np.sum(np.abs(spectrum[a:b]) ** 2) / length) for a, b in zip(edges[:-1], edges[1:])]
    return np.r_[x.mean(), x.std(), x.min(), x.max(), course, newer.std() - older.std(), power]


@pytest.mark.parametrize("length", [3, 7, 10, 20])
def test_summary_is_level_spread_course_change_and_band_powers(length):
    rng = np.random.default_rng(length)
    channels = rng.normal(size=(2, length)) * [[1.0], [3.0]] + [[0.0], [2.0]]
    rows = represent(channels.reshape(-1, 1), 2, "summary")
    assert rows.shape == (1, representation_size(2, length, "summary"))
    np.testing.assert_allclose(rows[0], np.r_[_numpy_summary(channels[0]), _numpy_summary(channels[1])], atol=1e-9)


def test_only_the_course_and_the_change_see_the_order_of_the_samples():
    """A window that leaves one level and spread for another differs from the one that enters it (reversed in
    time) in its course (the blocks' deviations in reverse order) and the sign of its change of spread, and in
    nothing else."""
    x = np.r_[np.full(10, 0.0), 2.0 + np.sin(np.arange(10.0))]  # still, then moving at a higher level
    forward, backward = represent(np.c_[x, x[::-1]], 1, "summary")
    course, change = list(range(4, 4 + BLOCKS)), 4 + BLOCKS
    assert forward[course[0]] < -0.9 < 0.9 < forward[course[-1]] and forward[change] > 0.5
    np.testing.assert_allclose(backward[course], forward[course][::-1], atol=1e-9)
    np.testing.assert_allclose(backward[change], -forward[change])
    np.testing.assert_allclose(np.delete(backward, course + [change]), np.delete(forward, course + [change]),
                               atol=1e-9)


def test_the_course_places_a_short_movement_inside_the_window():
    """A short bump in the first, the third or the last quarter of the window raises that block: the two late ones,
    whose halves have the same means and spreads (both bumps inside the newer half), are told apart."""
    courses = {}
    for start in (1, 10, 15):
        x = np.zeros(20)
        x[start:start + 4] = 1.0
        courses[start] = represent(x[:, None], 1, "summary")[0, 4:4 + BLOCKS]
        assert int(np.argmax(courses[start])) == start // 5
        np.testing.assert_allclose(courses[start].sum(), 0.0, atol=1e-12)  # blocks of equal length
    assert np.abs(courses[10] - courses[15]).max() > 0.15


def test_a_window_of_one_sample_has_no_change():
    row = represent(np.array([[3.0]]), 1, "summary")[0]
    np.testing.assert_array_equal(row, [3.0, 0.0, 3.0, 3.0, 0.0, 0.0])
