"""Building blocks of the ride simulator: pendulum, steering, road, plans, sensor and GPS models."""

import numpy as np
import pytest
from scipy.signal import welch

from spotfree.signal.frame import accel_roll_pitch, device_to_vehicle_axes
from spotfree.sim.gps import local_to_geodetic
from spotfree.sim.imu import ImuSpec, read_imu
from spotfree.sim.manoeuvres import Plan, iso8608_profile, raised_cosine_step
from spotfree.sim.vehicle import Road, RiderBody, Vehicle, simulate_motion
from spotfree.units import GRAVITY

FS = 200.0
BODY = RiderBody(com_height=0.85, balance_freq=1.0, balance_damping=0.9, lean_to_pitch=0.7, counter_pitch=0.2,
                 rest_pitch=0.0)
QUIET = Vehicle(motor_ripple=0.0)


def flat_road(distance):
    n = int(distance[-1] / 0.01) + 10
    return Road(dx=0.01, height=np.zeros((n, 2)), strike=np.zeros(n), surface=np.zeros(n, dtype=int),
                names=("smooth",))


def ride(accel, yaw=None, seconds=None):
    time = np.arange(len(accel)) / FS
    yaw = np.zeros_like(accel) if yaw is None else yaw
    return simulate_motion(time, accel, yaw, BODY, QUIET, flat_road, np.random.default_rng(0))


def test_steady_acceleration_leans_by_atan_a_over_g():
    a = 0.8
    command = a * raised_cosine_step(np.arange(0, 12, 1 / FS) - 1.0)
    m = ride(command)
    late = slice(int(8 * FS), None)
    np.testing.assert_allclose(m.lean_accel[late], a, atol=1e-3)
    np.testing.assert_allclose(m.accel[late], a, atol=1e-3)
    np.testing.assert_allclose(m.pitch[late], BODY.lean_to_pitch * np.arctan(a / GRAVITY), atol=1e-4)
    np.testing.assert_allclose(np.diff(m.speed[late]) * FS, a, atol=1e-2)
    # the tablet's specific force on handlebar axes: gravity and the acceleration, seen through the pitch
    theta = m.pitch[late]
    np.testing.assert_allclose(m.specific_force[late, 0], a * np.cos(theta) - GRAVITY * np.sin(theta), atol=1e-3)


def test_braking_starts_with_the_inverted_pendulum_surge():
    t = np.arange(0, 10, 1 / FS)
    command = 1.0 * raised_cosine_step((t - 0.5) / 0.5) - 3.0 * raised_cosine_step((t - 5.0) / 0.3)  # +1, then -2
    m = ride(command)
    before = (t > 4.6) & (t < 5.6)
    assert m.accel[before].max() > 1.3  # a brief surge above the 1 m/s^2 being held before the braking
    assert m.accel[(t > 6.5) & (t < 7.5)].mean() == pytest.approx(-2.0, abs=0.01)
    first_rise = np.argmax(m.pitch[before] > m.pitch[(t > 4.0) & (t < 4.5)].mean() + 1e-3)
    first_drop = np.argmax(m.pitch[before] < m.pitch[(t > 4.0) & (t < 4.5)].mean() - 1e-3)
    assert first_rise < first_drop  # counter-pitch forward before pitching back


def test_left_turn_tilts_the_handlebar_left_and_pulls_left():
    t = np.arange(0, 14, 1 / FS)
    command = 0.8 * raised_cosine_step((t - 0.5) / 1.0) - 0.8 * raised_cosine_step((t - 4.5) / 1.0)
    yaw = 0.4 * raised_cosine_step((t - 7.0) / 1.0)
    m = ride(command, yaw)
    late = t > 10.0
    v = m.speed[late].mean()
    assert v == pytest.approx(3.2, abs=0.05)
    assert np.all(m.roll[late] < 0)  # left side down
    level = m.specific_force[late, 1] * np.cos(m.roll[late]) - m.specific_force[late, 2] * np.sin(m.roll[late])
    # centripetal at the tablet, which leans l sin(phi) towards the centre of the turn
    np.testing.assert_allclose(level, v * 0.4 + 0.4**2 * QUIET.tablet_height * np.sin(m.roll[late]), atol=2e-3)
    heading = m.heading[-1] - m.heading[int(7 * FS)]
    assert heading == pytest.approx(0.4 * (t[-1] - 7.5), abs=0.02)


def test_plan_stops_exactly_and_never_reverses():
    plan = Plan()
    plan.wait(1.0)
    plan.change_speed(4.5, 0.8, 0.8)
    plan.wait(2.0)
    plan.brake([(1.0, 0.5), (3.0, 3.4), (1.2, 0.6)], [0.2, 0.3, 0.3, 0.5])
    plan.wait(2.0)
    programme = plan.programme(FS, np.random.default_rng(1))
    assert plan.v == 0.0
    assert programme.speed.max() == pytest.approx(4.5, abs=1e-6)
    assert programme.speed.min() > -1e-6  # integration round-off only
    assert abs(programme.speed[-1]) < 1e-6
    assert -programme.accel.min() == pytest.approx(3.0, abs=1e-9)


def test_iso8608_profile_has_the_class_psd():
    gd0, dx = 256e-6, 0.01
    z = iso8608_profile(2**18, dx, gd0, np.random.default_rng(2))
    freq, psd = welch(z, fs=1 / dx, nperseg=2**14)
    band = (freq > 0.2) & (freq < 5.0)
    ratio = psd[band] / (gd0 * (freq[band] / 0.1) ** -2)
    assert 0.8 < np.median(ratio) < 1.2


def test_imu_maps_handlebar_axes_to_the_device_and_adds_the_misalignment():
    time = np.arange(0, 5, 1 / FS)
    pitch = np.deg2rad(3.0)
    force = np.tile([-GRAVITY * np.sin(pitch), 0.0, GRAVITY * np.cos(pitch)], (len(time), 1))
    rate = np.tile([0.0, 0.1, 0.0], (len(time), 1))
    exact = ImuSpec(acc_noise_density=0.0, gyro_noise_density=0.0, acc_bias=0.0, gyro_bias=0.0, gyro_bias_walk=0.0,
                    jitter=0.0, misalignment=0.0)
    reading = read_imu(time, force, rate, 20.0, 80, np.random.default_rng(3), exact)
    lsb = 2 * 8 * GRAVITY / 2**16
    np.testing.assert_allclose(reading.acc[:, 1], -GRAVITY * np.sin(pitch), atol=lsb)  # forward = device +y
    np.testing.assert_allclose(reading.gyro[:, 0], -0.1, atol=1e-3)  # about vehicle y (left) = device -x
    tilted = ImuSpec(acc_noise_density=0.0, gyro_noise_density=0.0, acc_bias=0.0, gyro_bias=0.0,
                     gyro_bias_walk=0.0, jitter=0.0, misalignment=np.deg2rad(2.0))
    reading = read_imu(time, force, rate, 20.0, 80, np.random.default_rng(4), tilted)
    _, measured = accel_roll_pitch(device_to_vehicle_axes(reading.acc))
    expected = pitch + reading.misalignment[1]
    assert np.rad2deg(np.abs(measured - expected).max()) < 0.3


def test_imu_sampling_jitter_and_noise_levels():
    time = np.arange(0, 60, 1 / FS)
    force = np.tile([0.0, 0.0, GRAVITY], (len(time), 1))
    spec = ImuSpec(acc_bias=0.0, gyro_bias=0.0, gyro_bias_walk=0.0, misalignment=0.0)
    reading = read_imu(time, force, np.zeros_like(force), 20.0, 1200, np.random.default_rng(5), spec)
    expected = spec.acc_noise_density * np.sqrt(10.0)
    assert np.std(reading.acc[:, 2]) == pytest.approx(expected, rel=0.25)


def test_local_to_geodetic_scales_at_the_origin():
    lat, lon = local_to_geodetic(np.array([0.0, 1000.0]), np.array([1000.0, 0.0]), (36.0, 140.0))
    assert (lat[0] - 36.0) * 110_950 == pytest.approx(1000.0, rel=2e-3)  # ~110.95 km per degree at 36 deg
    assert (lon[1] - 140.0) * 90_180 == pytest.approx(1000.0, rel=2e-3)  # ~90.18 km per degree at 36 deg
