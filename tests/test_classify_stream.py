"""Streaming classification gives the batch path's causal labels sample for sample."""

import numpy as np
import pytest
from classify_fixtures import model, raw, truth_model, with_gap  # noqa: F401 (fixtures)

from spotfree.classify.batch import classify_recording
from spotfree.classify.stream import RideClassifier
from spotfree.errors import InputError
from spotfree.signal.features import ride_features

L = 20


def stream_labels(classifier, rec, times=True):
    """Feed ``rec``'s raw IMU and GPS speed sample by sample; labels with None as ``""``."""
    acc, gyr = rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"])
    ts = rec.time if times else [None] * len(rec)
    return np.array([classifier.update(a, g, t, v) or "" for a, g, t, v in zip(acc, gyr, ts, rec.channels["speed"])],
                    dtype=object)


def test_stream_equals_batch_on_two_simulated_rides(model, raw):
    # the clock restarts at 0 s in the second ride: a time that does not increase starts a new segment
    labels = stream_labels(RideClassifier(model), raw)
    batch = classify_recording(model, raw)
    np.testing.assert_array_equal(labels, batch.label)
    assert len(set(labels) - {""}) >= 2


def test_stream_equals_batch_across_a_gap(model, raw):
    ride = with_gap(raw.select_experiment(2), 300, 330)
    clf = RideClassifier(model)
    labels = stream_labels(clf, ride, times=False)  # NaN samples end the segment without any time stamps
    np.testing.assert_array_equal(labels, classify_recording(model, ride).label)
    assert np.all(labels[300:330 + L - 1] == "") and labels[330 + L - 1] != ""


@pytest.mark.parametrize("channels, normalisation, step", [(("lean", "acc_long"), "scale", 4),
                                                          (("lean", "acc_x"), "unit", 1)])
def test_stream_equals_batch_with_smoothing_step_unit_windows_and_gps_speed(raw, channels, normalisation, step):
    ride = with_gap(raw.select_experiment(2), 250, 270)
    model = truth_model(raw.select_experiment(1), channels=channels, step=step, normalisation=normalisation)
    for smoothing in (None, 5):
        labels = stream_labels(RideClassifier(model, smoothing=smoothing), ride)
        np.testing.assert_array_equal(labels, classify_recording(model, ride, smoothing=smoothing).label)
        assert len(set(labels) - {""}) >= 2


def test_a_long_time_step_starts_a_new_segment(model, raw):
    ride = raw.select_experiment(2).take(slice(0, 200))
    acc, gyr = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"])
    clf = RideClassifier(model)
    for k in range(100):
        clf.update(acc[k], gyr[k], ride.time[k])
    assert clf.update(acc[100], gyr[100], ride.time[99] + 0.6) is None  # 0.6 s > max_gap 0.5 s
    after = [clf.update(acc[k], gyr[k], ride.time[k] + 0.55) for k in range(101, 101 + L)]
    assert after[:L - 2] == [None] * (L - 2) and after[L - 2] is not None
    clf.reset()
    assert clf.update(acc[150], gyr[150]) is None


def test_channel_models_stream_their_channels(raw):
    model = truth_model(raw.select_experiment(1), features="channels")
    feats = ride_features(raw.select_experiment(2), derived=True)
    feats = feats.with_channels({c: feats.channels[c] for c in model.channels})
    clf = RideClassifier(model)
    labels = [clf.update_features(x, t) or "" for x, t in zip(feats.array(model.channels), feats.time)]
    np.testing.assert_array_equal(np.array(labels, dtype=object), classify_recording(model, feats).label)
    with pytest.raises(InputError, match="update_features"):
        clf.update([0, 0, 9.81], [0, 0, 0])
    with pytest.raises(InputError, match="needs 2 values"):
        clf.update_features([1.0, 2.0, 3.0])


def test_a_ride_model_needs_ride_feature_channels(raw):
    model = truth_model(raw.select_experiment(1).take(slice(0, 300)), channels=("lean", "acc_x"))
    model.channels = ["lean", "speedometer"]
    with pytest.raises(InputError, match="speedometer are not ride features"):
        RideClassifier(model)


def test_stream_equals_batch_for_a_model_of_the_general_learner(raw):
    """Models of :class:`~spotfree.learner.SetSupervisedLearner` run live and give the batch labels: a hankel model in
    compiled code like any other, a summary model too, with its representation computed in the compiled step."""
    from spotfree.learner import SetSupervisedLearner
    from spotfree.ride_prior import RidePrior

    feats = ride_features(raw, derived=True)
    rides = [part for _, part in feats.experiments()]
    learner = SetSupervisedLearner(channels=("acc_long", "pitch_rate"), representation="hankel", prior=RidePrior(),
                                   rounds=2, window=20, share_power=0.5, column_share=0.5, smoothing=0.5).fit(rides, [{"cruising", "normal-braking", "sudden-braking"}] * len(rides))
    labels = stream_labels(RideClassifier(learner.model_), raw)
    np.testing.assert_array_equal(labels, classify_recording(learner.model_, raw).label)
    summary = SetSupervisedLearner(channels=("acc_long", "pitch_rate"), rounds=0, window=20, share_power=0.5,
                                   column_share=0.5, smoothing=0.5).fit(
        rides, [{"cruising", "normal-braking", "sudden-braking"}] * len(rides)).model_
    live = RideClassifier(summary)
    assert live._ring.models_["summary"].all() and live._ring.models_["compiled"].all()
    labels = stream_labels(live, raw)
    np.testing.assert_array_equal(labels, classify_recording(summary, raw).label)
