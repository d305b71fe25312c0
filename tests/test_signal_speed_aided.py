"""The speed-aided pitch filter: a steady braking stays visible in ``acc_long`` where ``acc_x`` fades."""

from __future__ import annotations

import numpy as np

from spotfree.io.recording import Recording
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS, FeatureStream, ride_features
from spotfree.signal.frame import vehicle_to_device_axes
from spotfree.units import GRAVITY

RATE = 20.0


def balanced_braking(n: int = 700, decel: float = 1.0, gps: bool = True, seed: int = 0) -> Recording:
    """A self-balancing vehicle: 10 s at 5 m/s, a 4 s braking at ``decel`` m/s^2 (0.5 s ramps), then 1 m/s.

    The handlebar leans back by ``atan(decel / g)`` so that the specific force stays on its z axis (no
    longitudinal force for the accelerometer), exactly what hides a steady braking from ``acc_x``.
    GPS speed once a second (noise 0.1 m/s) when ``gps``.
    """
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE
    ramp = np.clip((t - 10.0) / 0.5, 0, 1) - np.clip((t - 13.5) / 0.5, 0, 1)
    a = -decel * ramp
    speed = 5.0 + np.cumsum(a) / RATE
    pitch = np.arctan2(a, GRAVITY)  # positive nose down: accelerating leans forward
    cp, sp = np.cos(pitch), np.sin(pitch)
    acc = np.column_stack([cp * a - sp * GRAVITY, np.zeros(n), sp * a + cp * GRAVITY])
    gyr = np.column_stack([np.zeros(n), np.gradient(pitch, 1 / RATE), np.zeros(n)])
    acc += rng.normal(0, 0.05, acc.shape)
    gyr += rng.normal(0, 0.002, gyr.shape)
    channels = dict(zip(("ax", "ay", "az", "gx", "gy", "gz"),
                        np.column_stack([vehicle_to_device_axes(acc), vehicle_to_device_axes(gyr)]).T))
    if gps:
        fix = np.full(n, np.nan)
        fix[::20] = speed[::20] + rng.normal(0, 0.1, len(fix[::20]))
        channels["speed"] = fix
    return Recording(t, channels, RATE, source="balanced.csv", truth={"decel": a})


def test_steady_braking_is_seen_by_acc_long_and_fades_from_acc_x():
    rec = balanced_braking()
    feats = ride_features(rec, derived=True)
    plateau = (rec.time > 11.5) & (rec.time < 13.5)
    acc_long, acc_x = feats.channels["acc_long"][plateau], feats.channels["acc_x"][plateau]
    assert abs(np.median(acc_long) + 1.0) < 0.25, np.median(acc_long)
    assert abs(np.median(acc_x)) < 0.5 * abs(np.median(acc_long))
    cruise = (rec.time > 4.0) & (rec.time < 9.5)
    assert np.all(np.abs(feats.channels["acc_long"][cruise]) < 0.25)


def test_gps_brings_acc_long_back_to_zero_after_the_braking_faster_than_the_gyro_alone():
    rec = balanced_braking()
    after = (rec.time > 17.0) & (rec.time < 25.0)
    aided = ride_features(rec, derived=True).channels["acc_long"]
    alone = ride_features(balanced_braking(gps=False), derived=True).channels["acc_long"]
    assert np.all(np.isfinite(alone))
    assert np.max(np.abs(aided[after])) < 0.15
    assert np.max(np.abs(alone[after])) > 2 * np.max(np.abs(aided[after]))
    assert np.max(np.abs(alone[rec.time > 30.0])) < 0.15


def test_stream_with_gps_equals_batch():
    rec = balanced_braking(n=400)
    batch = ride_features(rec, derived=True).array(FEATURE_CHANNELS + DERIVED_CHANNELS)  # not the carried speed
    stream = FeatureStream(RATE, derived=True)
    acc, gyr, speed = rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"]), rec.channels["speed"]
    online = np.array([stream.update(a, w, s) for a, w, s in zip(acc, gyr, speed)])
    np.testing.assert_allclose(online, batch, atol=1e-12)
