"""Windows confined to stretches: every sample of a stretch labelled from that stretch only, the streaming labels
equal to the batch ones."""

import numpy as np
import pytest
from classify_fixtures import raw, truth_model  # noqa: F401 (fixtures)

from spotfree.classify.batch import dictionary_classifier
from spotfree.classify.confined import StretchClassifier, classify_stretches, padded_stretch
from spotfree.errors import InputError
from spotfree.signal.features import ride_features

CHANNELS = ("lean", "acc_x")


@pytest.fixture(scope="module")
def feats(raw):
    ride = ride_features(raw.select_experiment(2), derived=True)
    return ride.with_channels({c: ride.channels[c] for c in CHANNELS})


def stretches(n: int) -> np.ndarray:
    """Stretches of several lengths, some shorter than a window, one touching the end."""
    keep = np.zeros(n, dtype=bool)
    for a, b in [(40, 43), (100, 180), (181, 182), (400, 700), (n - 50, n)]:
        keep[a:b] = True
    return keep


@pytest.mark.parametrize("representation, step", [("hankel", 1), ("summary", 1), ("hankel", 4)])
def test_streaming_equals_batch(raw, feats, representation, step):
    model = truth_model(raw.select_experiment(1), channels=CHANNELS, window=10, step=step,
                        representation=representation)
    keep = stretches(len(feats))
    batch = classify_stretches(model, feats, keep)
    stream = StretchClassifier(model)
    x = feats.array(CHANNELS)
    labels = np.array([stream.update(row, inside) for row, inside in zip(x, keep)], dtype=object)
    np.testing.assert_array_equal(labels, batch)
    assert (batch[keep] != "").all() and (batch[~keep] == "").all()
    assert len(set(batch[keep])) >= 2


@pytest.mark.parametrize("centred", [False, True])
def test_a_label_reads_only_its_stretch(raw, feats, centred):
    model = truth_model(raw.select_experiment(1), channels=CHANNELS, window=10)
    keep = stretches(len(feats))
    before = classify_stretches(model, feats, keep, centred=centred)
    rng = np.random.default_rng(0)
    noisy = feats.with_channels({c: np.where(keep, v, v + 5 * rng.standard_normal(len(v)))
                                 for c, v in feats.channels.items()})
    np.testing.assert_array_equal(classify_stretches(model, noisy, keep, centred=centred), before)
    if not centred:  # causal: nothing after a sample changes its label
        cut = 450
        later = feats.with_channels({c: np.r_[v[:cut + 1], v[cut + 1:] + 5] for c, v in feats.channels.items()})
        np.testing.assert_array_equal(classify_stretches(model, later, keep)[:cut + 1], before[:cut + 1])


def test_the_first_sample_of_a_stretch_is_labelled_as_if_held(raw, feats):
    model = truth_model(raw.select_experiment(1), channels=CHANNELS, window=10)
    keep = stretches(len(feats))
    labels = classify_stretches(model, feats, keep)
    x = feats.array(CHANNELS) / model.scale
    held = np.repeat(x[400:401], model.window, axis=0).T.reshape(-1, 1)
    expected = dictionary_classifier(model, causal=True).predict(model.inputs(held))
    assert labels[400] == expected[0]
    padded = padded_stretch(x[100:103], 4, 1)
    np.testing.assert_array_equal(padded, x[[100, 100, 100, 101, 102, 102]])


def test_bad_masks_are_refused(raw, feats):
    model = truth_model(raw.select_experiment(1), channels=CHANNELS, window=10)
    with pytest.raises(InputError, match="one per sample"):
        classify_stretches(model, feats, np.ones(3, dtype=bool))
    nan = feats.with_channels({c: np.r_[np.nan, v[1:]] for c, v in feats.channels.items()})
    keep = np.zeros(len(feats), dtype=bool)
    keep[:5] = True
    assert (classify_stretches(model, nan, keep)[1:5] != "").all()  # a gap ends the segment: the stretch starts after
    with pytest.raises(InputError, match="not finite"):
        StretchClassifier(model).update([np.nan, 0.0], True)
