"""The shared ring buffer of streaming windows: windows equal the batch windows, compiled CRC_RLS and kernel CRC_RLS
equal the batch labels."""

import numpy as np
import pytest
from classify_fixtures import model, raw, truth_model, with_gap  # noqa: F401 (fixtures)

from spotfree.classify.base import UNKNOWN
from spotfree.classify.batch import classify_recording, dictionary_classifier, model_affine
from spotfree.classify.ring import ModelRing
from spotfree.classify.stream import PRODUCED, RideClassifier
from spotfree.errors import InputError
from spotfree.signal.features import ride_features
from spotfree.windows import ChannelScaling, recording_windows, with_affine_row


class WindowRecorder:
    """A stand-in classifier that keeps every window it is asked about (so the ring's windows can be compared)."""

    def __init__(self):
        self.classes_ = np.array(["seen"])
        self.windows = []

    def predict_one(self, y):
        self.windows.append(np.array(y))
        return "seen"


def batch_windows(dictionary, feats):
    """The batch path's windows of ``feats`` for the model ``dictionary`` (causal, every ``step``), one per row."""
    windows = recording_windows(feats, tuple(dictionary.channels), dictionary.window, dictionary.step,
                                ChannelScaling(tuple(dictionary.channels), dictionary.scale), dictionary.normalisation)
    return with_affine_row(windows.matrix, model_affine(dictionary)).T


@pytest.mark.parametrize("normalisation, step, affine", [("scale", 1, 6.0), ("unit", 3, 0.0)])
def test_ring_windows_equal_the_batch_windows_bit_for_bit(raw, normalisation, step, affine):
    ride = raw.select_experiment(2).take(slice(0, 300))
    feats = ride_features(ride, derived=True)
    short = truth_model(raw.select_experiment(1), channels=("vib_z", "lean"), window=7, step=step,
                        normalisation=normalisation, affine=affine)
    long = truth_model(raw.select_experiment(1), channels=("acc_x", "yaw_rate", "acc_long"), window=25)
    recorders = [WindowRecorder(), WindowRecorder()]
    picks = [np.array([PRODUCED.index(c) for c in m.channels]) for m in (short, long)]
    ring = ModelRing([short, long], picks, len(PRODUCED), recorders)
    values = feats.array(list(PRODUCED))
    for row in values:
        ring.push(np.ascontiguousarray(row))
    for recorder, m in zip(recorders, (short, long)):
        np.testing.assert_array_equal(np.array(recorder.windows), batch_windows(m, feats))


@pytest.mark.parametrize("method", ["crc", "kcrc"])
def test_compiled_crc_with_rejection_equals_the_batch_labels(model, raw, method):
    ride = with_gap(raw.select_experiment(2), 200, 215)
    free = dictionary_classifier(model, method)
    windows = batch_windows(model, ride_features(raw.select_experiment(2).take(slice(0, 200)), derived=True))
    scores = np.sort(free.rejection_score(windows))
    k = int(0.7 * len(scores))  # about 30 % rejected; the threshold halfway between two scores, far from rounding
    clf = dictionary_classifier(model, method, reject=float(scores[k] + scores[k + 1]) / 2)
    stream = RideClassifier(model, classifier=clf)
    acc, gyr, speed = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.channels["speed"]
    labels = np.array([stream.update(a, w, t, v) or "" for a, w, t, v in zip(acc, gyr, ride.time, speed)])
    batch = classify_recording(model, ride, classifier=clf).label
    np.testing.assert_array_equal(labels, batch)
    assert 0.1 < np.mean(labels == UNKNOWN) < 0.9


def test_blocks_of_samples_give_the_labels_of_one_sample_at_a_time(model, raw):
    feats = ride_features(raw.select_experiment(2).take(slice(0, 300)), derived=True)
    other = truth_model(raw.select_experiment(1), channels=("acc_x", "lean"), window=9, step=2)
    models = [model, other]
    picks = [np.array([PRODUCED.index(c) for c in m.channels]) for m in models]
    classifiers = [dictionary_classifier(model, "kcrc"), dictionary_classifier(other, "crc")]
    one, blocks = (ModelRing(models, picks, len(PRODUCED), classifiers) for _ in range(2))
    values = feats.array(list(PRODUCED))
    want = [one.push(np.ascontiguousarray(row)) for row in values]
    got = [labels for k in range(0, len(values), 7) for labels in blocks.push_block(values[k:k + 7])]
    assert got == want
    assert got[5] == [None, None] and got[20][0] is not None and len({g[0] for g in got[20:]}) > 1


def test_a_classifier_without_a_compiled_path_gets_the_same_windows_and_labels(model, raw):
    ride = raw.select_experiment(2).take(slice(0, 160))
    stream = RideClassifier(model, method="nearest")
    acc, gyr, speed = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.channels["speed"]
    labels = np.array([stream.update(a, w, t, v) or "" for a, w, t, v in zip(acc, gyr, ride.time, speed)])
    np.testing.assert_array_equal(labels, classify_recording(model, ride, method="nearest").label)


def test_picks_that_do_not_match_the_model_are_refused(model):
    with pytest.raises(InputError, match="one index below 13 per channel"):
        ModelRing([model], [np.array([0])], 13, [dictionary_classifier(model)])
    with pytest.raises(InputError, match="one index below 13 per channel"):
        ModelRing([model], [np.array([0, 13])], 13, [dictionary_classifier(model)])
    with pytest.raises(InputError, match="one channel pick and one classifier per model"):
        ModelRing([model], [np.array([0, 1])], 13, [])
