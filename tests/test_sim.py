"""The ride simulator: contract, determinism, physics and ground truth."""

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.signal.frame import accel_roll_pitch, device_to_vehicle_axes
from spotfree.sim import SCENARIOS, simulate_ride, simulate_scenario
from spotfree.sim.scenarios import (
    CHANNELS,
    CLASSES,
    KINDS,
    NORMAL_BRAKING,
    SUDDEN_BRAKING,
    braking_labels,
    lateral_labels,
    manoeuvre_share,
)
from spotfree.units import GRAVITY

CONFOUNDERS = {"turn", "speed-change", "crossing-stop", "braking", "near-sudden", "kerb", "bump",
               "rough-asphalt", "cobblestone"}


@pytest.fixture(scope="module")
def files():
    """Each scenario once: 7 experiments, seed 0, 20 Hz."""
    return {name: simulate_scenario(name, repeats=7, seed=0) for name in SCENARIOS}


@pytest.fixture(scope="module")
def sudden_rides():
    return [simulate_ride("sudden-braking", k, repeats=7, seed=0) for k in range(1, 8)]


@pytest.fixture(scope="module")
def normal_rides():
    return [simulate_ride("normal-braking", k, repeats=7, seed=0) for k in range(1, 8)]


def vehicle_axes(ride, names):
    return device_to_vehicle_axes(np.column_stack([ride.channels[c] for c in names]))


def runs(mask):
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


# --- contract -------------------------------------------------------------------------------------------------


def test_columns_order_experiments_and_time_grid(files):
    for name, rec in files.items():
        assert tuple(rec.channels) == CHANNELS
        assert set(rec.truth) == {"label", "event"}
        assert rec.rate == 20.0
        assert np.array_equal(np.unique(rec.experiment), np.arange(1, 8))
        for k, part in rec.experiments():
            assert part.time[0] == 0.0
            assert np.allclose(np.diff(part.time), 1 / 20.0)
        assert set(np.unique(rec.truth["label"])) <= set(CLASSES[name])
        assert np.all(np.isfinite(rec.array(["ax", "ay", "az", "gx", "gy", "gz"])))
        assert rec.meta["scenario"] == name and rec.meta["seed"] == 0


def test_same_seed_same_output_other_seed_or_experiment_differs():
    a = simulate_scenario("road", repeats=2, seed=11)
    b = simulate_scenario("road", repeats=2, seed=11)
    c = simulate_scenario("road", repeats=2, seed=12)
    for column in CHANNELS:
        np.testing.assert_array_equal(a.channels[column], b.channels[column])
    np.testing.assert_array_equal(a.truth["label"], b.truth["label"])
    np.testing.assert_array_equal(a.truth["event"], b.truth["event"])
    assert len(a) != len(c) or not np.array_equal(a.channels["ax"], c.channels["ax"])
    first, second = (a.meta["experiments"][i]["rider"] for i in (0, 1))
    assert first != second


def test_unknown_scenario_and_bad_parameters_raise_input_error():
    with pytest.raises(InputError) as err:
        simulate_scenario("wheelie")
    message = str(err.value)
    assert "wheelie" in message and all(name in message for name in SCENARIOS) and "\n" not in message
    for kwargs in ({"repeats": 0}, {"seed": -1}, {"rate": 0.0}, {"repeats": 2.5}):
        with pytest.raises(InputError):
            simulate_scenario("cruising", **kwargs)


def test_rate_other_than_twenty_hertz():
    rec = simulate_scenario("cruising", repeats=1, seed=3, rate=50.0)
    assert np.allclose(np.diff(rec.time), 1 / 50.0)
    assert abs(rec.duration - 40.0) < 1.0


# --- sensors ---------------------------------------------------------------------------------------------------


def test_at_rest_the_accelerometer_reads_gravity(sudden_rides):
    for ride in sudden_rides:
        rest = (np.abs(ride.truth["speed"]) < 0.05) & (np.abs(ride.truth["accel"]) < 0.1)
        norm = np.linalg.norm(vehicle_axes(ride, ("ax", "ay", "az"))[rest], axis=1)
        assert rest.sum() > 10
        assert abs(np.median(norm) - GRAVITY) < 0.45  # residual offsets are at most 40 mg per axis
        assert np.std(norm) < 0.05


def test_device_pitch_matches_truth_within_the_misalignment(sudden_rides):
    for ride in sudden_rides:
        rest = (np.abs(ride.truth["speed"]) < 0.05) & (np.abs(ride.truth["accel"]) < 0.1)
        _, pitch = accel_roll_pitch(vehicle_axes(ride, ("ax", "ay", "az"))[rest])
        offset = np.rad2deg(np.median(pitch - ride.truth["pitch"][rest]))
        misalignment = ride.params["misalignment_deg"]
        bias = np.rad2deg(np.linalg.norm(ride.params["acc_bias"]) / GRAVITY)
        assert abs(offset) <= np.linalg.norm(misalignment) + bias + 0.3
        assert abs(offset - misalignment[1]) <= bias + 0.6


def test_gyro_pitch_rate_follows_the_handlebar(sudden_rides):
    for ride in sudden_rides:
        rate = vehicle_axes(ride, ("gx", "gy", "gz"))[:, 1]
        assert np.corrcoef(rate, ride.truth["pitch_rate"])[0, 1] > 0.9


def test_outputs_are_quantised_to_sixteen_bits(files):
    rec = files["road"]
    lsb = 2 * 8 * GRAVITY / 2**16
    steps = rec.channels["az"] / lsb
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert np.abs(rec.array(["ax", "ay", "az"])).max() <= 8 * GRAVITY


def test_gps_fixes_at_one_hertz_and_nan_between(files):
    for rec in files.values():
        for k, part in rec.experiments():
            fixes = np.flatnonzero(np.isfinite(part.channels["lat"]))
            assert np.array_equal(fixes, np.flatnonzero(np.isfinite(part.channels["speed"])))
            assert np.array_equal(fixes, np.flatnonzero(np.isfinite(part.channels["lon"])))
            assert set(np.diff(fixes)) <= {19, 20, 21}
            assert abs(len(fixes) - part.duration) <= 2
            assert np.nanmin(part.channels["speed"]) >= 0.0
            lat, lon = part.channels["lat"][fixes], part.channels["lon"][fixes]
            assert np.all(np.abs(lat - 36.0827) < 0.02) and np.all(np.abs(lon - 140.1114) < 0.02)


def test_gps_speed_tracks_the_true_speed(sudden_rides):
    for ride in sudden_rides:
        fixes = np.isfinite(ride.channels["speed"])
        error = ride.channels["speed"][fixes] - np.abs(ride.truth["speed"][fixes])
        assert np.sqrt(np.mean(error**2)) < 0.6  # 0.15 m/s noise plus the fix's 0.2 s latency while braking


# --- physics and ground truth ---------------------------------------------------------------------------------


def test_speed_stays_within_the_segway_limit(files):
    for name in SCENARIOS:
        for ride in (simulate_ride(name, k, repeats=3, seed=4) for k in (1, 2, 3)):
            assert ride.truth["speed"].max() * 3.6 <= 20.5
            assert ride.truth["speed"].min() > -0.35  # the axle rolls back a little as the rider straightens up
        assert np.nanmax(files[name].channels["speed"]) * 3.6 < 23.0


def test_sudden_braking_decelerates_and_pitches_harder_than_normal(sudden_rides, normal_rides):
    def stats(rides, label):
        decel = np.concatenate([-r.truth["accel"][r.label == label] for r in rides])
        pitch = np.concatenate([r.truth["pitch"][r.label == label] for r in rides])
        return np.median(decel), np.median(pitch)

    sudden_decel, sudden_pitch = stats(sudden_rides, "sudden-braking")
    normal_decel, normal_pitch = stats(normal_rides, "normal-braking")
    assert sudden_decel > 2.0 * normal_decel
    assert sudden_pitch < normal_pitch - np.deg2rad(4.0)

    def episode_peak_rate(rides, label):
        peaks = []
        for r in rides:
            rate = vehicle_axes(r, ("gx", "gy", "gz"))[:, 1]
            for i0, i1 in runs(r.label != "cruising"):
                if label in r.label[i0:i1]:
                    peaks.append(-rate[max(i0 - 10, 0) : i1].min())
        return np.median(peaks)

    assert episode_peak_rate(sudden_rides, "sudden-braking") > 1.5 * episode_peak_rate(normal_rides, "normal-braking")


def test_sudden_stops_pass_through_normal_braking(sudden_rides):
    for ride in sudden_rides:
        stops = runs(ride.label == "sudden-braking")
        assert 3 <= len(stops)
        for i0, i1 in stops:
            assert ride.label[i0 - 1] == "normal-braking" and ride.label[i1] == "normal-braking"
            assert ride.truth["lean_accel"][i0:i1].max() <= -SUDDEN_BRAKING


def test_labels_follow_the_lean_rule():
    lean = np.array([0.5, 0.0, -0.3, -0.6, -1.9, -2.1, -3.0])
    expected = ["cruising", "cruising", "cruising", "normal-braking", "normal-braking", "sudden-braking",
                "sudden-braking"]
    assert braking_labels(lean).tolist() == expected
    assert NORMAL_BRAKING < SUDDEN_BRAKING


def test_lateral_labels_from_yaw_rate():
    fs = 100.0
    t = np.arange(0, 30, 1 / fs)
    lobe = lambda t0, d, peak: np.where((t > t0) & (t < t0 + d), peak * np.sin(np.pi * (t - t0) / d) ** 2, 0.0)
    yaw = lobe(2, 5, 0.3) + lobe(10, 3, -0.8) + sum(lobe(16 + 1.5 * k, 1.5, 0.5 * (-1) ** k) for k in range(5))
    labels = lateral_labels(yaw, fs)
    assert labels[int(4.5 * fs)] == "gentle-turn"
    assert labels[int(11.5 * fs)] == "sharp-turn"
    assert labels[int(19.0 * fs)] == "slalom"
    assert labels[int(8.0 * fs)] == "straight" and labels[int(28 * fs)] == "straight"


@pytest.mark.parametrize("scenario, kinds, allowed", [
    ("lateral", ("sharp",), {"straight", "sharp-turn"}),
    ("lateral", ("gentle", "slalom"), {"straight", "gentle-turn", "slalom"}),
    ("lateral", (), {"straight"}),
    ("road", ("cobblestone",), {"smooth", "cobblestone"}),
    ("road", ("kerb",), {"smooth", "kerb"}),
    ("road", (), {"smooth"}),
])
def test_rides_hold_only_the_manoeuvres_asked_for(scenario, kinds, allowed):
    rec = simulate_scenario(scenario, repeats=3, seed=2, manoeuvres=kinds)
    labels = set(rec.truth["label"])
    assert labels <= allowed and (len(labels) > 1 or not kinds)
    assert rec.meta["manoeuvres"] == list(kinds)
    if scenario == "road" and "kerb" not in kinds:  # no kerb or bump strikes either
        assert not set("+".join(rec.truth["event"]).split("+")) & {"kerb", "bump"}


@pytest.mark.parametrize("scenario, every", [("lateral", KINDS["lateral"]), ("road", KINDS["road"])])
def test_rides_with_every_manoeuvre_are_the_default_rides(scenario, every):
    default = simulate_ride(scenario, 2, repeats=7, seed=4)
    chosen = simulate_ride(scenario, 2, repeats=7, seed=4, manoeuvres=every)
    assert default.label.tolist() == chosen.label.tolist() and default.event.tolist() == chosen.event.tolist()
    for name in CHANNELS:
        np.testing.assert_array_equal(default.channels[name], chosen.channels[name])


def test_manoeuvres_are_refused_outside_lateral_and_road_rides_and_when_unknown():
    with pytest.raises(InputError, match="lateral or road ride"):
        simulate_scenario("cruising", repeats=1, manoeuvres=("gentle",))
    with pytest.raises(InputError, match="zigzag.*gentle, sharp, slalom"):
        simulate_scenario("lateral", repeats=1, manoeuvres=("zigzag",))
    with pytest.raises(InputError, match="gentle.*rough-asphalt, cobblestone, kerb"):
        simulate_scenario("road", repeats=1, manoeuvres=("gentle",))


def test_every_experiment_holds_confounders(files):
    for name, rec in files.items():
        for k, part in rec.experiments():
            names = set("+".join(part.truth["event"]).split("+")) - {""}
            assert names, f"{name} experiment {k} has no confounder"
            assert names <= CONFOUNDERS
            moving = part.truth["event"] != ""
            assert moving.mean() < 0.9


def test_turns_while_cruising_stay_cruising(files):
    rec = files["sudden-braking"]
    turning = np.char.find(rec.truth["event"].astype(str), "turn") >= 0
    assert turning.any()
    assert np.mean(rec.truth["label"][turning] == "cruising") > 0.95


def test_manoeuvre_share_ranges_from_a_few_percent_to_a_large_part(files):
    shares = {name: [manoeuvre_share(p.truth["label"], name) for _, p in rec.experiments()] for name, rec in
              files.items()}
    for name in ("normal-braking", "lateral", "road"):
        assert min(shares[name]) < 0.15 and max(shares[name]) > 0.3, (name, shares[name])
    assert 0.02 < min(shares["sudden-braking"]) and max(shares["sudden-braking"]) < 0.2
    assert all(0.03 < s < 0.35 for s in shares["cruising"])


def test_one_normal_stop_per_file_comes_close_to_sudden(files):
    for name, rec in files.items():
        near = np.char.find(rec.truth["event"].astype(str), "near-sudden") >= 0
        assert near.any(), name
        assert not np.any(rec.truth["label"][near] == "sudden-braking")
    ride = simulate_ride("normal-braking", 5, repeats=7, seed=0)
    near = np.char.find(ride.event.astype(str), "near-sudden") >= 0
    assert -ride.truth["lean_accel"][near].min() > 0.85 * SUDDEN_BRAKING


def test_cruising_is_forty_seconds_ending_in_normal_braking(files):
    for k, part in files["cruising"].experiments():
        assert abs(part.duration - 40.0) < 1.0
        labels = part.truth["label"]
        braking = np.flatnonzero(labels == "normal-braking")
        assert len(braking) and braking[-1] > len(labels) - 8 * 20
        assert labels[-1] == "cruising"
    ride = simulate_ride("cruising", 2, repeats=7, seed=0)
    assert abs(ride.truth["speed"][-1]) < 0.1 and ride.truth["speed"].max() > 3.0
    for seed in range(1, 7):  # slow riders and long speed changes included
        assert all(abs(p.duration - 40.0) < 1.0 for _, p in simulate_scenario("cruising", 7, seed).experiments())


def test_road_surfaces_shake_the_tablet_in_order():
    rms = {name: [] for name in ("smooth", "rough-asphalt", "cobblestone")}
    for k in range(1, 5):
        ride = simulate_ride("road", k, repeats=4, seed=0)
        vertical = vehicle_axes(ride, ("ax", "ay", "az"))[:, 2]
        shake = vertical - np.convolve(vertical, np.ones(9) / 9, mode="same")
        for name in rms:
            m = (ride.label == name) & (ride.truth["speed"] > 2.5)
            if m.sum() > 40:
                rms[name].append(np.sqrt(np.mean(shake[m] ** 2)))
    smooth, rough, cobble = (np.median(rms[n]) for n in ("smooth", "rough-asphalt", "cobblestone"))
    assert smooth < rough < cobble


def test_kerb_strikes_are_short(files):
    rec = files["road"]
    strikes = runs(rec.truth["label"] == "kerb")
    assert len(strikes) >= 7
    assert max(i1 - i0 for i0, i1 in strikes) <= 12  # at most 0.6 s at 20 Hz
