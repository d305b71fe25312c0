"""The general spotting-free learner (spotfree.learner) on generated data of several kinds: periodic motions told
apart by their frequency, levels told apart by their depth, short rare events, and classes shared by every
recording or by none. Every recording declares only its set of classes; the per-sample truth scores the result."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from spotfree.errors import InputError
from spotfree.evaluation.metrics import near_transitions
from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner, _Windows, decode_runs
from spotfree.model import DictionaryModel
from spotfree.ride_prior import RidePrior
from spotfree.windows import ChannelScaling

RATE = 20.0
FIXED = {"window": 20, "share_power": 0.5, "column_share": 0.5, "smoothing": 0.5}
"""The settings the learner would otherwise choose (spotfree.selection, tested in test_selection.py), at their
first candidates, so that these tests see the learner's mechanism alone and run fast."""


def _signal(kind: str, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` samples of two channels of one class: still, periodic at 1 or 3 Hz, a level, or a spike."""
    t = np.arange(n) / RATE
    noise = rng.normal(0.0, 0.1, (n, 2))
    phase = rng.uniform(0, 2 * np.pi)
    shapes = {
        "still": np.zeros((n, 2)),
        "slow": np.column_stack([np.sin(2 * np.pi * 1.0 * t + phase), np.cos(2 * np.pi * 1.0 * t + phase)]),
        "fast": np.column_stack([np.sin(2 * np.pi * 3.0 * t + phase), np.cos(2 * np.pi * 3.0 * t + phase)]),
        "soft": np.tile([-0.8, 0.3], (n, 1)),
        "hard": np.tile([-2.4, 0.9], (n, 1)),
        "strike": np.tile([0.0, 3.0], (n, 1)),
    }
    return shapes[kind] + noise


def _recording(parts: list[tuple[str, float]], rng: np.random.Generator, source: str) -> Recording:
    """A recording of consecutive ``(class, seconds)`` parts, the truth kept for scoring."""
    x, label = [], []
    for kind, seconds in parts:
        n = int(round(seconds * RATE))
        x.append(_signal(kind, n, rng))
        label += [kind] * n
    x = np.vstack(x)
    return Recording(time=np.arange(len(x)) / RATE, channels={"u": x[:, 0], "v": x[:, 1]}, rate=RATE, source=source,
                     truth={"label": np.array(label)})


def _alternating(background: str, other: str, rng, source, runs=4, seconds=(4.0, 8.0), other_seconds=(3.0, 6.0)):
    parts = []
    for _ in range(runs):
        parts += [(background, rng.uniform(*seconds)), (other, rng.uniform(*other_seconds))]
    return _recording(parts + [(background, rng.uniform(*seconds))], rng, source)


def _away_accuracy(learner, tests) -> dict[str, float]:
    """Per true class, the share of its samples (away from true changes) labelled as it."""
    hits: dict[str, list[int]] = {}
    for rec in tests:
        predicted = learner.predict(rec)
        truth = rec.truth["label"]
        scored = ~near_transitions(truth, rate=rec.rate) & (predicted != "")
        for c in np.unique(truth):
            sel = scored & (truth == c)
            h = hits.setdefault(str(c), [0, 0])
            h[0] += int(np.sum(predicted[sel] == c))
            h[1] += int(sel.sum())
    return {c: a / b for c, (a, b) in hits.items()}


def test_periodic_motions_are_told_apart_whatever_their_phase():
    rng = np.random.default_rng(1)
    train = [_alternating("still", "slow", rng, "slow-1"), _alternating("still", "fast", rng, "fast-1"),
             _recording([("still", 20.0)], rng, "still-1"), _alternating("still", "slow", rng, "slow-2"),
             _alternating("still", "fast", rng, "fast-2")]
    sets = [{"still", "slow"}, {"still", "fast"}, {"still"}, {"still", "slow"}, {"still", "fast"}]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    tests = [_recording([("still", 5), ("slow", 5), ("fast", 5), ("still", 5), ("fast", 4), ("slow", 4)], rng, "t")]
    accuracy = _away_accuracy(learner, tests)
    assert min(accuracy.values()) >= 0.9, accuracy


def test_levels_a_hard_stop_against_a_soft_one():
    rng = np.random.default_rng(2)
    train = [_alternating("still", "soft", rng, "soft", other_seconds=(2.0, 4.0)),
             _recording([("still", 6), ("soft", 2), ("hard", 2), ("still", 6), ("soft", 2), ("hard", 2),
                         ("still", 6)], rng, "hard"),
             _recording([("still", 20)], rng, "still")]
    sets = [{"still", "soft"}, {"still", "soft", "hard"}, {"still"}]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    tests = [_recording([("still", 5), ("soft", 3), ("still", 5), ("soft", 2), ("hard", 2), ("still", 5)], rng, "t")]
    accuracy = _away_accuracy(learner, tests)
    assert min(accuracy.values()) >= 0.9, accuracy


def test_a_short_rare_event_is_found():
    rng = np.random.default_rng(3)
    parts = []
    for _ in range(6):
        parts += [("still", rng.uniform(5, 9)), ("strike", 0.6)]
    train = [_recording(parts + [("still", 5)], rng, "strikes"), _recording([("still", 30)], rng, "quiet")]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, [{"still", "strike"}, {"still"}])
    test = _recording([("still", 6), ("strike", 0.6), ("still", 6), ("strike", 0.6), ("still", 6)], rng, "t")
    predicted = learner.predict(test)
    truth = test.truth["label"]
    onsets = np.flatnonzero((truth[1:] == "strike") & (truth[:-1] != "strike")) + 1
    assert len(onsets) == 2
    for start in onsets:
        assert np.any(predicted[start:start + 12] == "strike"), "a strike went unlabelled"
    scored = (predicted != "") & ~near_transitions(truth, rate=test.rate) & (truth == "still")
    assert np.mean(predicted[scored] == "still") >= 0.95


def _strikes_with_aftermath(rng: np.random.Generator) -> tuple[list[Recording], list[set[str]], Recording]:
    """Two recordings of strikes, each strike followed by a soft level that is background (its truth ``still``), and two
    quiet recordings that hold the soft level too, more seldom; and a test recording of strikes."""
    def recording(parts, source):
        rec = _recording(parts, rng, source)
        rec.truth["label"] = np.where(rec.truth["label"] == "soft", "still", rec.truth["label"])
        return rec

    def strikes(source):
        parts = [part for _ in range(4) for part in (("still", rng.uniform(5, 9)), ("strike", 0.6),
                                                     ("soft", rng.uniform(2, 4)))]
        return recording(parts + [("still", 5)], source)

    train = [strikes("s1"), strikes("s2"), recording([("still", 12), ("soft", 2), ("still", 12)], "q1"),
             recording([("still", 12), ("soft", 2), ("still", 12)], "q2")]
    return train, [{"still", "strike"}, {"still", "strike"}, {"still"}, {"still"}], strikes("t")


def _strike_windows(learner, train) -> tuple[int, int]:
    """Training windows the learner named ``strike``, and those truly of a strike (at the window's centre)."""
    named = sum(int(np.sum(names == "strike")) for names in learner.window_labels_)
    true = sum(int(np.sum(rec.truth["label"][ends - learner.window // 2] == "strike"))
               for rec, ends in zip(train, learner.window_ends_))
    return named, true


def test_a_pattern_that_also_occurs_without_the_event_is_not_named_the_event():
    """The soft level is far more frequent where strikes are declared, but it occurs without them: the absence
    evidence keeps it from the strike, which the strike would otherwise claim (as the standing after a sudden
    stop)."""
    train, sets, test = _strikes_with_aftermath(np.random.default_rng(0))
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    named, true = _strike_windows(learner, train)
    assert named <= 3 * true, (named, true)
    predicted, truth = learner.predict(test), test.truth["label"]
    onsets = np.flatnonzero((truth[1:] == "strike") & (truth[:-1] != "strike")) + 1
    assert all(np.any(predicted[a:a + 12] == "strike") for a in onsets), "a strike went unlabelled"
    assert np.sum(predicted == "strike") <= 3 * np.sum(truth == "strike")

    without, _ = _strike_windows(SetSupervisedLearner(**FIXED, absence=0.0, seed=0).fit(train, sets), train)
    assert without >= 5 * true, (without, true)


def _absence_ratios(learner, train, sets) -> tuple[np.ndarray, np.ndarray, _Windows]:
    """The absence evidence ``r_c`` of every training window of the fitted ``learner`` (module docstring, step 2),
    the true label at each window's centre, and the windows."""
    allowed = np.array([[c in s for c in learner.classes_] for s in sets])
    data = learner._windows(train, ("u", "v"), ChannelScaling(("u", "v")).fit(train), learner.settings_["window"])
    ratio = learner._absence(data.X, data, allowed, np.random.default_rng(0))
    truth = np.concatenate([rec.truth["label"][ends - learner.settings_["window"] // 2]
                            for rec, ends in zip(train, data.ends)])
    return ratio, truth, data


def test_the_absence_evidence_reaches_a_class_declared_in_a_single_recording():
    """One recording declares the strikes and one does not: no two halves of the recordings each hold both kinds, so
    the evidence is cross-fitted over time blocks, and the soft level after each strike, which the quiet recording
    holds too, is still kept from the strike (without the evidence the strike claims it)."""
    train, sets, test = _strikes_with_aftermath(np.random.default_rng(4))
    train, sets = [train[0], train[2]], [sets[0], sets[2]]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    ratio, truth, data = _absence_ratios(learner, train, sets)
    strike, declares = learner.classes_.index("strike"), data.recording == 0
    assert np.median(ratio[declares & (truth == "strike"), strike]) < 0.2
    assert np.median(ratio[declares & (truth == "still"), strike]) > 0.5
    named, true = _strike_windows(learner, train)
    assert named <= 3 * true, (named, true)

    without, _ = _strike_windows(SetSupervisedLearner(**FIXED, absence=0.0, seed=0).fit(train, sets), train)
    assert without >= 5 * true, (without, true)


def test_the_absence_evidence_is_none_for_a_class_every_recording_declares():
    rng = np.random.default_rng(9)
    train = [_alternating("still", "slow", rng, "a"), _alternating("still", "fast", rng, "b"),
             _alternating("still", "slow", rng, "c"), _alternating("still", "fast", rng, "d")]
    sets = [{"still", "slow"}, {"still", "fast"}, {"still", "slow"}, {"still", "fast"}]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    ratio, truth, _ = _absence_ratios(learner, train, sets)
    assert np.all(ratio[:, learner.classes_.index("still")] == 0)
    slow = learner.classes_.index("slow")
    # windows of slow motion are absent where slow is not declared; still windows occur everywhere
    assert np.median(ratio[truth == "slow", slow]) < 0.2 < np.median(ratio[truth == "still", slow])


@pytest.mark.parametrize("power", [-1.0, float("nan"), float("inf"), "1", True])
def test_a_share_power_that_is_not_a_number_at_least_0_is_refused(power):
    rng = np.random.default_rng(8)
    with pytest.raises(InputError, match="share_power=.*give a number >= 0"):
        SetSupervisedLearner(share_power=power).fit([_recording([("still", 5)], rng, "a")], [{"still"}])


@pytest.mark.parametrize("share", [0.0, -0.5, 1.5, float("nan"), "1", True])
def test_a_column_share_outside_0_to_1_is_refused(share):
    rng = np.random.default_rng(8)
    with pytest.raises(InputError, match="column_share=.*give a share > 0 and <= 1"):
        SetSupervisedLearner(column_share=share).fit([_recording([("still", 5)], rng, "a")], [{"still"}])


def test_the_columns_are_drawn_from_the_share_of_a_class_s_windows_named_most_surely():
    rng = np.random.default_rng(9)
    train = [_alternating("still", "slow", rng, "a"), _alternating("still", "slow", rng, "b"),
             _recording([("still", 20)], rng, "c")]
    sets = [{"still", "slow"}, {"still", "slow"}, {"still"}]
    models = {share: SetSupervisedLearner(**{**FIXED, "column_share": share}, max_columns=100_000, seed=0).fit(
        train, sets)
              for share in (0.25, 0.5, 1.0)}
    named = np.concatenate(models[1.0].window_labels_)
    for share, learner in models.items():
        np.testing.assert_array_equal(np.concatenate(learner.window_labels_), named)  # the share moves no name
    slow = models[1.0].classes_.index("slow")
    n_slow = int(np.sum(named == "slow"))
    counts = {share: int(np.sum(learner.model_.column_class == slow)) for share, learner in models.items()}
    assert counts[1.0] == n_slow  # every window named slow
    for share in (0.25, 0.5):
        assert share * n_slow <= counts[share] <= share * n_slow + 2, counts  # a quantile of the margins
    columns = {share: {tuple(np.round(col, 9)) for col, c in zip(learner.model_.dictionary.T,
                                                                   learner.model_.column_class) if c == slow}
               for share, learner in models.items()}
    assert columns[0.25] <= columns[0.5] <= columns[1.0]  # a smaller share keeps the windows named most surely


def test_no_class_in_every_recording_and_windows_keep_to_their_sets():
    """Two recordings share no class; a window only ever takes a class its recording declares."""
    rng = np.random.default_rng(4)
    train = [_alternating("slow", "hard", rng, "a"), _alternating("fast", "soft", rng, "b"),
             _alternating("slow", "soft", rng, "c")]
    sets = [{"slow", "hard"}, {"fast", "soft"}, {"slow", "soft"}]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    for names, declared in zip(learner.window_labels_, sets):
        assert set(names) == declared  # every declared class found, nothing else
    assert set(learner.classes_) == {"slow", "hard", "fast", "soft"}
    tests = [_recording([("slow", 6), ("hard", 5), ("fast", 6), ("soft", 5)], rng, "t")]
    accuracy = _away_accuracy(learner, tests)
    assert min(accuracy.values()) >= 0.85, accuracy


def test_same_inputs_and_seed_give_the_same_model(tmp_path):
    rng = np.random.default_rng(5)
    train = [_alternating("still", "slow", rng, "a"), _recording([("still", 20)], rng, "b")]
    sets = [{"still", "slow"}, {"still"}]
    paths = []
    for k in range(2):
        model = SetSupervisedLearner(**FIXED, seed=3).fit(train, sets).model_
        paths.append(tmp_path / f"m{k}.npz")
        model.save(paths[-1])
    first, second = DictionaryModel.load(paths[0]), DictionaryModel.load(paths[1])
    assert first.metadata() == second.metadata()
    for name in ("dictionary", "column_class", "causal_dictionary", "feature_offset", "feature_scale"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
    assert first.representation == "summary"


def test_a_last_bit_difference_of_exp_and_log_does_not_change_the_model(monkeypatch):
    """numpy's exp and log round the last bit differently on different processors: the learner gives the same names
    and columns when every posterior and density ratio it computes is one unit in the last place off."""
    rng = np.random.default_rng(8)
    train = [_alternating("still", kind, rng, f"{kind}-{k}", other_seconds=(1.0, 3.0))
             for k in range(3) for kind in ("slow", "soft")] + [_recording([("still", 20)], rng, "still")]
    sets = [{"still", "slow"}, {"still", "soft"}] * 3 + [{"still"}]
    reference = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    jitter = np.random.default_rng(0)

    def one_ulp_off(method):
        def off(self, *args, **kwargs):
            values = method(self, *args, **kwargs)
            up = (jitter.random(values.shape) < 0.5) & np.isfinite(values)
            return np.where(up, np.nextafter(values, np.inf), values)
        return off

    for name in ("_cross_fitted", "_absence"):
        monkeypatch.setattr(SetSupervisedLearner, name, one_ulp_off(getattr(SetSupervisedLearner, name)))
    perturbed = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    for ours, theirs in zip(reference.window_labels_, perturbed.window_labels_):
        np.testing.assert_array_equal(ours, theirs)
    np.testing.assert_array_equal(reference.model_.dictionary, perturbed.model_.dictionary)
    np.testing.assert_array_equal(reference.model_.causal_dictionary, perturbed.model_.causal_dictionary)


def test_the_ride_prior_never_engages_for_other_data():
    rng = np.random.default_rng(6)
    train = [_alternating("still", "slow", rng, "a"), _recording([("still", 20)], rng, "b")]
    sets = [{"still", "slow"}, {"still"}]
    prior = RidePrior()
    for rec in train:
        assert not prior.log_prior(rec, np.arange(len(rec)), ["slow", "still"]).any()  # no GPS speed here
    with_prior = SetSupervisedLearner(**FIXED, prior=prior, seed=0).fit(train, sets).model_
    without = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets).model_
    np.testing.assert_array_equal(with_prior.dictionary, without.dictionary)
    n = 100  # a ride's channels, but classes the prior does not name; the names it knows, but no ride channels
    ride = Recording(time=np.arange(n) / RATE, channels={"yaw_rate": np.full(n, 0.5), "speed": np.r_[5.0, np.full(
        n - 1, np.nan)]}, rate=RATE)
    assert not prior.log_prior(ride, np.arange(n), ["slow", "still"]).any()
    assert not prior.log_prior(train[0], np.arange(len(train[0])), ["gentle-turn", "straight", "normal-braking"]).any()


def test_the_ride_prior_favours_turning_where_the_vehicle_yaws_and_bridges_a_slalom_s_lobes():
    n = 200
    yaw = np.zeros(n)
    yaw[60:100], yaw[102:140] = 0.3, -0.3  # two lobes of a slalom, through zero for 0.1 s between them
    yaw[150] = np.nan  # a gap: no evidence there
    rec = Recording(time=np.arange(n) / RATE, channels={"u": np.zeros(n), "yaw_rate": yaw}, rate=RATE)
    log_prior = RidePrior().log_prior(rec, np.arange(n), ["slalom", "straight"])
    assert log_prior[20, 1] > 0 and log_prior[20, 0] == 0  # 1 s: straight ahead
    assert (log_prior[[70, 100, 101, 120], 0] > 0).all() and not log_prior[[70, 100, 101, 120], 1].any()
    assert log_prior[60 - 5, 0] > 0 and log_prior[60 - 6, 1] > 0  # the turn widened by the bridge, 0.25 s
    assert not log_prior[150].any()


def test_the_ride_prior_favours_braking_where_the_speed_falls():
    n = 200
    speed = np.full(n, np.nan)
    speed[::20] = np.r_[np.full(5, 5.0), 5.0 - np.arange(1, 6)]  # 1 Hz fixes: steady, then losing 1 m/s^2
    rec = Recording(time=np.arange(n) / RATE, channels={"u": np.zeros(n), "speed": speed}, rate=RATE)
    log_prior = RidePrior(braking=("braking",)).log_prior(rec, np.arange(n), ["braking", "cruising"])
    assert log_prior[40, 1] > 0 and log_prior[40, 0] == 0  # 2.0 s: steady speed
    assert log_prior[160, 0] > 0 and log_prior[160, 1] == 0  # 8.0 s: slowing down


def test_decode_runs_every_class_appears_and_runs_are_kept():
    q = np.log(np.array([[0.9, 0.1, 0.0 + 1e-9]] * 6 + [[0.4, 0.6, 1e-9]] * 2 + [[0.9, 0.1, 1e-9]] * 6))
    labels = decode_runs(q, 5.0)
    assert set(labels) == {0, 1, 2}  # class 2 is never likely, yet declared: it takes its best stretch
    assert np.count_nonzero(np.diff(labels)) <= 4
    free = decode_runs(q[:, :2], 0.0)
    np.testing.assert_array_equal(free, q[:, :2].argmax(axis=1))


@pytest.mark.parametrize("smoothing", [0.05, 0.1, 0.15, 0.2, 0.5])
def test_the_margins_are_averaged_over_windows_centred_on_each(smoothing):
    learner = SetSupervisedLearner(**{**FIXED, "smoothing": smoothing})
    learner.rate_, learner.settings_ = 20.0, learner.get_params()
    runs = _Windows(X=np.zeros((41, 1)), recording=np.zeros(41, dtype=int), ends=[np.arange(41)], runs=[(0, 41)],
                    offsets=np.array([0, 41]))
    impulse = np.zeros((41, 2))
    impulse[20, 0] = 1.0
    averaged = learner._smoothed(impulse, runs)[:, 0]
    np.testing.assert_allclose(averaged, averaged[::-1], atol=1e-15)  # no shift towards the past or the future
    assert averaged.sum() == pytest.approx(1.0)
    assert np.count_nonzero(averaged) == int(round(smoothing * 20)) + 1 - int(round(smoothing * 20)) % 2


@pytest.mark.parametrize("case, message", [
    ("short", "no gap-free stretch is as long as one window"),
    ("nan", "no gap-free stretch"),
    ("constant", "constant"),
    ("sets", "class sets"),
    ("empty", "declare at least one class"),
    ("rates", "different rates"),
])
def test_bad_input_is_refused_with_a_clear_message(case, message):
    rng = np.random.default_rng(7)
    good = _alternating("still", "slow", rng, "good")
    train, sets = [good, _recording([("still", 10)], rng, "other")], [{"still", "slow"}, {"still"}]
    if case == "short":
        train[1] = _recording([("still", 0.5)], rng, "short")
    elif case == "nan":
        train[1].channels["u"][:] = np.nan
    elif case == "constant":
        for rec in train:
            rec.channels["v"][:] = 1.0
    elif case == "sets":
        sets = sets[:1]
    elif case == "empty":
        sets[1] = set()
    elif case == "rates":
        train[1] = Recording(time=train[1].time, channels=train[1].channels, rate=40.0, source="fast")
    with pytest.raises(InputError, match=message):
        SetSupervisedLearner(**FIXED).fit(train, sets)


def test_a_class_that_looks_like_another_is_warned_about():
    """A declared class that never shows in its recording still gets windows (every declared class does), and the
    summary says it could not be told apart."""
    rng = np.random.default_rng(8)
    train = [_alternating("still", "slow", rng, "a"), _recording([("still", 30)], rng, "ghost")]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, [{"still", "slow"}, {"still", "ghost"}])
    assert any("class ghost is not told apart" in w for w in learner.warnings_), learner.warnings_
    assert learner.model_.summary["warnings"] == learner.warnings_
    assert not any("class slow" in w or "class still" in w for w in learner.warnings_)


@pytest.mark.slow
def test_thousands_of_short_recordings():
    rng = np.random.default_rng(9)
    train, sets = [], []
    for k in range(1000):
        kind = ("slow", "fast")[k % 2]
        train.append(_recording([("still", 2.0), (kind, 2.0)], rng, f"r{k}"))
        sets.append({"still", kind})
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    assert all(set(names) == declared for names, declared in zip(learner.window_labels_, sets))
    assert set(learner.model_.summary["columns_per_class"]) == {"still", "slow", "fast"}


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_any_input_trains_or_is_refused_with_an_input_error(data):
    """Recordings of any length (some shorter than a window), with NaN stretches, constant or huge channels, and any
    class sets: the learner either fits, every window taking a class its recording declares, or refuses with an
    InputError; nothing else escapes."""
    n_recordings = data.draw(st.integers(1, 4))
    classes = ["a", "b", "c"]
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 16)))
    recordings, sets = [], []
    for k in range(n_recordings):
        n = data.draw(st.integers(1, 200))
        x = rng.normal(0, 1, (n, 2)) * data.draw(st.sampled_from([1.0, 1e-6, 1e6]))
        if data.draw(st.booleans()):
            start = data.draw(st.integers(0, n - 1))
            x[start:start + data.draw(st.integers(1, 50)), 0] = np.nan
        if data.draw(st.booleans()):
            x[:, 1] = 3.0
        recordings.append(Recording(time=np.arange(n) / RATE, channels={"u": x[:, 0], "v": x[:, 1]}, rate=RATE,
                                    source=f"r{k}"))
        sets.append(set(data.draw(st.lists(st.sampled_from(classes), min_size=1, max_size=3))))
    try:
        learner = SetSupervisedLearner(**FIXED, rounds=1, seed=0).fit(recordings, sets)
    except InputError:
        return
    for names, declared in zip(learner.window_labels_, sets):
        assert set(names) <= declared
    assert np.all(np.isfinite(learner.model_.dictionary))


def test_a_class_that_always_comes_with_another_is_named():
    """``hard`` is declared only in recordings that also declare ``soft``; the recordings with ``soft`` and without
    ``hard`` tell them apart (and one without either, ``soft`` from ``still``): the training windows of ``hard`` end
    named ``hard`` and those of ``soft`` ``soft``, in every recording."""
    rng = np.random.default_rng(5)
    train = []
    for k in range(3):
        train.append(_alternating("still", "soft", rng, f"soft-{k}", other_seconds=(2.0, 4.0)))
        train.append(_recording([("still", 4), ("soft", 4), ("hard", 3), ("still", 4), ("soft", 4), ("hard", 3),
                                 ("still", 4)], rng, f"hard-{k}"))
    train.append(_recording([("still", 20)], rng, "still"))
    sets = [{"still", "soft"}, {"still", "soft", "hard"}] * 3 + [{"still"}]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(train, sets)
    for rec, names, ends in zip(train, learner.window_labels_, learner.window_ends_):
        truth = rec.truth["label"][ends - learner.window // 2]
        away = ~near_transitions(rec.truth["label"], rate=rec.rate)[ends - learner.window // 2]
        for c in ("soft", "hard"):
            sel = away & (truth == c)
            if sel.any():
                assert np.mean(names[sel] == c) >= 0.8, (rec.source, c, np.mean(names[sel] == c))


def test_classes_declared_together_everywhere_are_warned_about_unless_a_prior_tells_them_apart():
    """Every recording declares both classes: the sets cannot tell them apart, and the summary says so; recordings that
    hold one without the other, or a prior, silence it."""
    rng = np.random.default_rng(9)
    both = [_alternating("still", "slow", rng, f"r{k}") for k in range(2)]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(both, [{"still", "slow"}] * 2)
    assert any("classes slow, still are declared by the same recordings" in w for w in learner.warnings_), \
        learner.warnings_
    apart = both + [_recording([("still", 20)], rng, "rest")]
    learner = SetSupervisedLearner(**FIXED, seed=0).fit(apart, [{"still", "slow"}] * 2 + [{"still"}])
    assert not any("declared by the same recordings" in w for w in learner.warnings_), learner.warnings_

    class Flat:
        def log_prior(self, recording, centres, classes):
            return np.zeros((len(centres), len(classes)))

    learner = SetSupervisedLearner(**FIXED, seed=0, prior=Flat()).fit(both, [{"still", "slow"}] * 2)
    assert not any("declared by the same recordings" in w for w in learner.warnings_)


def test_class_names_that_differ_only_in_case_are_warned_about():
    """`Walking` in one recording and `walking` in another are two classes: the summary says so."""
    rng = np.random.default_rng(3)
    recordings = [_alternating("still", "slow", rng, "a"), _recording([("still", 20)], rng, "b"),
                  _alternating("still", "slow", rng, "c")]
    learner = SetSupervisedLearner(**FIXED, seed=0, rounds=1).fit(recordings, [{"still", "slow"}, {"still"}, {"Slow ", "still"}])
    assert any(w.startswith("classes 'Slow ', 'slow' differ only in case or spaces") for w in learner.warnings_), \
        learner.warnings_
    learner = SetSupervisedLearner(**FIXED, seed=0, rounds=1).fit(recordings, [{"still", "slow"}, {"still"}, {"slow", "still"}])
    assert not any("differ only in case" in w for w in learner.warnings_)
