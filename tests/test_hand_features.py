"""Hand feature channels: the neutral, units, and, measured on simulated people, that the five postures are apart in
feature space and that the gestures move."""

import itertools

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.hand.features import FEATURES, hand_features
from spotfree.hand.log import frames_to_recording
from spotfree.hand.vocabulary import POSTURES
from spotfree.sim.hand import simulate_hands

GEOMETRY = [n for n in FEATURES if n.startswith(("pos_", "normal_", "dir_"))]


@pytest.fixture(scope="module")
def recording():
    return frames_to_recording(simulate_hands(people=6, seed=1, rounds=1))


@pytest.fixture(scope="module")
def features(recording):
    return hand_features(recording)


def test_channels_units_and_truth(features, recording):
    assert tuple(features.channels) == FEATURES and features.rate == recording.rate
    np.testing.assert_array_equal(features.truth["label"], recording.truth["label"])
    ok = features.valid()
    assert np.array_equal(ok, recording.valid())
    for name in ("normal", "dir"):
        vectors = features.array([f"{name}_{a}" for a in "xyz"])[ok]
        np.testing.assert_allclose(np.linalg.norm(vectors, axis=1), 1.0)
    for name in ("grab", "pinch", "ext_index"):
        assert 0.0 <= np.nanmin(features.channels[name]) and np.nanmax(features.channels[name]) <= 1.0
    spread = features.channels["spread"][ok]
    assert 0.2 < spread.min() and spread.max() < 1.5  # fingertip spread over palm width


def test_positions_are_relative_to_the_calibration_hold(features, recording):
    for number, part in features.experiments():
        start = part.time < part.time[0] + 1.0
        position = part.array(["pos_x", "pos_y", "pos_z"])
        assert np.all(np.abs(np.nanmedian(position[start], axis=0)) < 1e-3)
        raw = recording.select_experiment(number).array(["palm_y"])[:, 0]
        assert np.nanmedian(raw[start]) > 0.1  # the sensor sees the hand 10-30 cm up
    given = hand_features(recording, neutral=np.array([0.0, 0.2, 0.0]))
    np.testing.assert_allclose(given.channels["pos_y"], recording.channels["palm_y"] - 0.2)


def test_each_pair_of_postures_is_apart_in_some_channel(features):
    """Per pair, the best single channel's mean difference in pooled within-class standard deviations."""
    X = features.array(list(FEATURES))
    posture = features.valid() & (features.truth["state"] == "posture")
    separation = {}
    for a, b in itertools.combinations(POSTURES, 2):
        A, B = X[posture & (features.truth["label"] == a)], X[posture & (features.truth["label"] == b)]
        d = np.abs(A.mean(axis=0) - B.mean(axis=0)) / np.sqrt((A.var(axis=0) + B.var(axis=0)) / 2 + 1e-12)
        separation[a, b] = d.max()
    assert min(separation.values()) > 5.0, separation


def test_postures_of_held_out_people_fall_nearest_their_own_class_mean(features):
    """Class means of the position and orientation channels from people 1-3 label the holds of people 4-6."""
    X = features.array(GEOMETRY)
    person = features.truth["person"].astype(int)
    posture = features.valid() & (features.truth["state"] == "posture")
    labels = features.truth["label"]
    train, test = posture & (person <= 3), posture & (person > 3)
    means = np.array([X[train & (labels == p)].mean(axis=0) for p in POSTURES])
    scale = X[train].std(axis=0)
    distance = (((X[test][:, None, :] - means[None]) / scale) ** 2).sum(axis=2)
    predicted = np.array(POSTURES)[distance.argmin(axis=1)]
    assert np.mean(predicted == labels[test]) >= 0.99


def test_gestures_move_and_postures_hold_still(features):
    ok = features.valid()
    gesture = ok & (features.truth["state"] == "gesture")
    posture = ok & (features.truth["state"] == "posture")
    speed = np.linalg.norm(features.array(["vel_x", "vel_y", "vel_z"]), axis=1)
    assert np.mean(speed[gesture]) > 3.0 * np.mean(speed[posture])
    direction = features.array(["dir_x", "dir_y", "dir_z"])
    turn = np.r_[np.nan, np.arccos(np.clip(np.sum(direction[1:] * direction[:-1], axis=1), -1, 1))] * features.rate
    assert np.nanmean(turn[gesture]) > 5.0 * np.nanmean(turn[posture])


def test_a_session_without_a_hand_at_its_start_or_without_hand_channels_is_refused(recording):
    blind = recording.with_channels({k: v.copy() for k, v in recording.channels.items()})
    first = blind.experiment == 2
    start = np.flatnonzero(first)[0]
    for values in blind.channels.values():
        values[start + 3:start + 40] = np.nan  # the hand is seen for 0.15 s, then lost for 1.85 s
    with pytest.raises(InputError, match=r"session 2\): 3 sample\(s\) with a hand in the first 1 s"):
        hand_features(blind)
    with pytest.raises(InputError, match="no hand channel"):
        hand_features(recording.with_channels({"palm_x": recording.channels["palm_x"]}))
