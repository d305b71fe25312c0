"""Two-stage hand recognition: spotting-free training (truth never read), accuracy on a held-out person, streaming
equal to batch, model files, commands and their confirmation rule."""

import numpy as np
import pytest

from spotfree.classify.batch import classify_recording
from spotfree.classify.confined import classify_stretches
from spotfree.errors import InputError
from spotfree.hand.commands import COMMANDS, CommandFilter, command_latencies
from spotfree.hand.features import FEATURES
from spotfree.hand.log import frames_to_recording
from spotfree.hand.motion import MOTION, motion_channels
from spotfree.hand.recognition import (
    HandModel, HandRecognizer, declared, features_of, gesture_samples, recognise, session_tasks, train_hand,
    vote_stretches,
)
from spotfree.hand.vocabulary import GESTURES, POSTURES, TRAINING_TASKS
from spotfree.sim.hand import simulate_hands


@pytest.fixture(scope="module")
def training():
    rec = frames_to_recording(simulate_hands(people=2, seed=4, rounds=3, protocol="training"))
    return [(features_of(part), task) for part, task in session_tasks(rec)]


@pytest.fixture(scope="module")
def result(training):
    return train_hand(training)


@pytest.fixture(scope="module")
def test_run():
    return features_of(frames_to_recording(simulate_hands(people=1, seed=4, rounds=2, first=101)))


def test_training_protocol_sessions_and_declarations(training):
    assert [task for _, task in training] == list(TRAINING_TASKS) * 2
    assert declared("hold", "state") == ["posture"] and declared("hold", "gesture") == []
    assert declared("round-stop", "gesture") == ["hold", "straight-to-stop", "stop-to-straight"]
    for rec, task in training:
        assert {str(s) for s in rec.truth["state"]} == ({"posture"} if task == "hold" else {"posture", "gesture"})


def test_each_stage_names_all_its_classes(result):
    model = result.model
    assert sorted(model.state.classes) == ["gesture", "posture"]
    assert sorted(model.posture.classes) == sorted(POSTURES)
    assert sorted(model.gesture.classes) == sorted(GESTURES)


def test_truth_is_never_read_by_training(training, result, tmp_path):
    rng = np.random.default_rng(3)
    scrambled = []
    for rec, task in training:
        copy = rec.take(slice(None))
        copy.truth = {k: rng.permutation(v) for k, v in copy.truth.items()}
        scrambled.append((copy, task))
    train_hand(scrambled).model.save(tmp_path / "a.npz")
    result.model.save(tmp_path / "b.npz")
    for name in ("a.npz", "a.live-state.npz", "a.posture.npz", "a.gesture.npz"):
        a, b = np.load(tmp_path / name), np.load(tmp_path / name.replace("a", "b", 1))
        assert a.files == b.files and all(np.array_equal(a[k], b[k]) for k in a.files if k != "metadata")
        assert str(a["metadata"]).replace('"a.', '"b.') == str(b["metadata"])


def test_held_out_person_postures_and_gestures(result, test_run):
    labels = recognise(result.model, test_run)
    state, label = test_run.truth["state"], test_run.truth["label"]
    ok = labels.state != ""
    assert ok.mean() > 0.9
    posture = ok & (state == "posture")
    gesture = ok & (state == "gesture")
    assert (labels.state[posture] == "posture").mean() > 0.9
    # the slow ends of a gesture look like the posture-only sessions, which the learner's absence evidence holds
    # against the gesture state (docs/training.md): live, a quarter of the gesture samples start or end as posture
    assert (labels.state[gesture] == "gesture").mean() > 0.75
    caught = posture & (labels.state == "posture")
    assert (labels.label[caught] == label[caught]).mean() > 0.93  # two training people; four: benchmarks/hand_eval.py
    caught = gesture & (labels.state == "gesture")
    # two training people; chance is 1/8; eight people: benchmarks/results/hand_eval.md
    assert (labels.label[caught] == label[caught]).mean() > 0.5
    assert not (labels.label[~ok] != "").any()


def test_offline_mode_sees_more_of_each_gesture_and_names_each_stretch_once(result, test_run):
    live, offline = recognise(result.model, test_run), recognise(result.model, test_run, offline=True)
    state, label = test_run.truth["state"], test_run.truth["label"]
    gesture = state == "gesture"
    assert (offline.label[gesture] == label[gesture]).mean() > (live.label[gesture] == label[gesture]).mean()
    posture = (state == "posture") & (offline.state != "")
    assert (offline.label[posture] == label[posture]).mean() > 0.9  # two training people
    edges = np.diff(np.r_[0, (offline.state == "gesture").astype(int), 0])
    stretches = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
    assert len(stretches) >= 8 and all(len(set(offline.label[a:b])) == 1 for a, b in stretches)
    assert not (offline.label[offline.state == ""] != "").any()


@pytest.mark.parametrize("offline", [False, True])
def test_gesture_events_are_the_long_enough_gesture_stretches_each_named_once(result, test_run, offline):
    labels = recognise(result.model, test_run, offline=offline)
    edges = np.diff(np.r_[0, (labels.state == "gesture").astype(int), 0])
    stretches = list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))
    shortest = gesture_samples(result.model)
    assert shortest == round(result.model.state.parameters["smoothing"] * result.model.state.rate) > 1
    assert [(e.start, e.stop) for e in labels.events] == [(a, b) for a, b in stretches if b - a >= shortest]
    for event in labels.events:
        names, counts = np.unique(labels.label[event.start:event.stop], return_counts=True)
        assert event.label in GESTURES and counts[list(names).index(event.label)] == counts.max()
    label_runs = sum(1 + int(np.sum(labels.label[a + 1:b] != labels.label[a:b - 1])) for a, b in stretches)
    assert len(labels.events) <= len(stretches) <= label_runs


def test_vote_stretches_gives_each_run_its_most_frequent_label():
    mask = np.array([0, 1, 1, 1, 0, 1, 1, 0, 1], dtype=bool)
    label = np.array(["x", "a", "b", "b", "y", "c", "d", "z", "e"])
    out = vote_stretches(mask, label)
    assert out.tolist() == ["x", "b", "b", "b", "y", "c", "c", "z", "e"]  # a tie goes to the first in the run
    assert vote_stretches(np.zeros(3, dtype=bool), label[:3]).tolist() == ["x", "a", "b"]


def test_streaming_equals_batch_and_gaps_give_no_label(result, test_run):
    labels = recognise(result.model, test_run)
    recogniser = HandRecognizer(result.model)
    rows = test_run.array(FEATURES)
    out = [recogniser.update(row) for row in rows]
    assert [o[0] for o in out] == list(labels.state)
    assert [o[1] for o in out] == list(labels.label)
    assert [o[2] for o in out] == list(labels.command)
    gap = ~np.all(np.isfinite(rows), axis=1)
    assert gap.any() and all(out[i] == ("", "", "stop") for i in np.flatnonzero(gap))
    recogniser.reset()
    assert recogniser.events_ == labels.events and labels.events
    assert recogniser.update({c: v for c, v in zip(FEATURES, rows[-1])})[2] in COMMANDS.values()
    with pytest.raises(InputError, match="hand sample holds"):
        recogniser.update(rows[0][:5])


def test_model_files_round_trip_and_missing_sibling_is_clear(result, test_run, tmp_path):
    result.model.save(tmp_path / "m.npz")
    loaded = HandModel.load(tmp_path / "m.npz")
    a, b = recognise(result.model, test_run), recognise(loaded, test_run)
    assert list(a.label) == list(b.label) and list(a.command) == list(b.command)
    (tmp_path / "m.gesture.npz").unlink()
    with pytest.raises(InputError, match="gesture stage"):
        HandModel.load(tmp_path / "m.npz")
    result.model.posture.save(tmp_path / "plain.npz")
    with pytest.raises(InputError, match="not a hand model"):
        HandModel.load(tmp_path / "plain.npz")


def test_a_model_without_a_live_state_labels_live_with_its_state_stage(result, test_run, tmp_path):
    old = HandModel(result.model.state, result.model.posture, result.model.gesture)
    old.save(tmp_path / "old.npz")
    assert not (tmp_path / "old.live-state.npz").exists()
    loaded = HandModel.load(tmp_path / "old.npz")
    assert loaded.live_state is None and set(loaded.stages()) == {"state", "posture", "gesture"}
    live = recognise(loaded, test_run)
    state = classify_recording(result.model.state, test_run).label
    assert list(live.state[live.state != ""]) == list(state[live.state != ""])


def test_live_labels_use_the_live_state_and_postures_read_their_stretch_only(result, test_run):
    model = result.model
    assert model.live_state.representation == "hankel" and model.state.representation == "summary"
    live, offline = recognise(model, test_run), recognise(model, test_run, offline=True)
    for labels, state_model, centred in ((live, model.live_state, False), (offline, model.state, True)):
        state = classify_recording(state_model, test_run, centred=centred).label
        ok = labels.state != ""
        assert list(labels.state[ok]) == list(state[ok])
        posture = classify_stretches(model.posture, test_run, state == "posture", centred=centred)
        at = labels.state == "posture"
        assert at.sum() > 100 and list(labels.label[at]) == list(posture[at])


def test_a_log_that_is_not_the_protocol_is_refused(test_run):
    with pytest.raises(InputError, match="9 sessions per person"):
        session_tasks(test_run)
    with pytest.raises(InputError, match="lack the task"):
        train_hand([(test_run, "hold")])


def test_motion_channels_are_zero_for_a_still_hand_and_nan_at_segment_starts(test_run):
    still = test_run.take(slice(0, 30))
    for name in ("vel_x", "vel_y", "vel_z"):
        still.channels[name] = np.zeros(30)
    for name in [c for c in FEATURES if c.startswith(("normal", "dir", "grab", "ext"))]:
        still.channels[name] = np.full(30, still.channels[name][0])
    out = motion_channels(still)
    assert np.isnan(out.channels["turn"][0]) and np.isnan(out.channels["flex"][0])
    assert np.allclose([out.channels[c][1:] for c in MOTION], 0.0, atol=1e-6)


def test_signed_rates_tell_a_turn_from_its_reverse(test_run):
    part = test_run.take(slice(0, 21))
    angle = np.linspace(0.0, 1.0, 21)  # the hand direction turns 1 rad in 1 s about the vertical, toward -x
    part.channels.update(dir_x=-np.sin(angle), dir_y=np.zeros(21), dir_z=-np.cos(angle))
    forward = motion_channels(part)
    part.channels.update(dir_x=-np.sin(angle[::-1]), dir_z=-np.cos(angle[::-1]))
    backward = motion_channels(part)
    assert forward.channels["drate_x"][1:] == pytest.approx(-np.cos(angle[1:] - 0.025), rel=2e-3, nan_ok=True)
    assert np.all(forward.channels["drate_x"][1:] < -0.5) and np.all(backward.channels["drate_x"][1:] > 0.5)
    assert forward.channels["turn"][1:] == pytest.approx(backward.channels["turn"][1:], nan_ok=True)  # unsigned


def test_command_changes_only_after_confirmation():
    f = CommandFilter(rate=20.0, confirm=0.25)
    assert f.needed == 5
    stream = [("posture", "straight")] * 5 + [("gesture", "straight-to-left")] * 3 + [("posture", "left")] * 4
    out = [f.update(*x) for x in stream]
    assert out[:4] == ["stop"] * 4 and out[4] == "go-straight"
    assert out[5:] == ["go-straight"] * 7
    assert f.update("posture", "left") == "turn-left"
    assert f.update("posture", "right") == "turn-left"  # one sample of another posture does not switch
    assert f.update("", "") == "stop"  # no hand: stop at once
    with pytest.raises(InputError):
        CommandFilter(rate=20.0, confirm=-1)


def test_command_latency_from_true_onsets():
    t = np.arange(12) / 20.0
    state = np.array(["posture"] * 3 + ["gesture"] * 3 + ["posture"] * 6)
    label = np.array(["straight"] * 3 + ["straight-to-left"] * 3 + ["left"] * 6)
    command = np.array(["go-straight"] * 8 + ["turn-left"] * 4)
    lat = command_latencies(t, command, state, label)
    assert lat.posture.tolist() == ["left"] and lat.latency == pytest.approx([0.1])
    assert np.isnan(command_latencies(t, np.array(["stop"] * 12), state, label).latency[0])


def test_dropping_the_hold_class_drops_its_causal_columns_too():
    from spotfree.hand.recognition import HOLD, without_class
    from spotfree.model import DictionaryModel

    classes = ["a-to-b", HOLD, "b-to-a"]
    columns = np.arange(12.0).reshape(2, 6)
    model = DictionaryModel(classes=classes, channels=["x"], rate=20.0, window=2, step=1, normalisation="scale",
                            scale=np.ones(1), dictionary=columns, column_class=np.array([0, 1, 2, 2, 1, 0]),
                            causal_dictionary=columns[:, ::-1], causal_column_class=np.array([0, 1, 2, 2, 1, 0]))
    out = without_class(model, HOLD)
    assert out.classes == ["a-to-b", "b-to-a"]
    np.testing.assert_array_equal(out.dictionary, columns[:, [0, 2, 3, 5]])
    np.testing.assert_array_equal(out.causal_dictionary, columns[:, ::-1][:, [0, 2, 3, 5]])
    assert out.column_class.tolist() == out.causal_column_class.tolist() == [0, 1, 1, 0]


def test_a_model_on_channels_that_are_not_hand_features_is_a_clear_error(result):
    from dataclasses import replace

    channels = ["wrist_temperature", *result.model.posture.channels[1:]]  # one channel no hand log has
    odd = replace(result.model, posture=replace(result.model.posture, channels=channels))
    with pytest.raises(InputError, match="wrist_temperature.*not hand features"):
        HandRecognizer(odd)
