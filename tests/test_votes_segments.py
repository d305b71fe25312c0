"""Offline segment vote: change points of the model's channels, a majority label per segment, bad input."""

import numpy as np
import pytest
from classify_fixtures import model, raw, with_gap  # noqa: F401 (fixtures)

from spotfree.classify.batch import classify_recording
from spotfree.errors import InputError
from spotfree.votes.options import Votes, apply_votes, check_penalty, edge_levels, event_background, model_edge, \
    voted_labels
from spotfree.votes.segments import (LEVEL_FLOOR, change_points, event_edges, event_ends, segment_signal,
                                     segment_vote)


def test_change_points_find_a_step_in_the_mean_and_one_in_a_level_channels_scale():
    rng = np.random.default_rng(0)
    step = np.r_[np.zeros(80), np.full(70, 2.0)] + rng.normal(0.0, 0.3, 150)
    ends = change_points(segment_signal({"yaw_rate": step}, ["yaw_rate"]), 4.0)
    assert ends[-1] == 150 and len(ends) == 2 and abs(ends[0] - 80) <= 1
    # a level (RMS) that quadruples: its logarithm steps, whatever the units
    level = np.abs(rng.normal(0.0, 1.0, 200)) * np.r_[np.full(120, 0.01), np.full(80, 0.04)] + 0.05
    ends = change_points(segment_signal({"rough_z": level}, ["rough_z"]), 8.0)
    assert abs(ends[0] - 120) <= 3 and len(ends) <= 3


def test_the_signal_takes_the_log_of_levels_and_leaves_a_constant_channel_at_zero():
    x = segment_signal({"vib_z": np.array([0.0, 1.0, 3.0]), "roll": np.full(3, 0.2)}, ["vib_z", "roll"])
    logs = np.log(np.array([0.0, 1.0, 3.0]) + LEVEL_FLOOR)
    np.testing.assert_allclose(x[:, 0], (logs - logs.mean()) / logs.std())
    np.testing.assert_array_equal(x[:, 1], 0.0)
    assert np.array_equal(change_points(x[:4], 1.0), [3])  # shorter than two segments: one segment


def test_each_segment_takes_its_majority_and_blanks_and_kept_classes_stay():
    labels = np.array(["", "a", "b", "a", "kerb", "b", "b", "a", "", "c"], dtype=object)
    voted = segment_vote(labels, np.array([5, 10]), keep=("kerb",))
    assert list(voted) == ["", "a", "a", "a", "kerb", "b", "b", "b", "", "b"]
    tie = segment_vote(np.array(["b", "a", "a", "b"], dtype=object), np.array([4]))
    assert list(tie) == ["b"] * 4  # a tie goes to the label that came first


def test_each_run_outside_the_background_is_one_event_with_its_majority_label():
    labels = np.array(["", "", "straight", "gentle", "sharp", "sharp", "gentle", "sharp", "straight", "sharp", "kerb",
                       "gentle", "gentle"], dtype=object)
    ends = event_ends(labels, "straight")
    assert list(ends) == [3, 8, 9, 13]
    voted = segment_vote(labels, ends, keep=("kerb",))
    assert list(voted) == ["", "", "straight"] + ["sharp"] * 5 + ["straight", "gentle", "kerb", "gentle", "gentle"]
    assert list(event_ends(np.array(["straight"] * 3), "straight")) == [3]


def test_the_event_background_is_the_one_given_class_a_model_has():
    classes = ["straight", "gentle-turn", "sharp-turn"]
    assert event_background(("smooth", "straight"), classes) == "straight"
    assert event_background(("smooth",), classes) is None
    with pytest.raises(InputError, match="--events straight, gentle-turn: give one background class per model"):
        event_background(("straight", "gentle-turn"), classes)


def test_event_edges_move_to_where_the_channel_crosses_the_level_off_the_background_median():
    labels = np.array(["straight"] * 10 + ["sharp"] * 6 + ["straight"] * 10, dtype=object)
    values = np.r_[np.zeros(7), np.full(7, 0.3), np.full(12, 0.05)] + 1.0  # a bias of 1 cancels
    edged = event_edges(labels, values, "straight", 0.1, reach=20)
    assert list(np.flatnonzero(edged == "sharp")) == list(range(7, 14))  # started 3 samples sooner, ended 2 sooner
    short = event_edges(labels, values, "straight", 0.1, reach=2)
    assert list(np.flatnonzero(short == "sharp")) == list(range(8, 14))  # at most 2 samples either way
    blank = labels.copy()
    blank[8] = ""
    assert list(np.flatnonzero(event_edges(blank, values, "straight", 0.1, 20) == "sharp")) == list(range(9, 14))
    quiet = event_edges(labels, np.zeros(26), "straight", 0.1, reach=20)
    assert list(np.flatnonzero(quiet == "sharp")) == [15]  # an event never vanishes
    np.testing.assert_array_equal(event_edges(labels, values, "straight", 5.0, reach=0), labels)


def test_edge_levels_and_the_model_edge_are_checked():
    assert edge_levels(["yaw_rate=0.09"]) == {"yaw_rate": 0.09} and edge_levels([]) == {}
    for bad in ("yaw_rate", "yaw_rate=-1", "=0.1", "yaw_rate=fast", "yaw_rate=nan"):
        with pytest.raises(InputError, match=f"--edges {bad}: give CHANNEL=LEVEL"):
            edge_levels([bad])
    assert model_edge({}, ["yaw_rate"], None) is None
    assert model_edge({"yaw_rate": 0.09}, ["yaw_rate"], "straight") == ("yaw_rate", 0.09)
    with pytest.raises(InputError, match=r"--edges roll: not a channel of the model \(yaw_rate\)"):
        model_edge({"roll": 0.1}, ["yaw_rate"], "straight")
    with pytest.raises(InputError, match="--edges yaw_rate, roll: give one channel per model"):
        model_edge({"yaw_rate": 0.09, "roll": 0.1}, ["yaw_rate", "roll"], "straight")
    with pytest.raises(InputError, match="--edges yaw_rate: the model runs no event vote; .* --events"):
        model_edge({"yaw_rate": 0.09}, ["yaw_rate"], None)


@pytest.mark.parametrize("bad", [-1.0, float("nan"), float("inf"), True, "4"])
def test_a_bad_penalty_is_refused(bad):
    with pytest.raises(InputError, match=r"--segments"):
        check_penalty(bad)
    assert check_penalty(0) is None and check_penalty(None) is None and check_penalty(4) == 4.0


def test_the_vote_labels_only_labelled_samples_changes_less_and_is_in_the_meta(model, raw):
    ride = with_gap(raw.select_experiment(2), 400, 440)
    plain = classify_recording(model, ride, centred=True)
    voted = voted_labels(model, ride, Votes(segments=4.0))
    np.testing.assert_array_equal(voted.labelled(), plain.labelled())
    flips = lambda lab: int(np.sum(lab[1:] != lab[:-1]))  # noqa: E731
    assert flips(voted.label) < flips(plain.label)
    assert voted.meta["segments"] == 4.0 and voted.meta["keep"] == [] and "segments" not in plain.meta
    truth = ride.truth["label"]
    right = lambda lab: np.mean(lab.label[lab.labelled()] == truth[lab.labelled()])  # noqa: E731
    print(f"centred {right(plain):.3f}, segment vote {right(voted):.3f}")
    assert right(voted) >= right(plain) - 0.02


def test_kept_classes_keep_their_labels_and_an_unknown_class_is_refused(model, raw):
    ride = raw.select_experiment(2)
    plain = classify_recording(model, ride, centred=True)
    kept = voted_labels(model, ride, Votes(segments=4.0, keep=("sudden-braking",)))
    was = plain.label == "sudden-braking"
    assert was.any()
    np.testing.assert_array_equal(kept.label[was], "sudden-braking")
    with pytest.raises(InputError, match=r"--keep kerb: not a class of the model"):
        voted_labels(model, ride, Votes(segments=4.0, keep=("kerb",)))


def test_the_event_vote_makes_each_stop_one_label_and_is_in_the_meta(model, raw):
    ride = raw.select_experiment(2)
    voted = voted_labels(model, ride, Votes(segments=4.0, events=("cruising",)))
    assert voted.meta["events"] == "cruising"
    assert voted_labels(model, ride, Votes(segments=4.0)).meta["events"] == ""
    label = voted.label.astype(str)
    ends = event_ends(label, "cruising")
    stops = [label[start:end] for start, end in zip([0, *ends[:-1]], ends) if label[start] not in ("cruising", "")]
    assert stops and all(len(set(stop)) == 1 for stop in stops)
    with pytest.raises(InputError, match=r"--events straight: not a class of the model"):
        voted_labels(model, ride, Votes(events=("straight",)))


def test_event_edges_move_labels_only_within_a_window_of_an_event_edge_and_are_in_the_meta(model, raw):
    ride = raw.select_experiment(2)
    voted = voted_labels(model, ride, Votes(segments=4.0, events=("cruising",)))
    edged = voted_labels(model, ride, Votes(segments=4.0, events=("cruising",), edges={"lean": 0.04}))
    assert edged.meta["edges"] == {"lean": 0.04} and voted.meta["edges"] == {}
    np.testing.assert_array_equal(edged.labelled(), voted.labelled())
    moved = np.flatnonzero(edged.label != voted.label)
    assert len(moved)
    inside = (voted.label != "cruising") & (voted.label != "")
    edges = np.flatnonzero(inside[1:] != inside[:-1]) + 1
    assert all(np.min(np.abs(edges - k)) <= model.window for k in moved)
    with pytest.raises(InputError, match="--edges lean: the model runs no event vote"):
        voted_labels(model, ride, Votes(edges={"lean": 0.04}))


def test_votes_on_labels_already_made_equal_the_votes_of_one_classification(model, raw):
    ride = with_gap(raw.select_experiment(2), 400, 440)
    plain = classify_recording(model, ride, centred=True)
    votes = Votes(segments=4.0, keep=("sudden-braking",), events=("cruising",), edges={"lean": 0.04})
    once = voted_labels(model, ride, votes)
    again = apply_votes(model, ride, plain, votes)
    np.testing.assert_array_equal(again.label, once.label)
    assert again.meta == once.meta and "segments" not in plain.meta
    assert apply_votes(model, ride, plain, Votes()) is plain
    with pytest.raises(InputError, match="labels of this recording made without votes"):
        apply_votes(model, ride, once, Votes(segments=4.0))
    with pytest.raises(InputError, match="labels of this recording made without votes"):
        apply_votes(model, raw.select_experiment(1), plain, Votes(segments=4.0))
    with pytest.raises(InputError, match="--events straight: not a class of the model"):
        apply_votes(model, ride, plain, Votes(events=("straight",)))


def test_change_points_equal_the_breakpoints_of_ruptures_pelt():
    ruptures = pytest.importorskip("ruptures")
    rng = np.random.default_rng(1)
    for _ in range(40):
        n, d = int(rng.integers(6, 300)), int(rng.integers(1, 4))
        pieces = [rng.normal(rng.normal(0.0, 2.0, d), 1.0, (int(rng.integers(3, 60)), d)) for _ in range(n // 3)]
        x = np.concatenate(pieces)[:n]
        penalty, min_size = float(rng.choice([0.5, 2.0, 8.0, 30.0])), int(rng.choice([1, 2, 3, 5]))
        reference = ruptures.Pelt(model="l2", min_size=min_size, jump=1).fit(x).predict(pen=penalty)
        np.testing.assert_array_equal(change_points(x, penalty, min_size), reference)
