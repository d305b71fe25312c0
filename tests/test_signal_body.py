"""Body channels of a raw IMU log: the rotation rate about the vertical whatever the device's orientation, to
either side, zero for a rotation about a horizontal axis, the to-and-fro rotation of a stride filtered out and a turn
kept, never above the rotation rate's norm times the low-pass's gain, causal, restarted after a gap, and a log too
slow for the low-passes refused."""

import numpy as np
import pytest
import scipy.signal
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.signal.body import ACC_BODY_CHANNELS, BODY_CHANNELS, TURN_CUTOFF, body_features, vertical_rotation
from spotfree.signal.butterworth import butter_lowpass

RATE = 20.0
TURN_GAIN = float(np.abs(scipy.signal.sosfilt(butter_lowpass(RATE, cutoff=TURN_CUTOFF, order=2),
                                              np.r_[1.0, np.zeros(4000)])).sum())
"""``sum |h|`` of the turning low-pass at :data:`RATE`: the most it amplifies a bounded input."""


def _log(acc: np.ndarray, gyro: np.ndarray) -> Recording:
    names = ("ax", "ay", "az", "gx", "gy", "gz")
    values = np.hstack([acc, gyro])
    return Recording(time=np.arange(len(values)) / RATE, channels=dict(zip(names, values.T)), rate=RATE,
                     source="test")


def _held(orientation: Rotation, n: int, about_vertical: float, about_horizontal: float) -> Recording:
    """A device held still in ``orientation`` (world to device) on a body that turns at ``about_vertical`` rad/s
    and sways at ``about_horizontal`` rad/s about a horizontal axis."""
    gravity = orientation.apply([0.0, 0.0, 9.81])
    rate = orientation.apply([about_horizontal, 0.0, about_vertical])
    return _log(np.tile(gravity, (n, 1)), np.tile(rate, (n, 1)))


def test_the_turning_rate_is_the_same_in_every_orientation_and_to_either_side():
    for seed in range(5):
        orientation = Rotation.random(random_state=seed)
        for turn in (1.5, -1.5):
            rec = _held(orientation, 60, turn, 2.0)
            np.testing.assert_allclose(vertical_rotation(rec), 1.5, atol=1e-9)
        np.testing.assert_allclose(vertical_rotation(_held(orientation, 60, 0.0, 2.0)), 0.0, atol=1e-9)


def test_a_stride_to_and_fro_is_filtered_out_and_a_turn_kept():
    """A device on a body that rotates to and fro about the vertical once a second (a stride), at 2 rad/s peak, and
    then also turns one way at 1 rad/s: the stride leaves less than a third of its peak, the turn comes through (the
    stride's rotation rectified unfiltered would average 4 / pi rad/s, more than the turn)."""
    orientation = Rotation.random(random_state=3)
    t = np.arange(400) / RATE
    about_vertical = 2.0 * np.sin(2 * np.pi * 1.0 * t) + np.where(t >= 10.0, 1.0, 0.0)
    gravity = np.tile(orientation.apply([0.0, 0.0, 9.81]), (len(t), 1))
    rate = orientation.apply(np.column_stack([np.zeros_like(t), np.zeros_like(t), about_vertical]))
    turning = vertical_rotation(_log(gravity, rate))
    settled = (t > 5.0) & (t < 10.0)
    assert turning[settled].max() < 0.3 * 2.0
    assert abs(turning[t > 15.0].mean() - 1.0) < 0.05
    assert turning[settled].mean() < 0.4


def test_body_features_hold_every_body_channel():
    rec = body_features(_held(Rotation.random(random_state=0), 40, 1.0, 0.5))
    assert rec.names == list(BODY_CHANNELS) and rec.meta["features"] == "body"


def test_a_log_without_a_gyroscope_gives_the_acceleration_channels():
    full = body_features(_held(Rotation.random(random_state=1), 40, 1.0, 0.5))
    acc_only = full.with_channels({c: full.channels[c] for c in ("ax", "ay", "az")})
    rec = body_features(acc_only)
    assert rec.names == list(ACC_BODY_CHANNELS) and rec.meta["features"] == "body"
    np.testing.assert_array_equal(rec.channels["acc_norm"], full.channels["acc_norm"])


def test_a_log_without_an_accelerometer_is_refused_naming_its_columns():
    rec = _log(np.zeros((40, 3)), np.zeros((40, 3)))
    gyro_only = rec.with_channels({c: rec.channels[c] for c in ("gx", "gy", "gz")})
    with pytest.raises(InputError, match="accelerometer's columns ax, ay, az.*the log has gx, gy, gz"):
        body_features(gyro_only)


def test_causal_and_restarted_after_a_gap():
    rng = np.random.default_rng(0)
    acc, gyro = rng.normal(0, 3, (200, 3)) + [0, 0, 9.81], rng.normal(0, 1, (200, 3))
    whole = vertical_rotation(_log(acc, gyro))
    np.testing.assert_array_equal(vertical_rotation(_log(acc[:120], gyro[:120])), whole[:120])  # causal
    acc[100:110] = np.nan
    gapped = vertical_rotation(_log(acc, gyro))
    assert np.isnan(gapped[100:110]).all()
    np.testing.assert_array_equal(gapped[:100], whole[:100])
    np.testing.assert_allclose(gapped[110:], vertical_rotation(_log(acc[110:], gyro[110:])), rtol=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.lists(st.tuples(*[st.floats(-50, 50)] * 6), min_size=1, max_size=60))
def test_never_above_the_norm_of_the_rotation_rate_times_the_gain_of_the_low_pass(rows):
    values = np.array(rows)
    rec = _log(values[:, :3], values[:, 3:])
    turning = vertical_rotation(rec)
    largest = np.maximum.accumulate(np.linalg.norm(values[:, 3:], axis=1))
    assert np.all(turning >= 0) and np.all(turning <= TURN_GAIN * largest * (1 + 1e-9) + 1e-12)


@pytest.mark.parametrize("rate", [0.2, 0.8])  # too slow for the gravity low-pass; for the turning low-pass only
def test_a_log_too_slow_for_the_low_passes_is_a_clear_error(rate):
    slow = Recording(time=np.arange(5) / rate, channels={c: np.ones(5) for c in ("ax", "ay", "az", "gx", "gy", "gz")},
                     rate=rate, source="slow.csv")
    with pytest.raises(InputError, match="needs a sampling rate above .* resample"):
        body_features(slow)
