"""The hand simulator: determinism, the protocol and its ground truth, the movement law, the tracker, the CLI."""

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.hand.frames import HAND_CHANNELS, frame_message
from spotfree.hand.log import read_hand_log
from spotfree.hand.vocabulary import GESTURES, POSTURES
from spotfree.sim.hand import (
    KNUCKLES, PALM_WIDTH, SEGMENTS, draw_person, fingertips, minimum_jerk, pace, simulate_hands,
)


@pytest.fixture(scope="module")
def two():
    return simulate_hands(people=2, seed=11, rounds=2)


def runs(labels):
    """``(label, first index, count)`` of each run of equal labels."""
    out, start = [], 0
    for label, group in itertools.groupby(labels):
        count = len(list(group))
        out.append((label, start, count))
        start += count
    return out


def table(frames):
    """Timestamps, ids, sessions and hand channels (NaN without a hand) of frames, as one array."""
    hands = [f.hands[0].vector() if f.hands else np.full(len(HAND_CHANNELS), np.nan) for f in frames]
    return np.c_[[[f.timestamp, f.id, f.session] for f in frames], hands]


def test_same_seed_same_frames_other_seed_other_frames(two):
    again = simulate_hands(people=2, seed=11, rounds=2)
    np.testing.assert_array_equal(table(again), table(two))
    assert [f.truth for f in again] == [f.truth for f in two]
    assert [frame_message(f) for f in again[:300]] == [frame_message(f) for f in two[:300]]
    other = simulate_hands(people=2, seed=12, rounds=1)
    assert not np.array_equal(table(other[:50]), table(two[:50]))


def test_a_person_is_the_same_whichever_selection_draws_it(two):
    alone = simulate_hands(people=1, seed=11, rounds=2, first=2)
    second = [f for f in two if f.session == 2]
    assert [f.truth for f in alone] == [f.truth for f in second]
    assert all(f.truth["person"] == 2 for f in alone)
    for a, b in zip(alone, second):
        assert len(a.hands) == len(b.hands)
        if a.hands:
            np.testing.assert_array_equal(a.hands[0].vector(), b.hands[0].vector())
    assert draw_person(11, 2).neutral.tolist() == draw_person(11, 2).neutral.tolist()
    assert draw_person(11, 2).neutral.tolist() != draw_person(11, 3).neutral.tolist()


def test_protocol_every_gesture_rounds_times_between_its_two_postures(two):
    for session in (1, 2):
        frames = [f for f in two if f.session == session]
        t = np.array([f.time for f in frames])
        labelled = runs([(f.truth["state"], f.truth["label"]) for f in frames])
        (state, label), _, count = labelled[0]
        assert (state, label) == ("posture", "straight") and t[count] - t[0] >= 2.0  # calibration hold
        states = [s for (s, _), _, _ in labelled]
        assert states == ["posture", "gesture"] * (len(states) // 2) + ["posture"]
        gestures = [lab for (s, lab), _, _ in labelled if s == "gesture"]
        assert sorted(gestures) == sorted(GESTURES * 2)
        postures = [lab for (s, lab), _, _ in labelled if s == "posture"]
        assert set(postures) == set(POSTURES)
        for before, gesture, after in zip(postures, gestures, postures[1:]):
            assert gesture == f"{before}-to-{after}"
        durations = [t[a + n - 1] - t[a] for (s, _), a, n in labelled if s == "gesture"]
        assert 0.25 < min(durations) and max(durations) < 1.6


def test_minimum_jerk_starts_and_ends_at_rest():
    u = np.linspace(0.0, 1.0, 10001)
    s = minimum_jerk(u)
    velocity, acceleration = np.gradient(s, u), np.gradient(np.gradient(s, u), u)
    assert s[0] == 0.0 and s[-1] == 1.0 and np.all(np.diff(s) >= 0)
    assert abs(velocity[0]) < 1e-3 and abs(velocity[-1]) < 1e-3 and velocity.max() == pytest.approx(1.875, 1e-4)
    assert abs(acceleration[1]) < 1e-2 and abs(acceleration[-2]) < 1e-2
    assert minimum_jerk(np.array([-1.0, 2.0])).tolist() == [0.0, 1.0]


@pytest.mark.parametrize("skew", [0.8, 1.0, 1.25])
def test_pace_is_the_path_speed_over_its_peak(skew):
    tau = np.linspace(0.0, 1.0, 20001)
    speed = np.gradient(minimum_jerk(tau**skew), tau)
    np.testing.assert_allclose(pace(tau, skew), speed / speed.max(), atol=2e-3)
    assert pace(np.array([0.0, 1.0]), skew).tolist() == [0.0, 0.0]


def test_pace_truth_rises_and_falls_once_per_gesture_and_is_zero_in_postures(two):
    for label, start, count in runs([(f.session, f.truth["label"]) for f in two]):
        values = np.array([f.truth["pace"] for f in two[start:start + count]])
        if label[1] in POSTURES:
            assert np.all(values == 0.0)
        else:
            top = int(np.argmax(values))
            assert values.max() > 0.95 and values[0] < 0.2 and values[-1] < 0.2
            assert np.all(np.diff(values[:top + 1]) >= 0) and np.all(np.diff(values[top:]) <= 0)


def test_tracker_rate_jitter_dropped_frames_and_lost_hands(two):
    for session in (1, 2):
        frames = [f for f in two if f.session == session]
        steps = np.diff([f.time for f in frames])
        median = np.median(steps)
        assert 1 / 120 <= median <= 1 / 100
        assert 0.02 < np.std(steps[steps < 1.5 * median]) / median < 0.08  # 5 % interval jitter
        assert 0.002 < np.mean(steps > 1.5 * median) < 0.03  # 1 % of frames never sent
        assert 0.002 < np.mean([not f.hands for f in frames]) < 0.1  # tracking-loss episodes
        ids = np.array([f.id for f in frames])
        assert np.all(np.diff(ids) >= 1)


def test_fingertips_extend_and_curl_and_scale_with_the_hand():
    rotation = Rotation.identity()
    origin = np.zeros((1, 3))
    open_hand = fingertips(origin, rotation, np.zeros((1, 5)), 1.0)[0]
    fist = fingertips(origin, rotation, np.ones((1, 5)), 1.0)[0]
    base = np.c_[KNUCKLES, np.zeros(5)]
    np.testing.assert_allclose(np.linalg.norm(open_hand - base, axis=1), SEGMENTS.sum(axis=1))  # straight fingers
    curled = np.linalg.norm(fist - base, axis=1) / SEGMENTS.sum(axis=1)
    assert np.all(curled[1:] < 0.5) and curled[0] < 0.9  # the thumb flexes less
    assert np.all(fist[1:, 2] > 0.0)  # curled toward the palm side (the normal, hand-frame z)
    big = fingertips(origin, rotation, np.full((1, 5), 0.3), 1.15)[0]
    small = fingertips(origin, rotation, np.full((1, 5), 0.3), 0.85)[0]
    np.testing.assert_allclose(big / (1.15 * PALM_WIDTH), small / (0.85 * PALM_WIDTH))


def test_bad_arguments_are_refused():
    with pytest.raises(InputError, match="at least 1"):
        simulate_hands(people=0)


def test_cli_writes_the_same_file_for_the_same_seed(tmp_path):
    runner = CliRunner()
    paths = [tmp_path / "a.jsonl", tmp_path / "b.jsonl"]
    for path in paths:
        result = runner.invoke(app, ["hand", "simulate", "-o", str(path), "--people", "2", "--seed", "5",
                                     "--rounds", "1"], catch_exceptions=False)
        assert result.exit_code == 0 and "2 session(s)" in " ".join(result.output.split())
    assert paths[0].read_bytes() == paths[1].read_bytes()
    rec = read_hand_log(paths[0])
    assert np.unique(rec.experiment).tolist() == [1, 2] and set(rec.truth["person"]) == {"1", "2"}
    bad = runner.invoke(app, ["hand", "simulate", "-o", str(tmp_path / "missing" / "x.jsonl"), "--people", "1",
                              "--rounds", "1"])
    assert bad.exit_code == 2 and "does not exist" in " ".join(bad.output.split())
