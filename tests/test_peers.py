"""Peers of the evaluation: supervised MiniRocket, 1-NN, and ClaSP segmentation, on one shared interface.

Floors were measured on the split below (simulator seed 3; train on ride 1 of a normal-braking and a
sudden-braking file, test on ride 2 of each). Balanced accuracy (mean per-class recall) is used because cruising
is 84 % of the test samples: labelling everything "cruising" scores 0.843 accuracy but 1/3 balanced accuracy.
Measured: 1-NN 0.895 accuracy / 0.793 balanced, MiniRocket (840 kernels) 0.885 / 0.789.
"""

import sys
from importlib.util import find_spec

import numpy as np
import pytest
from sklearn.metrics import balanced_accuracy_score

from spotfree.errors import InputError, SpotfreeError
from spotfree.io.recording import Recording
from spotfree.evaluation.peers import ClaspPeer, MiniRocketPeer, NearestNeighbourPeer
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario

needs_aeon = pytest.mark.skipif(find_spec("aeon") is None,
                                reason="MiniRocket and ClaSP come from aeon: pip install -e '.[eval]'")

BALANCED_FLOOR = 0.75


@pytest.fixture(scope="module")
def split():
    files = [ride_features(simulate_scenario(s, repeats=2, seed=3), derived=True)
             for s in ("normal-braking", "sudden-braking")]
    return [f.select_experiment(1) for f in files], [f.select_experiment(2) for f in files]


@pytest.fixture(scope="module")
def minirocket(split):
    return MiniRocketPeer(n_kernels=840).fit(split[0])


def scores(peer, tests):
    truth, labels = [], []
    for rec in tests:
        predicted = peer.predict(rec)
        labelled = predicted != ""
        truth.append(rec.truth["label"][labelled])
        labels.append(predicted[labelled])
    truth, labels = np.concatenate(truth), np.concatenate(labels)
    return float(np.mean(truth == labels)), float(balanced_accuracy_score(truth, labels))


def test_nearest_neighbour_learns_the_braking_split(split):
    peer = NearestNeighbourPeer().fit(split[0])
    accuracy, balanced = scores(peer, split[1])
    assert balanced > BALANCED_FLOOR and accuracy > 0.87
    assert peer.fit_time_ > 0 and peer.predict_time_ > 0


@needs_aeon
def test_minirocket_learns_the_braking_split(split, minirocket):
    accuracy, balanced = scores(minirocket, split[1])
    assert balanced > BALANCED_FLOOR and accuracy > 0.86
    assert list(minirocket.classes_) == ["cruising", "normal-braking", "sudden-braking"]
    assert minirocket.fit_time_ > 0 and minirocket.predict_time_ > 0


@pytest.mark.parametrize("alignment, unlabelled_head, unlabelled_tail", [("causal", 19, 0), ("centred", 9, 10)])
def test_alignment_decides_which_samples_a_window_labels(split, alignment, unlabelled_head, unlabelled_tail):
    rec = split[1][0]
    labels = NearestNeighbourPeer(alignment=alignment).fit(split[0]).predict(rec)
    labelled = np.flatnonzero(labels != "")
    assert labelled[0] == unlabelled_head and labelled[-1] == len(rec) - 1 - unlabelled_tail
    assert len(labelled) == len(rec) - 19


def test_centred_labels_get_the_vote_spotfree_s_offline_labels_get(split, monkeypatch):
    import spotfree.evaluation.peers.base as base
    from spotfree.classify.smoothing import majority_vote, vote_samples

    for vote in (0.5, 0.1):  # the learner's default smoothing, and the hand's
        peer = NearestNeighbourPeer(alignment="centred", vote=vote).fit(split[0])
        voted = np.concatenate([peer.predict(rec) for rec in split[1]])
        with monkeypatch.context() as patch:
            patch.setattr(base, "alignment_smoothing", lambda n, centred, offline: None)
            raw = [peer.predict(rec) for rec in split[1]]
        n = vote_samples(vote, split[1][0].rate)
        expected = np.concatenate([majority_vote(r.astype(object), n, centred=True).astype(str) for r in raw])
        np.testing.assert_array_equal(voted, expected)
        assert (voted != np.concatenate(raw)).any()  # the split's raw labels flicker somewhere


@needs_aeon
def test_no_label_inside_a_gap_and_labels_resume_after_it(split, minirocket):
    rec = split[1][1]
    gap = slice(400, 430)
    holed = rec.with_channels({c: np.where(np.isin(np.arange(len(rec)), np.r_[gap]), np.nan, v)
                               for c, v in rec.channels.items()})
    labels = minirocket.predict(holed)
    assert (labels[gap] == "").all()
    assert (labels[gap.stop:gap.stop + 19] == "").all() and labels[gap.stop + 19] != ""
    assert (labels[:gap.start] == minirocket.predict(rec)[:gap.start]).all()


def regimes(order, seed, rate=20.0, length=300):
    """Channels ``lean``/``acc_x`` running through regimes of ``length`` samples each: oscillations of period 40,
    12 and 5 samples around 0, 2 and -1 (named by their period), plus noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(length)
    shapes = {"p40": np.sin(2 * np.pi * t / 40), "p12": 2 + np.sin(2 * np.pi * t / 12),
              "p5": -1 + np.sin(2 * np.pi * t / 5)}
    signal = np.concatenate([shapes[name] for name in order])
    n = len(signal)
    channels = {"lean": signal + 0.1 * rng.normal(size=n), "acc_x": 0.5 * signal + 0.1 * rng.normal(size=n)}
    return Recording(time=np.arange(n) / rate, rate=rate, source=f"regimes {'-'.join(order)}", channels=channels,
                     truth={"label": np.repeat(np.array(order), length)})


@needs_aeon
def test_clasp_finds_regime_changes_and_centroids_name_them():
    peer = ClaspPeer().fit([regimes(["p40", "p12", "p5"], seed=0)])
    test = regimes(["p12", "p5", "p40"], seed=1)
    labels = peer.predict(test)
    assert len(peer.change_points_) == 2
    assert np.all(np.abs(np.array(peer.change_points_) - [300, 600]) <= peer.window)  # measured: 282, 585
    assert np.mean(labels == test.truth["label"]) > 0.95  # measured: 0.963


@needs_aeon
def test_clasp_stops_at_a_weak_split_of_recurring_regimes():
    """ClaSP scores a split by how well left and right are told apart; a regime that comes back (A B A B) sits
    on both sides of every split, so the first split scores below min_score and the segmentation stops there."""
    peer = ClaspPeer().fit([regimes(["p40", "p12", "p5"], seed=0)])
    peer.predict(regimes(["p12", "p40", "p12", "p40"], seed=1))
    assert peer.change_points_ == []
    assert ClaspPeer(min_score=0.6).fit([regimes(["p40", "p12"], seed=0)]).segment(
        regimes(["p12", "p40", "p12", "p40"], seed=1).array(["lean", "acc_x"])) != []


@needs_aeon
def test_clasp_truth_naming_bounds_centroid_naming_on_the_same_segments(split):
    centroid, truth = ClaspPeer().fit(split[0]), ClaspPeer(naming="truth").fit(split[0])
    for rec in split[1]:
        by_centroid, by_truth = centroid.predict(rec), truth.predict(rec)
        assert centroid.change_points_ == truth.change_points_
        assert np.mean(by_truth == rec.truth["label"]) >= np.mean(by_centroid == rec.truth["label"])
        assert (by_centroid != "").all()


PEERS = [pytest.param(NearestNeighbourPeer, id="1nn"),
         pytest.param(lambda **kw: MiniRocketPeer(n_kernels=84, **kw), id="minirocket", marks=needs_aeon),
         pytest.param(ClaspPeer, id="clasp", marks=needs_aeon)]


@pytest.mark.parametrize("make", PEERS)
def test_a_missing_channel_is_named(split, make):
    with pytest.raises(InputError, match="no column 'pitch_rat'.*available"):
        make(channels=("lean", "pitch_rat")).fit(split[0])
    peer = make().fit(split[0])
    reduced = split[1][0].with_channels({"lean": split[1][0].channels["lean"]})
    with pytest.raises(InputError, match="no column 'acc_x'"):
        peer.predict(reduced)


@pytest.mark.parametrize("make", PEERS)
def test_a_recording_shorter_than_a_window_is_refused(split, make):
    peer = make().fit(split[0])
    with pytest.raises(InputError, match="as long as one window"):
        peer.predict(split[1][0].take(slice(0, 15)))


@pytest.mark.parametrize("make", PEERS)
def test_a_rate_that_differs_from_training_is_named(split, make):
    peer = make().fit(split[0])
    rec = split[1][0]
    other = Recording(time=rec.time, channels=rec.channels, rate=50.0, source="fifty.csv")
    with pytest.raises(InputError, match="fifty.csv: sampled at 50 Hz but the peer was trained at 20 Hz"):
        peer.predict(other)


def test_training_needs_ground_truth_and_two_classes(split):
    rec = split[0][0]
    bare = Recording(time=rec.time, channels=rec.channels, rate=rec.rate, source="bare.csv")
    with pytest.raises(InputError, match="bare.csv: no 'label' column"):
        NearestNeighbourPeer().fit([bare])
    one_class = rec.take(slice(0, 200))
    assert set(one_class.truth["label"]) == {"cruising"}
    with pytest.raises(InputError, match="1 class"):
        NearestNeighbourPeer().fit([one_class])
    with pytest.raises(InputError, match="not fitted"):
        NearestNeighbourPeer().predict(rec)


def test_bad_parameters_are_refused(split):
    with pytest.raises(InputError, match="alignment 'middle'"):
        NearestNeighbourPeer(alignment="middle").fit(split[0])
    with pytest.raises(InputError, match="at least 9 samples"):
        MiniRocketPeer(window=5).fit(split[0])
    for vote in (-0.5, float("nan"), float("inf"), "0.5", True):
        with pytest.raises(InputError, match="vote must be seconds >= 0"):
            NearestNeighbourPeer(alignment="centred", vote=vote).fit(split[0])
    with pytest.raises(InputError, match="naming 'oracle'"):
        ClaspPeer(naming="oracle").fit(split[0])
    with pytest.raises(InputError, match="naming='truth'"):
        ClaspPeer(naming="truth").fit(split[0]).predict(
            Recording(time=split[1][0].time, channels=split[1][0].channels, rate=20.0, source="unlabelled.csv"))


def test_a_missing_aeon_says_how_to_install_it(split, monkeypatch):
    monkeypatch.setitem(sys.modules, "aeon.classification.convolution_based", None)
    monkeypatch.setitem(sys.modules, "aeon.transformations.series", None)
    with pytest.raises(SpotfreeError, match=r"MiniRocketClassifier comes from aeon.*pip install -e '.\[eval\]'"):
        MiniRocketPeer(n_kernels=84).fit(split[0])
    with pytest.raises(SpotfreeError, match="ClaSPTransformer comes from aeon"):
        ClaspPeer().fit(split[0]).predict(split[1][0])
