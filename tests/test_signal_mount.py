"""Mount detection: a phone flat, upright in a holder or turned on the handlebar gives the same vehicle features."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io.csvlog import write_csv
from spotfree.signal.features import FEATURE_CHANNELS, ride_features
from spotfree.signal.frame import MOUNT
from spotfree.signal.mount import PRESETS, estimate_mount, rotation_angle
from spotfree.sim.scenarios import simulate_scenario

# v_new_device = Q @ v_flat_device: the simulated tablet (flat, top edge forward) re-mounted
MOUNTS = {
    "upright in a holder": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
    "holder tilted back 66 deg": Rotation.from_euler("x", -66, degrees=True).as_matrix(),
    "turned 35 deg on the handlebar": Rotation.from_euler("z", 35, degrees=True).as_matrix(),
    "landscape, upside down, tilted": Rotation.from_euler("zxy", [120, 50, 10], degrees=True).as_matrix(),
}


def remounted(rec, q):
    channels = dict(rec.channels)
    for names in (["ax", "ay", "az"], ["gx", "gy", "gz"]):
        channels.update(zip(names, (rec.array(names) @ q.T).T))
    return rec.with_channels(channels)


@pytest.fixture(scope="module")
def ride():
    return simulate_scenario("sudden-braking", repeats=2, seed=4)


@pytest.fixture(scope="module")
def flat_features(ride):
    return ride_features(ride, derived=True)


def test_the_simulated_flat_tablet_is_usual_and_keeps_the_nominal_mount(ride, flat_features):
    estimate = estimate_mount(ride)
    assert np.degrees(estimate.angle_from_nominal) < 10  # the simulator's misalignment is a few degrees
    assert np.array_equal(estimate.used, MOUNT) and estimate.warnings == []
    assert "speed changes" in estimate.source and estimate.correlation > 0.5
    assert "using the nominal mount" in flat_features.meta["mount"]


@pytest.mark.parametrize("name", list(MOUNTS))
def test_the_estimate_turns_with_the_phone(ride, name):
    q = MOUNTS[name]
    flat, turned = estimate_mount(ride), estimate_mount(remounted(ride, q))
    assert np.degrees(rotation_angle(turned.estimated @ q @ flat.estimated.T)) < 0.5
    assert any("features use the estimated mount" in w for w in turned.warnings)


@pytest.mark.parametrize("name", list(MOUNTS))
def test_every_mount_gives_the_flat_mounts_vehicle_features(ride, flat_features, name):
    feats = ride_features(remounted(ride, MOUNTS[name]), derived=True)
    ok = flat_features.valid() & feats.valid() & (feats.time > 5.0)  # the attitude filters have settled
    tolerance = {"roll": 0.03, "pitch": 0.03, "pitch_rate": 0.01, "acc_x": 0.1, "acc_y": 0.1, "acc_z": 0.1,
                 "acc_long": 0.1, "lean": 0.01, "yaw_rate": 0.01, "roll_rate": 0.01}
    for channel, limit in tolerance.items():
        a, b = flat_features.channels[channel][ok], feats.channels[channel][ok]
        assert np.sqrt(np.mean((a - b) ** 2)) < limit, channel


def test_a_wrong_mount_choice_changes_the_features(ride, flat_features):
    upright = remounted(ride, MOUNTS["upright in a holder"])
    forced = ride_features(upright, derived=True, mount="flat")
    ok = flat_features.valid() & forced.valid() & (forced.time > 5.0)
    assert np.sqrt(np.mean((forced.channels["acc_x"][ok] - flat_features.channels["acc_x"][ok]) ** 2)) > 0.3
    preset = ride_features(upright, mount="upright")
    assert np.allclose(preset.meta["mount_matrix"], PRESETS["upright"])


def test_without_gps_speed_the_top_edge_or_back_is_forward(ride):
    no_gps = ride.with_channels({k: v for k, v in ride.channels.items() if k != "speed"})
    for name in ("upright in a holder", "holder tilted back 66 deg"):
        estimate = estimate_mount(remounted(no_gps, MOUNTS[name]))
        flat = estimate_mount(no_gps)
        assert "top edge" in estimate.source
        forward = (estimate.estimated[0] @ MOUNTS[name]) @ flat.estimated[0]  # both in flat device coordinates
        assert forward > np.cos(np.radians(10))


def test_an_unknown_mount_choice_is_refused(ride):
    with pytest.raises(InputError, match="--mount 'sideways' is not known"):
        estimate_mount(ride, "sideways")


def test_the_command_reports_the_mount_and_takes_the_override(tmp_path, ride):
    path = tmp_path / "upright.csv"
    write_csv(remounted(ride, MOUNTS["upright in a holder"]), path)
    runner = CliRunner()
    result = runner.invoke(app, ["features", str(path), "-o", str(tmp_path / "f.csv")])
    assert result.exit_code == 0, result.output
    assert "mount: up is" in result.stderr and "using the estimate" in result.stderr
    assert "warning:" in result.stderr and "features use the estimated mount" in result.stderr
    forced = runner.invoke(app, ["features", str(path), "-o", str(tmp_path / "g.csv"), "--mount", "upright"])
    assert forced.exit_code == 0 and "using the --mount upright choice" in forced.stderr
    bad = runner.invoke(app, ["features", str(path), "-o", str(tmp_path / "h.csv"), "--mount", "sideways"])
    assert bad.exit_code == 2 and bad.stderr.count("error:") == 1
    assert FEATURE_CHANNELS[0] in (tmp_path / "f.csv").read_text().splitlines()[0]


def with_accelerations(rec, acc, keep_track=True):
    channels = {**rec.channels, **dict(zip(["ax", "ay", "az"], acc.T))}
    if not keep_track:
        channels = {c: v for c, v in channels.items() if c not in ("lat", "lon")}
    return rec.with_channels(channels)


def test_a_constant_accelerometer_bias_is_not_reported_as_a_tilt(ride):
    """3.5 m/s^2 on the phone's y axis turns the mean specific force by 20 deg, as a tilt would; its magnitude
    (10.4 m/s^2, not g) is all that tells them apart, so the report says either may be."""
    biased = estimate_mount(with_accelerations(ride, ride.array(["ax", "ay", "az"]) + [0.0, 3.5, 0.0]))
    assert biased.biased and 10.2 < biased.force < 10.7
    assert np.degrees(biased.angle_from_nominal) > 15
    assert "deg from flat with the top edge forward or an accelerometer bias (its mean specific force is" \
        in biased.describe()
    assert any("a bias across the vertical tilts the estimate by up to" in w and "cannot tell from a tilt" in w
               for w in biased.warnings)
    assert not any("the phone is mounted" in w for w in biased.warnings)
    sound = estimate_mount(ride)
    assert not sound.biased and "bias" not in sound.describe() and not any("bias" in w for w in sound.warnings)


@pytest.fixture(scope="module")
def turning_ride():
    return simulate_scenario("lateral", repeats=2, seed=4)


def test_an_accelerometer_of_flipped_sign_is_told_by_the_gps_track(turning_ride):
    """Minus the specific force (iOS's sign) with a right gyroscope is a mirror image of the ride: the mount cues
    all agree with it, but the gyroscope then turns against the GPS track."""
    right = estimate_mount(turning_ride)
    assert not any("GPS track" in w or "upside down" in w for w in right.warnings)
    flipped = estimate_mount(with_accelerations(turning_ride, -turning_ride.array(["ax", "ay", "az"])))
    told = [w for w in flipped.warnings if "the gyroscope turns against the GPS track" in w]
    assert len(told) == 1 and "multiply ax, ay, az by -1, or by -9.81 when they are in g" in told[0]
    assert not any("the phone is mounted" in w for w in flipped.warnings)


def test_without_a_track_a_phone_upside_down_names_both_readings(turning_ride):
    flipped = estimate_mount(with_accelerations(turning_ride, -turning_ride.array(["ax", "ay", "az"]), False))
    said = [w for w in flipped.warnings if "upside down" in w]
    assert len(said) == 1 and "either it is, or the accelerometer reads minus the specific force" in said[0]
    assert said[0].endswith("the GPS track would tell, and the log has none")
