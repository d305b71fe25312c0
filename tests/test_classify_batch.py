"""Batch classification: alignment of windows with samples, gaps and experiments, step, smoothing, bad input."""

import numpy as np
import pytest
from classify_fixtures import model, raw, truth_model, with_gap  # noqa: F401 (fixtures)

from spotfree.classify.batch import classify_recording, dictionary_classifier, model_features
from spotfree.classify.smoothing import MajorityVote, majority_vote, vote_samples
from spotfree.errors import InputError
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario
from spotfree.windows import block_hankel, with_affine_row

L = 20


@pytest.fixture(scope="module")
def test_ride(raw):
    return raw.select_experiment(2)


@pytest.fixture(scope="module")
def causal(model, test_ride):
    return classify_recording(model, test_ride)


def test_a_causal_label_is_the_class_of_the_window_ending_at_that_sample(model, test_ride, causal):
    feats = model_features(model, test_ride)
    x = feats.array(model.channels) / model.scale
    clf = dictionary_classifier(model)
    for t in (L - 1, 300, 777, len(x) - 1):
        window = block_hankel(x[t - L + 1:t + 1], L)
        assert causal.label[t] == clf.predict(with_affine_row(window, 6.0).T)[0]
    assert np.all(causal.label[:L - 1] == "") and np.all(causal.label[L - 1:] != "")
    assert causal.meta["alignment"] == "causal" and causal.meta["offset"] == 0


def test_centred_labels_are_the_causal_ones_moved_back_half_a_window(model, test_ride, causal):
    centred = classify_recording(model, test_ride, centred=True, smoothing=0)
    o = L // 2
    assert centred.meta["alignment"] == "centred" and centred.meta["offset"] == o and centred.meta["smoothing"] == 0
    np.testing.assert_array_equal(centred.label[L - 1 - o:len(centred) - o], causal.label[L - 1:])
    assert np.all(centred.label[:L - 1 - o] == "") and np.all(centred.label[len(centred) - o:] == "")


def test_offline_labels_get_the_model_s_smoothing_vote_by_default_and_live_ones_none(model, test_ride, causal):
    raw = classify_recording(model, test_ride, centred=True, smoothing=0).label
    voted = classify_recording(model, test_ride, centred=True)
    n = vote_samples(model.parameters.get("smoothing", 0.5), model.rate)
    assert n % 2 == 1 and n >= 3
    assert voted.meta["smoothing"] == n and causal.meta["smoothing"] == 0
    np.testing.assert_array_equal(voted.label, majority_vote(raw, n, centred=True))
    starts = np.flatnonzero(np.r_[True, voted.label[1:] != voted.label[:-1]])
    lengths = np.diff(np.r_[starts, len(voted.label)])
    inner = (voted.label[starts] != "") & (starts > 0) & (starts + lengths < len(voted.label))
    assert (lengths[inner] >= 2).all()  # no label holds for a single sample between two others
    one = np.flatnonzero(np.r_[False, (raw[1:-1] != raw[:-2]) & (raw[1:-1] != raw[2:]) & (raw[:-2] == raw[2:]), False])
    assert len(one) and (voted.label[one] == raw[one - 1]).all()  # each such flicker of the raw labels is gone


@pytest.mark.parametrize("seconds, rate, n", [(0.5, 20.0, 11), (0.1, 20.0, 3), (0.45, 20.0, 9), (0.0, 20.0, 1),
                                              (0.5, 100.0, 51), (0.02, 20.0, 1)])
def test_the_vote_spans_the_smoothing_in_an_odd_number_of_samples(seconds, rate, n):
    assert vote_samples(seconds, rate) == n


def test_labels_follow_the_truth_and_centred_windows_are_more_accurate(model, test_ride, causal):
    truth = test_ride.truth["label"]
    centred = classify_recording(model, test_ride, centred=True)
    accuracy = {name: np.mean(lab.label[lab.labelled()] == truth[lab.labelled()])
                for name, lab in (("causal", causal), ("centred", centred))}
    print(f"accuracy on the second ride (dictionary from the first): {accuracy}")
    assert accuracy["causal"] > 0.8
    assert accuracy["centred"] > accuracy["causal"]


def test_labels_stop_at_a_gap_and_resume_one_window_after_it(model, test_ride, causal):
    a, b = 400, 440
    labels = classify_recording(model, with_gap(test_ride, a, b))
    assert np.all(labels.label[a:b + L - 1] == "")
    assert np.all(labels.label[b + L - 1:] != "") and np.all(labels.label[L - 1:a] != "")
    np.testing.assert_array_equal(labels.label[:a], causal.label[:a])
    after = classify_recording(model, test_ride.take(slice(b, None)))
    np.testing.assert_array_equal(labels.label[b:], after.label)  # nothing from before the gap leaks across it
    (gap,) = labels.breaks()
    assert gap.stopped == pytest.approx(test_ride.time[a - 1]) and gap.resumed == pytest.approx(test_ride.time[b + L - 1])
    assert "stop after" in str(gap) and "resume at" in str(gap)


def test_no_window_spans_two_experiments(model, raw):
    both = classify_recording(model, raw)
    np.testing.assert_array_equal(both.experiment, raw.experiment)
    for k, part in raw.experiments():
        np.testing.assert_array_equal(both.label[raw.experiment == k], classify_recording(model, part).label)
    assert both.breaks() == []  # a new experiment is not a break inside one


def test_a_step_holds_each_label_until_the_next_window(raw, test_ride, causal):
    stepped = classify_recording(truth_model(raw.select_experiment(1), step=3), test_ride)
    ends = np.arange(L - 1, len(test_ride), 3)
    np.testing.assert_array_equal(stepped.label[ends], causal.label[ends])
    held = np.repeat(causal.label[ends], 3)[:len(test_ride) - (L - 1)]
    np.testing.assert_array_equal(stepped.label[L - 1:], held)


def test_a_feature_log_is_classified_like_the_raw_log_it_came_from(model, test_ride, causal):
    feats = ride_features(test_ride, derived=True)
    feats = feats.with_channels({c: feats.channels[c] for c in model.channels})
    np.testing.assert_array_equal(classify_recording(model, feats).label, causal.label)


def test_a_model_of_other_channels_or_rate_is_refused_naming_both(model, test_ride):
    plain = ride_features(test_ride)  # no lean channel
    with pytest.raises(InputError, match=r"model expects channels lean,acc_x at 20 Hz; .* has roll,pitch,.* at 20 Hz"):
        classify_recording(model, plain)
    fast = simulate_scenario("cruising", repeats=1, seed=0, rate=50.0).take(slice(0, 200))
    with pytest.raises(InputError, match=r"at 20 Hz; .* at 50 Hz; resample the log to 20 Hz"):
        classify_recording(model, fast)


def test_too_short_a_log_and_bad_smoothing_are_refused(model, test_ride):
    with pytest.raises(InputError, match="as long as the model's window"):
        classify_recording(model, test_ride.take(slice(0, L - 1)))
    with pytest.raises(InputError, match="smoothing"):
        classify_recording(model, test_ride, smoothing=-2)


def test_smoothing_is_off_by_default_and_never_labels_an_unlabelled_sample(model, test_ride, causal):
    assert causal.meta["smoothing"] == 0
    gappy = with_gap(test_ride, 400, 440)
    for centred in (False, True):
        plain = classify_recording(model, gappy, centred=centred)
        smooth = classify_recording(model, gappy, centred=centred, smoothing=7)
        np.testing.assert_array_equal(smooth.labelled(), plain.labelled())
        assert smooth.meta["smoothing"] == 7
        assert _changes(smooth.label) <= _changes(plain.label)


def _changes(labels):
    return int(np.sum(labels[1:] != labels[:-1]))


def test_majority_vote_removes_short_flickers_and_ties_go_to_the_most_recent():
    raw = np.array(list("aaabaaabbbbaa"), dtype=object)
    np.testing.assert_array_equal(majority_vote(raw, 1), raw)
    np.testing.assert_array_equal(majority_vote(raw, 3), np.array(list("aaaaaaaabbbba"), dtype=object))
    np.testing.assert_array_equal(majority_vote(raw, 3, centred=True), np.array(list("aaaaaaabbbbaa"), dtype=object))
    np.testing.assert_array_equal(majority_vote(np.array(list("aabb"), dtype=object), 4),
                                  np.array(list("aaab"), dtype=object))  # 2-2 tie: the most recent, b
    with_holes = np.array(["", "", "a", "b", "b", ""], dtype=object)
    np.testing.assert_array_equal(majority_vote(with_holes, 3), np.array(["", "", "a", "b", "b", ""], dtype=object))
    vote = MajorityVote(3)
    assert [vote.update(x) for x in "abb"] == ["a", "b", "b"]
    vote.reset()
    assert vote.update(None) is None and vote.update("c") == "c"
