import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.windows import (
    ChannelScaling,
    block_hankel,
    normalise_columns,
    recording_windows,
    window_ends,
    with_affine_row,
)


def test_block_hankel_columns_are_stacked_channel_windows():
    x = np.column_stack([np.arange(10.0), 100 + np.arange(10.0)])
    h = block_hankel(x, length=4, step=3)
    assert h.shape == (8, 3)
    np.testing.assert_array_equal(h[:, 0], [0, 1, 2, 3, 100, 101, 102, 103])
    np.testing.assert_array_equal(h[:, 2], [6, 7, 8, 9, 106, 107, 108, 109])
    np.testing.assert_array_equal(window_ends(10, 4, 3), [3, 6, 9])


def test_block_hankel_neighbouring_columns_are_shifts():
    x = np.random.default_rng(0).normal(size=(50, 3))
    h = block_hankel(x, length=5)
    for c in range(3):
        block = h[c * 5:(c + 1) * 5]
        np.testing.assert_array_equal(block[1:, :-1], block[:-1, 1:])


def test_shorter_than_a_window_gives_no_column():
    assert block_hankel(np.zeros((3, 2)), length=4).shape == (8, 0)


def test_unit_normalisation_discards_amplitude_and_scale_keeps_it():
    w = np.array([[1.0, 10.0], [0.0, 0.0]])
    np.testing.assert_allclose(normalise_columns(w, "unit"), [[1, 1], [0, 0]])
    np.testing.assert_array_equal(normalise_columns(w, "scale"), w)
    with pytest.raises(InputError, match="unknown window normalisation"):
        normalise_columns(w, "zscore")


def _rec(values, experiment=None):
    n = len(values)
    return Recording(time=np.arange(n) / 20.0, channels={"a": values, "b": 2 * values}, rate=20.0,
                     experiment=experiment)


def test_windows_never_span_gaps_or_experiments():
    values = np.arange(30.0)
    values[10] = np.nan
    experiment = np.r_[np.ones(20, int), 2 * np.ones(10, int)]
    w = recording_windows(_rec(values, experiment), ("a", "b"), length=4)
    # segments: 0..9 (7 windows), 11..19 (6 windows), 20..29 (7 windows)
    assert w.matrix.shape == (8, 20)
    assert np.isfinite(w.matrix).all()
    np.testing.assert_array_equal(w.experiment, np.r_[np.ones(13, int), 2 * np.ones(7, int)])
    assert 10 not in w.ends and 20 + 2 not in w.ends


def test_recording_shorter_than_window_is_a_clear_error():
    with pytest.raises(InputError, match="shorter --window"):
        recording_windows(_rec(np.arange(3.0)), ("a",), length=10)


def test_channel_scaling_learns_std_and_rejects_constant_channels():
    rng = np.random.default_rng(1)
    rec = Recording(time=np.arange(100) / 20, channels={"a": rng.normal(0, 2, 100), "b": rng.normal(0, 0.1, 100)},
                    rate=20.0)
    scaling = ChannelScaling(("a", "b")).fit([rec])
    np.testing.assert_allclose(scaling.transform(rec.array(["a", "b"])).std(axis=0), 1.0)
    flat = Recording(time=np.arange(100) / 20, channels={"a": rng.normal(size=100), "b": np.ones(100)}, rate=20.0)
    with pytest.raises(InputError, match="constant"):
        ChannelScaling(("a", "b")).fit([flat])


def test_affine_row_breaks_the_sign_symmetry():
    w = np.random.default_rng(1).normal(size=(6, 4))
    np.testing.assert_array_equal(with_affine_row(w, 0.0), w)
    a = with_affine_row(w, 2.0)
    assert a.shape == (7, 4)
    np.testing.assert_array_equal(a[:6], w)
    np.testing.assert_array_equal(a[6], 2.0)
    # -y is a multiple of y, but [-y; c] is not a multiple of [y; c]
    pair = np.column_stack([with_affine_row(w[:, :1], 2.0), with_affine_row(-w[:, :1], 2.0)])
    assert np.linalg.matrix_rank(pair) == 2
