"""The ride assistant: one warning per dangerous manoeuvre despite label flicker, events, speed, distance with
GPS jumps ignored, and the time to destination."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gpxpy.geo import haversine_distance

from spotfree.errors import InputError
from spotfree.ride.assistant import KMH, RideAssistant
from spotfree.ride.records import Event
from spotfree.sim.gps import local_to_geodetic
from spotfree.sim.scenarios import simulate_scenario

ORIGIN = (36.0827, 140.1114)


def _feed(assistant, labels, rate=20.0):
    return [assistant.update(k / rate, label) for k, label in enumerate(labels)]


def test_one_warning_per_stop_even_when_the_label_flickers():
    stop = ["cruising"] * 20 + ["sudden-braking", "normal-braking"] * 3 + ["sudden-braking"] * 10 \
        + ["normal-braking"] * 10 + ["sudden-braking"] * 4 + ["cruising"] * 100
    statuses = _feed(RideAssistant(), stop * 2)
    warnings = [s.warning for s in statuses if s.warning]
    assert len(warnings) == 2
    first = stop.index("sudden-braking")
    run = first + 6  # the first run of three samples (0.1 s) starts after the flicker
    assert warnings[0].onset == run / 20 and warnings[0].time == (run + 2) / 20
    assert warnings[1].onset == (len(stop) + run) / 20
    events = [s.event for s in statuses if s.event]
    last = len(stop) - 100 - 1
    assert events == [Event("sudden-braking", run / 20, last / 20), Event("sudden-braking", (len(stop) + run) / 20,
                                                                          (len(stop) + last) / 20)]
    assert statuses.index(next(s for s in statuses if s.event)) == last + 61  # refractory 3 s = 60 samples


def test_short_blips_do_not_warn_and_min_duration_zero_warns_at_once():
    blips = (["cruising"] * 10 + ["sudden-braking"] * 2) * 10
    assert not any(s.warning for s in _feed(RideAssistant(), blips))
    statuses = _feed(RideAssistant(min_duration=0.0), blips)
    warning = next(s.warning for s in statuses if s.warning)
    assert warning.onset == warning.time == 0.5
    assert sum(s.warning is not None for s in statuses) == 1  # blips 0.6 s apart stay in one episode


def test_a_stop_after_the_refractory_time_warns_again_and_finish_closes_the_episode():
    labels = ["sudden-braking"] * 5 + ["cruising"] * 61 + ["sudden-braking"] * 5
    assistant = RideAssistant(refractory=3.0)
    statuses = _feed(assistant, labels)
    assert sum(s.warning is not None for s in statuses) == 2
    assert assistant.pop_events() == [Event("sudden-braking", 0.0, 0.2)] and assistant.pop_events() == []
    assert assistant.finish() == [Event("sudden-braking", 0.0, 0.2), Event("sudden-braking", 3.3, 3.5)]


def test_several_dangerous_classes_are_debounced_apart():
    labels = ["lateral"] * 5 + ["sudden-braking"] * 5 + ["lateral"] * 5
    statuses = _feed(RideAssistant(dangerous=("sudden-braking", "lateral")), labels)
    assert [(s.warning.kind, s.warning.onset) for s in statuses if s.warning] == \
           [("lateral", 0.0), ("sudden-braking", 0.25)]


def test_simulated_rides_with_noisy_labels_give_one_warning_per_sudden_stop():
    rides = simulate_scenario("sudden-braking", repeats=3, seed=4)
    rng = np.random.default_rng(0)
    for _, ride in rides.experiments():
        truth = ride.truth["label"]
        noisy = truth.copy()
        flip = rng.random(len(truth)) < 0.1
        noisy[flip] = rng.choice(["cruising", "normal-braking", "sudden-braking"], flip.sum())
        assistant = RideAssistant()
        statuses = [assistant.update(t, str(label)) for t, label in zip(ride.time, noisy)]
        onsets = ride.time[1:][(truth[1:] == "sudden-braking") & (truth[:-1] != "sudden-braking")]
        warned = np.array([s.warning.time for s in statuses if s.warning])
        assert len(warned) == len(onsets) > 0
        assert np.all((warned >= onsets - 0.2) & (warned <= onsets + 0.5))  # no noise-only stop is warned


def _track(speed=4.0, seconds=60, rate=20.0, fix_every=20, east_per_north=1.0):
    """A straight ride at constant ``speed`` (m/s) with a fix every second: times, lat, lon (NaN between)."""
    t = np.arange(int(seconds * rate)) / rate
    along = speed * t
    unit = np.hypot(east_per_north, 1.0)
    lat, lon = local_to_geodetic(along * east_per_north / unit, along / unit, ORIGIN)
    fix = np.arange(len(t)) % fix_every == 0
    return t, np.where(fix, lat, np.nan), np.where(fix, lon, np.nan)


def test_speed_distance_location_and_eta_on_a_straight_ride():
    t, lat, lon = _track(speed=4.0, seconds=60)
    assistant = RideAssistant()
    destination = local_to_geodetic(np.array(400.0 / np.sqrt(2)), np.array(400.0 / np.sqrt(2)), ORIGIN)
    assistant.set_destination(*destination)
    statuses = [assistant.update(a, None, b, c) for a, b, c in zip(t, lat, lon)]
    last = statuses[-1]
    assert last.distance == pytest.approx(4.0 * 59, rel=2e-3)  # last fix at 59 s
    assert last.speed == pytest.approx(4.0, rel=2e-3) and last.speed_kmh == pytest.approx(14.4, rel=2e-3)
    assert (last.lat, last.lon) == (lat[np.isfinite(lat)][-1], lon[np.isfinite(lon)][-1])
    assert last.remaining == pytest.approx(400.0 - 4.0 * 59, rel=3e-3)
    assert last.eta == pytest.approx((400.0 - 4.0 * 59) / 4.0, rel=3e-3)
    assert math.isnan(statuses[0].eta)  # one fix: no average speed yet
    figures = assistant.state()
    assert figures == last.figures() and figures["eta"] == pytest.approx(last.eta) and figures["time"] == t[-1]
    assert RideAssistant().state() == {} and statuses[0].figures()["eta"] is None
    assert KMH == 3.6


@pytest.mark.parametrize("size", [1, 5, 37])
def test_blocks_give_the_warnings_events_and_state_of_one_sample_at_a_time(size):
    t, lat, lon = _track(speed=4.0, seconds=40)
    stop = (["cruising"] * 20 + ["sudden-braking"] * 12 + ["normal-braking"] * 70) * 8
    labels = stop[:len(t)]
    speed = np.where(np.isfinite(lat), 4.0, np.nan)
    one, block = RideAssistant(), RideAssistant()
    for assistant in (one, block):
        assistant.set_destination(*local_to_geodetic(np.array(200.0), np.array(200.0), ORIGIN))
    statuses = [one.update(*row) for row in zip(t, labels, lat, lon, speed)]
    rows = list(zip(t.tolist(), lat.tolist(), lon.tolist(), speed.tolist()))
    warnings = [w for k in range(0, len(t), size) for w in block.update_block(rows[k:k + size], labels[k:k + size])]
    assert warnings == [s.warning for s in statuses if s.warning] and len(warnings) == 8
    assert block.pop_events() == one.pop_events() and len(one.events_) == 7
    assert block.state() == one.state() and block.state()["distance"] > 100
    assert block.update_block([], []) == [] and block.state() == one.state()


def test_gps_jumps_are_ignored_and_a_lost_track_re_anchors():
    t, lat, lon = _track(speed=3.0, seconds=30)
    fixes = np.flatnonzero(np.isfinite(lat))
    lat[fixes[10]] += 0.01  # one fix 1.1 km off
    assistant = RideAssistant()
    statuses = [assistant.update(a, None, b, c) for a, b, c in zip(t, lat, lon)]
    assert statuses[-1].distance == pytest.approx(3.0 * 29, rel=3e-3)
    assert statuses[fixes[10]].lat == statuses[fixes[9]].lat

    moved = RideAssistant()
    moved.update(0.0, None, *ORIGIN)
    moved.update(1.0, None, ORIGIN[0] + 5e-5, ORIGIN[1])
    far = (ORIGIN[0] + 0.02, ORIGIN[1])
    assert moved.update(2.0, None, *far).lat == ORIGIN[0] + 5e-5  # a jump: ignored
    status = moved.update(3.0, None, far[0] + 1e-5, far[1])  # plausible from the jump: re-anchored
    assert status.lat == far[0] + 1e-5
    assert status.distance == pytest.approx(haversine_distance(*ORIGIN, ORIGIN[0] + 5e-5, ORIGIN[1]), rel=1e-9)


@pytest.mark.parametrize("scenario, seed", [("cruising", 2), ("sudden-braking", 1)])
def test_distance_of_a_simulated_ride_matches_its_gps_speed(scenario, seed):
    ride = simulate_scenario(scenario, repeats=1, seed=seed)
    lat, lon, speed = (ride.channels[c] for c in ("lat", "lon", "speed"))
    assistant = RideAssistant()
    statuses = [assistant.update(*row) for row in zip(ride.time, [None] * len(ride), lat, lon, speed)]
    fix = np.isfinite(lat)
    travelled = np.trapezoid(speed[fix], ride.time[fix])
    assert statuses[-1].distance == pytest.approx(travelled, rel=0.05)
    assert statuses[-1].speed == speed[fix][-1]


def test_jitter_below_the_minimum_step_adds_no_distance():
    assistant = RideAssistant(min_step=2.0)
    rng = np.random.default_rng(1)
    for k in range(60):
        east, north = rng.normal(0.0, 0.3, 2)
        status = assistant.update(float(k), None, *local_to_geodetic(np.array(east), np.array(north), ORIGIN))
    assert status.distance == 0.0 and status.lat != ORIGIN[0]
    assert RideAssistant(min_step=0.0).min_step == 0.0


def test_speed_goes_stale_and_eta_is_unknown_when_standing():
    assistant = RideAssistant(fix_timeout=5.0)
    assistant.set_destination(ORIGIN[0] + 0.01, ORIGIN[1])
    for k in range(10):
        status = assistant.update(float(k), None, *ORIGIN, 0.0)
    assert status.speed == 0.0 and math.isnan(status.eta) and status.remaining > 1000
    assert math.isnan(assistant.update(15.0, None).speed)
    assistant.set_destination(ORIGIN[0] + 5e-5, ORIGIN[1])  # 5.5 m away: arrived
    assert assistant.update(16.0, None).eta == 0.0
    assistant.clear_destination()
    assert math.isnan(assistant.update(17.0, None).remaining)


@pytest.mark.parametrize("call, message", [
    (lambda a: a.update(0.0, None), "not after"),
    (lambda a: a.update(2.0, None, 91.0, 0.0), "within \\[-90, 90\\]"),
    (lambda a: a.update(2.0, None, 36.0, math.nan), "both together"),
    (lambda a: a.update(2.0, None, speed=-1.0), "GPS speed"),
    (lambda a: a.update(math.nan, None), "not after"),
    (lambda a: a.set_destination(0.0, 200.0), "destination"),
])
def test_bad_input_is_refused_without_changing_state(call, message):
    assistant = RideAssistant()
    assistant.update(1.0, "sudden-braking", *ORIGIN, 2.0)
    with pytest.raises(InputError, match=message):
        call(assistant)
    status = assistant.update(1.05, "sudden-braking")
    assert status.speed == 2.0 and status.lat == ORIGIN[0]


@pytest.mark.parametrize("params", [dict(refractory=-1.0), dict(max_speed=0.0), dict(min_duration=math.nan),
                                    dict(dangerous=())])
def test_bad_parameters(params):
    with pytest.raises(InputError):
        RideAssistant(**params)


def test_the_service_warns_of_the_dangerous_classes_its_model_has():
    from dataclasses import replace

    from classify_fixtures import truth_model
    from spotfree.ride.service import assistant_factory

    model = truth_model(simulate_scenario("sudden-braking", repeats=1, seed=1), stride=10)
    assert assistant_factory(model)().dangerous == ("sudden-braking",)
    road = replace(model, classes=["cobblestone", "kerb", "rough-asphalt"])
    assert assistant_factory(road)().dangerous == ("cobblestone",)
    lateral = replace(model, classes=["gentle-turn", "sharp-turn", "straight"])
    assert assistant_factory(lateral)().dangerous == ("sharp-turn",)
    assert assistant_factory(replace(model, classes=["a", "b", "c"]))().dangerous == ("sudden-braking",)
