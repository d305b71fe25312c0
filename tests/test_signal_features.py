"""Ride features: channels, frames and signs, gaps and experiments, streaming = batch, input errors."""

import sys

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.signal.features import (
    DERIVED_CHANNELS,
    FEATURE_CHANNELS,
    LEAN_BIAS_TIME_CONSTANT,
    LEAN_TIME_CONSTANT,
    NO_SPEED_NOTE,
    ROUGH_SPEED,
    VIB_TIME_CONSTANT,
    FeatureStream,
    lean_coefficients,
    ride_features,
)
from spotfree.signal.frame import gravity_direction, vehicle_to_device_axes
from spotfree.signal.orientation import ORIENTATIONS
from spotfree.signal.recursions import FEATURE_WIDTH, ride_features_block
from spotfree.units import GRAVITY

RATE = 20.0


def device_recording(acc_vehicle, gyr_vehicle, experiment=None, truth=None, source="ride.csv") -> Recording:
    """A Recording of raw device-frame IMU channels from vehicle-axis specific force and rates."""
    acc = vehicle_to_device_axes(acc_vehicle)
    gyr = vehicle_to_device_axes(gyr_vehicle)
    n = len(acc)
    names = ("ax", "ay", "az", "gx", "gy", "gz")
    channels = dict(zip(names, np.column_stack([acc, gyr]).T))
    return Recording(np.arange(n) / RATE, channels, RATE, source=source, experiment=experiment, truth=truth or {})


def braking_ride(seed: int = 0, n: int = 600, brake: float = 2.0):
    """Vehicle-axis IMU of a handlebar that pitches nose-down while the vehicle brakes (positive pitch rate)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    pitch = 0.08 * np.sin(2 * np.pi * t / 6.0) ** 2  # nose down up to 4.6 deg and back, repeatedly
    roll = 0.03 * np.sin(2 * np.pi * t / 9.0)
    decel = -brake * np.sin(2 * np.pi * t / 6.0) ** 2  # level-frame x acceleration, m/s^2, in step with the pitch
    # specific force in body axes: R^T (a_level + g z), R = R_y(pitch) R_x(roll)
    cr, sr, cp, sp = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch)
    fx, fz = decel, np.full(n, GRAVITY)
    acc = np.column_stack([cp * fx - sp * fz, sr * (sp * fx + cp * fz), cr * (sp * fx + cp * fz)])
    gyr = np.column_stack([np.gradient(roll, 1 / RATE), np.gradient(pitch, 1 / RATE), np.zeros(n)])
    acc += rng.normal(0, 0.02, acc.shape)
    return acc, gyr, roll, pitch, decel


def test_channels_grid_experiment_and_truth_are_kept():
    acc, gyr, *_ = braking_ride(n=100)
    exp = np.repeat([1, 2], 50)
    rec = device_recording(acc, gyr, experiment=exp, truth={"label": np.array(["cruising"] * 100)})
    feats = ride_features(rec)
    assert tuple(feats.names) == FEATURE_CHANNELS
    np.testing.assert_array_equal(feats.time, rec.time)
    np.testing.assert_array_equal(feats.experiment, exp)
    np.testing.assert_array_equal(feats.truth["label"], rec.truth["label"])
    assert feats.rate == RATE


def test_static_tilted_handlebar_gives_its_angles_and_no_acceleration():
    n = 200
    roll, pitch = np.radians(4.0), np.radians(6.0)
    acc = np.tile(GRAVITY * gravity_direction(np.array([roll]), np.array([pitch])), (n, 1))
    for orientation in ("default", "paper"):
        feats = ride_features(device_recording(acc, np.zeros((n, 3))), orientation=orientation)
        np.testing.assert_allclose(feats.channels["roll"], roll, atol=1e-9)
        np.testing.assert_allclose(feats.channels["pitch"], pitch, atol=1e-9)
        for c in ("acc_x", "acc_y", "acc_z", "pitch_rate"):
            np.testing.assert_allclose(feats.channels[c], 0.0, atol=1e-9)


def test_braking_signs_nose_down_pitch_and_negative_acc_x():
    acc, gyr, roll, pitch, _ = braking_ride(brake=0.0)
    ch = ride_features(device_recording(acc, gyr)).channels
    np.testing.assert_allclose(ch["pitch_rate"], gyr[:, 1], atol=1e-12)  # about vehicle y, nose down positive
    assert np.corrcoef(ch["pitch"], pitch)[0, 1] > 0.99
    assert np.corrcoef(ch["roll"], roll)[0, 1] > 0.99
    acc, gyr, roll, pitch, decel = braking_ride(brake=2.0)
    ch = ride_features(device_recording(acc, gyr), zero_phase=True).channels
    assert np.corrcoef(ch["acc_x"], decel)[0, 1] > 0.9
    # a sustained deceleration tilts the specific force like a nose-up pitch; the filter attributes part of it
    # to attitude over its ~3 s time constant (measured: -0.94 m/s^2 where the truth is below -1.5)
    assert np.mean(ch["acc_x"][decel < -1.5]) < -0.7
    assert np.max(np.abs(ch["acc_z"][50:])) < 0.3


def test_gaps_are_nan_and_each_segment_starts_fresh():
    acc, gyr, *_ = braking_ride(n=300)
    rec = device_recording(acc, gyr)
    holed = rec.with_channels({k: v.copy() for k, v in rec.channels.items()})
    holed.channels["ax"][100:120] = np.nan
    feats = ride_features(holed).array(FEATURE_CHANNELS)
    assert np.all(np.isnan(feats[100:120]))
    first = ride_features(rec.take(slice(0, 100))).array(FEATURE_CHANNELS)
    second = ride_features(rec.take(slice(120, 300))).array(FEATURE_CHANNELS)
    np.testing.assert_allclose(feats[:100], first, atol=1e-12)
    np.testing.assert_allclose(feats[120:], second, atol=1e-12)


def test_experiments_are_separate_segments():
    acc, gyr, *_ = braking_ride(n=200)
    exp = np.repeat([1, 2], 100)
    feats = ride_features(device_recording(acc, gyr, experiment=exp)).array(FEATURE_CHANNELS)
    alone = ride_features(device_recording(acc[100:], gyr[100:])).array(FEATURE_CHANNELS)
    np.testing.assert_allclose(feats[100:], alone, atol=1e-12)


@pytest.mark.parametrize("orientation", ORIENTATIONS)
def test_stream_equals_causal_batch(orientation):
    if orientation == "vqf":
        pytest.importorskip("vqf")
    acc, gyr, *_ = braking_ride(seed=5, n=400)
    rec = device_recording(acc, gyr)
    batch = ride_features(rec, orientation=orientation).array(FEATURE_CHANNELS)
    stream = FeatureStream(RATE, orientation=orientation)
    dev_acc, dev_gyr = rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"])
    online = np.array([stream.update(a, w) for a, w in zip(dev_acc, dev_gyr)])
    np.testing.assert_allclose(online, batch, rtol=0, atol=1e-12)
    stream.reset()
    np.testing.assert_allclose(stream.update(dev_acc[0], dev_gyr[0]), batch[0], atol=1e-12)
    stream.reset()
    rows = np.column_stack([dev_acc, dev_gyr, np.full(len(dev_acc), np.nan)])
    blocks = np.vstack([stream.update_block(rows[k:k + 9]) for k in range(0, len(rows), 9)])
    np.testing.assert_array_equal(blocks, online)


def test_zero_phase_changes_only_the_accelerations():
    acc, gyr, *_ = braking_ride(n=300)
    rec = device_recording(acc, gyr)
    causal, offline = ride_features(rec), ride_features(rec, zero_phase=True)
    for c in ("roll", "pitch", "pitch_rate"):
        np.testing.assert_array_equal(causal.channels[c], offline.channels[c])
    assert not np.allclose(causal.channels["acc_x"], offline.channels["acc_x"])


def test_missing_imu_columns_name_what_is_needed():
    rec = Recording(np.arange(10) / RATE, {"ax": np.zeros(10), "ay": np.zeros(10)}, RATE, source="log.csv")
    with pytest.raises(InputError) as info:
        ride_features(rec)
    message = str(info.value)
    assert "log.csv" in message and "az, gx, gy, gz" in message and "ax ay az" in message and "gx gy gz" in message
    assert "\n" not in message


def test_unknown_orientation_and_missing_vqf(monkeypatch):
    acc, gyr, *_ = braking_ride(n=20)
    rec = device_recording(acc, gyr)
    with pytest.raises(InputError, match="default, paper, vqf"):
        ride_features(rec, orientation="madgwick")
    monkeypatch.setitem(sys.modules, "vqf", None)
    with pytest.raises(InputError, match="pip install vqf"):
        ride_features(rec, orientation="vqf")


def test_derived_lean_is_the_leaky_integral_of_pitch_rate_and_follows_a_held_lean():
    n = 400
    t = np.arange(n) / RATE
    lean_true = np.where((t > 5) & (t < 15), -0.2, 0.0)  # rad, held back lean (braking) for 10 s
    q = np.gradient(lean_true, 1 / RATE)
    acc = np.tile([0.0, 0.0, GRAVITY], (n, 1))  # the accelerometer sees no lean (balanced vehicle)
    feats = ride_features(device_recording(acc, np.column_stack([np.zeros(n), q, np.zeros(n)])), derived=True)
    assert tuple(feats.names) == FEATURE_CHANNELS + DERIVED_CHANNELS
    assert len(feats.names) == FEATURE_WIDTH
    lean = feats.array(["lean"])[:, 0]
    b, a, c = lean_coefficients(RATE)
    expected, bias = np.zeros(n), np.zeros(n)
    for k in range(n):
        bias[k] = (c * bias[k - 1] if k else 0.0) + (1 - c) * q[k]
        expected[k] = (a * expected[k - 1] if k else 0.0) + b * (q[k] - bias[k])
    np.testing.assert_allclose(lean, expected, atol=1e-12)
    # 2 s into the held lean: the step response of the two high-passes, (p1 e^-p1 t - p2 e^-p2 t) / (p1 - p2)
    p1, p2, i = 1 / LEAN_TIME_CONSTANT, 1 / LEAN_BIAS_TIME_CONSTANT, int(7.0 * RATE)
    kept = (p1 * np.exp(-2.0 * p1) - p2 * np.exp(-2.0 * p2)) / (p1 - p2)
    assert lean[i] == pytest.approx(-0.2 * kept, rel=0.03)


def test_derived_lean_forgets_a_constant_gyro_bias():
    n, bias = 2400, 0.01  # rad/s, 2 minutes
    acc = np.tile([0.0, 0.0, GRAVITY], (n, 1))
    gyr = np.column_stack([np.zeros(n), np.full(n, bias), np.zeros(n)])
    lean = ride_features(device_recording(acc, gyr), derived=True).array(["lean"])[:, 0]
    assert abs(lean[-1]) < 0.1 * bias * LEAN_TIME_CONSTANT


def test_derived_rates_are_the_vehicle_gyro_and_vibration_is_the_rms_the_lowpass_removes():
    n = 400
    t = np.arange(n) / RATE
    heave = 2.0 * np.sin(2 * np.pi * 8.0 * t)  # m/s^2 at 8 Hz, far above the 3 Hz low-pass
    acc = np.column_stack([np.zeros(n), np.zeros(n), GRAVITY + np.where(t >= 10.0, heave, 0.0)])
    turning = np.column_stack([0.3 * np.sin(t), np.zeros(n), -0.2 * np.ones(n)])
    rates = ride_features(device_recording(acc, turning), derived=True).array(["roll_rate", "yaw_rate"])
    np.testing.assert_allclose(rates, turning[:, [0, 2]], atol=1e-12)
    vib = ride_features(device_recording(acc, np.zeros((n, 3))), derived=True).array(["vib_x", "vib_y", "vib_z"])
    calm, shaken = t < 10.0, t >= 10.0 + 5 * VIB_TIME_CONSTANT
    assert np.all(vib[calm] < 0.02)  # only the attitude filter's own ripple
    # the low-pass passes almost nothing at 8 Hz, so the RMS of the residual is the heave's, 2 / sqrt(2)
    assert np.median(vib[shaken, 2]) == pytest.approx(np.sqrt(2.0), rel=0.1)
    assert np.all(vib[shaken, :2] < 0.2 * vib[shaken, 2:])


@pytest.mark.parametrize("speed", [None, 4.0, 20.0])
def test_roughness_is_the_vibration_over_the_root_of_the_held_speed(speed):
    n = 400
    t = np.arange(n) / RATE
    acc = np.column_stack([np.zeros(n), np.zeros(n), GRAVITY + 2.0 * np.sin(2 * np.pi * 8.0 * t)])
    rec = device_recording(acc, np.zeros((n, 3)))
    if speed is not None:  # a 1 Hz GPS fix of a steady ride
        rec = rec.with_channels({**rec.channels, "speed": np.where(np.arange(n) % 20 == 0, speed, np.nan)})
    stream = FeatureStream(RATE, derived=True)
    streamed = np.array([stream.update(a, w, v) for a, w, v in zip(
        rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"]),
        rec.channels.get("speed", np.full(n, np.nan)))])
    feats = ride_features(rec, derived=True)
    vib, rough = feats.array(["vib_x", "vib_y", "vib_z"]), feats.array(["rough_x", "rough_y", "rough_z"])
    held = 1.0 if speed is None else min(speed, ROUGH_SPEED[1])  # no fix: the speed stays near 0, held to 1 m/s
    np.testing.assert_allclose(rough * np.sqrt(held), vib, rtol=1e-3, atol=1e-9)
    np.testing.assert_allclose(streamed, feats.array(FEATURE_CHANNELS + DERIVED_CHANNELS), atol=1e-12)
    if speed is not None:  # carried as it is, for the ride prior (spotfree.ride_prior.RidePrior)
        np.testing.assert_array_equal(feats.channels["speed"], rec.channels["speed"])
        assert tuple(feats.names) == FEATURE_CHANNELS + DERIVED_CHANNELS + ("speed",)


def test_roughness_never_divides_by_a_speed_no_gps_fix_measured():
    """Without a GPS speed the speed-aided filter's speed is the integrated acceleration (here 0.5 m/s^2 forward for
    20 s, far past 1 m/s): the road channels are then the vibration itself, batch and stream, and a note says so;
    from the first fix on they are normalised by the speed."""
    n = 400
    t = np.arange(n) / RATE
    acc = np.column_stack([np.full(n, 0.5), np.zeros(n), GRAVITY + 2.0 * np.sin(2 * np.pi * 8.0 * t)])
    rec = device_recording(acc, np.zeros((n, 3)), source="no-gps.csv")
    feats = ride_features(rec, derived=True)
    levels = ("vib_x", "vib_y", "vib_z")
    assert np.array_equal(feats.array(["rough_x", "rough_y", "rough_z"]), feats.array(levels))
    assert rec.meta["repairs"] == [f"no-gps.csv: {NO_SPEED_NOTE}"]
    ride_features(rec, derived=True)
    assert len(rec.meta["repairs"]) == 1  # said once per log
    fix = 200
    gps = device_recording(acc, np.zeros((n, 3)))
    gps.channels["speed"] = np.where(np.arange(n) == fix, 4.0, np.nan)
    stream = FeatureStream(RATE, derived=True)
    streamed = np.array([stream.update(a, w, v) for a, w, v in zip(
        gps.array(["ax", "ay", "az"]), gps.array(["gx", "gy", "gz"]), gps.channels["speed"])])
    feats = ride_features(gps, derived=True)
    rough, vib = feats.array(["rough_x", "rough_y", "rough_z"]), feats.array(levels)
    assert np.array_equal(rough[:fix], vib[:fix]) and np.all(rough[fix:, 2] < vib[fix:, 2])
    np.testing.assert_allclose(streamed, feats.array(FEATURE_CHANNELS + DERIVED_CHANNELS), atol=1e-12)
    assert "repairs" not in gps.meta


def test_stream_with_derived_channels_equals_batch_and_keeps_six_by_default():
    acc, gyr, *_ = braking_ride(n=300)
    rec = device_recording(acc, gyr)
    batch = ride_features(rec, derived=True).array()
    plain, derived = FeatureStream(RATE), FeatureStream(RATE, derived=True)
    six = np.array([plain.update(a, w) for a, w in zip(rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"]))])
    raw = list(zip(rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"])))
    seven = np.array([derived.update(a, w) for a, w in raw])
    assert six.shape == (300, 6) and seven.shape == (300, 6 + len(DERIVED_CHANNELS))
    np.testing.assert_allclose(seven, batch, atol=1e-12)
    np.testing.assert_array_equal(six, seven[:, :6])
    derived.reset()
    np.testing.assert_allclose(derived.update(rec.array(["ax", "ay", "az"])[0], rec.array(["gx", "gy", "gz"])[0]),
                               batch[0], atol=1e-12)


def test_compiled_features_refuse_an_output_too_short_for_every_channel():
    stream = FeatureStream(RATE, derived=True)
    with pytest.raises(ValueError, match="16 values"):
        stream.step(0.0, GRAVITY, 0.0, 0.0, 0.0, 0.0, float("nan"), np.zeros(13))
    with pytest.raises(ValueError, match="16 values"):
        ride_features_block(stream.parameters_, stream.state_, True, np.zeros((3, 7)), np.arange(7),
                            np.zeros((3, 13)))
