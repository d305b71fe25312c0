"""Scoring of the hand evaluation: collars around true changes of state and the places inside a gesture."""

import numpy as np

from spotfree.evaluation.hand import ONSETS, _accuracy, _near_change, _onset_scores, _places, onset_truth
from spotfree.hand.recognition import HandLabels


def test_collar_leaves_out_the_samples_around_each_change_within_an_experiment():
    truth = np.array(["posture"] * 4 + ["gesture"] * 3 + ["posture"] * 3 + ["gesture"] * 2)
    experiment = np.array([1] * 10 + [2] * 2)
    near = _near_change(truth, experiment, 1)
    assert np.flatnonzero(near).tolist() == [3, 4, 6, 7]  # no change counted across experiments 1 -> 2
    assert np.flatnonzero(_near_change(truth, experiment, 2)).tolist() == [2, 3, 4, 5, 6, 7, 8]


def test_accuracy_with_a_collar_scores_only_the_kept_samples():
    truth_state = np.array(["posture"] * 3 + ["gesture"] * 3 + ["posture"] * 3)
    truth_label = np.array(["straight"] * 3 + ["straight-to-left"] * 3 + ["left"] * 3)
    state = np.array(["posture"] * 4 + ["gesture"] * 1 + ["posture"] * 4)  # the gesture seen late and short
    label = np.where(state == "gesture", "straight-to-left", np.array(["straight"] * 4 + [""] + ["left"] * 4))
    strict = _accuracy(state, label, truth_state, truth_label)
    assert strict["end_gesture"] == 1 / 3 and strict["end_posture"] == 1.0
    keep = ~_near_change(truth_state, np.ones(9, dtype=int), 1)
    assert _accuracy(state, label, truth_state, truth_label, keep)["end_gesture"] == 1.0


def test_places_count_from_both_ends_of_every_gesture():
    truth_state = np.array(["posture"] * 2 + ["gesture"] * 10 + ["posture"] * 2)
    truth_label = np.where(truth_state == "gesture", "straight-to-stop", "straight")
    recognised = np.where(np.arange(14) >= 3, truth_label, "straight")  # first gesture sample missed
    labels = HandLabels(np.arange(14) / 20, np.where(truth_state == "gesture", "gesture", "posture"), recognised,
                        np.full(14, "stop"))
    table = _places({"offline": labels}, truth_state, truth_label, np.ones(14, dtype=int), np.full(14, 0.05))
    rows = table.set_index("place")
    assert rows.loc["start +0", "offline"] == 0.0 and rows.loc["start +1", "offline"] == 1.0
    assert rows.loc["inside", "samples"] == 2 and rows.loc["end -0", "samples"] == 1
    assert rows.loc["postures", "samples"] == 4 and rows.loc["postures", "speed mm/s"] == 50.0


def test_onset_truth_gives_the_slow_ends_of_a_gesture_to_the_postures_around_it():
    truth_state = np.array(["posture"] * 2 + ["gesture"] * 6 + ["posture"] * 2 + ["gesture"] * 2)
    truth_label = np.array(["straight"] * 2 + ["straight-to-stop"] * 6 + ["stop"] * 2 + ["stop-to-straight"] * 2)
    pace = np.array([0, 0, 0.01, 0.3, 0.9, 1.0, 0.4, 0.04, 0, 0, 0.02, 0.03])
    experiment = np.array([1] * 10 + [2] * 2)
    state, label = onset_truth(truth_state, truth_label, pace, experiment, 0.05)
    assert state.tolist() == ["posture"] * 3 + ["gesture"] * 4 + ["posture"] * 5
    assert label.tolist() == (["straight"] * 3 + ["straight-to-stop"] * 4 + ["stop"] * 3
                              + ["stop", "straight"])  # a gesture never as fast as c is split in the middle
    same = onset_truth(truth_state, truth_label, pace, experiment, 0.0)
    assert same[0].tolist() == truth_state.tolist() and same[1].tolist() == truth_label.tolist()


def test_onset_scores_per_threshold_with_and_without_a_collar():
    truth_state = np.array(["posture"] * 4 + ["gesture"] * 10 + ["posture"] * 4)
    truth_label = np.where(truth_state == "gesture", "straight-to-stop", np.array(["straight"] * 9 + ["stop"] * 9))
    pace = np.r_[np.zeros(4), [0.01, 0.08, 0.3, 0.7, 0.95, 1.0, 0.8, 0.4, 0.08, 0.02], np.zeros(4)]
    seen = np.r_[np.zeros(5, bool), np.ones(8, bool), np.zeros(5, bool)]  # the recogniser's gesture: samples 5-12
    labels = HandLabels(np.arange(18) / 20, np.where(seen, "gesture", "posture"),
                        np.where(seen, "straight-to-stop", np.array(["straight"] * 9 + ["stop"] * 9)),
                        np.full(18, "stop"))
    scores = _onset_scores(labels, truth_state, truth_label, pace, np.ones(18, dtype=int))
    assert list(scores) == [0.0, *ONSETS] and all(set(v) == {0, 2} for v in scores.values())
    assert scores[0.0][0]["end_gesture"] == 8 / 10  # the slow first and last samples missed
    assert scores[0.05][0]["end_gesture"] == 1.0 and scores[0.05][0]["end_posture"] == 1.0
    assert scores[0.10][0]["end_posture"] == 10 / 12  # called gesture before the onset and after the end
    assert scores[0.0][2]["end_gesture"] == 1.0 and scores[0.0][2]["samples"] == 18 - 8


def test_gesture_events_match_one_recognised_event_per_true_gesture_near_its_onset():
    from spotfree.classify.runs import RunEvent
    from spotfree.evaluation.hand import gesture_events

    truth = np.array(["straight"] * 10 + ["straight-to-left"] * 10 + ["left"] * 20 + ["left-to-straight"] * 10)
    events = [RunEvent("straight-to-left", 12, 18),  # two samples late: matched
             RunEvent("straight-to-left", 30, 32), RunEvent("straight-to-stop", 48, 50)]  # two false detections
    scores = gesture_events(events, truth, np.ones(len(truth), dtype=int), rate=20.0, tolerance=0.5)
    assert (scores["events"], scores["detections"], scores["matched"]) == (2, 3, 1)
    assert scores["precision"] == 1 / 3 and scores["recall"] == 1 / 2 and scores["f1"] == 2 / 5
    assert gesture_events(events, truth, np.ones(len(truth), dtype=int), rate=20.0, tolerance=0.05)["matched"] == 0
