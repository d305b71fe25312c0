"""The learner's settings chosen from the class sets alone (spotfree.selection): the set risk on held-out
recordings, the folds, a given setting kept, and the search picking the candidate that is known right."""

from __future__ import annotations

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.learner import SELECTED, SetSupervisedLearner
from spotfree.selection import CANDIDATES, TOLERANCE, held_out_folds, set_risk

RATE = 20.0
FIXED = {"window": 20, "share_power": 0.5, "column_share": 0.5, "smoothing": 0.5}
AUTO = {name: "auto" for name in FIXED}


def _labels(*parts: tuple[str, int]) -> np.ndarray:
    return np.concatenate([np.full(n, c, dtype=object) for c, n in parts])


def test_set_risk_counts_names_outside_the_set_per_sample_and_missed_classes_per_log():
    classes = ["a", "b", "still"]
    labels = [_labels(("still", 30), ("a", 10)),  # declares still, a: nothing wrong
              _labels(("still", 36), ("a", 4)),  # declares still: 4 of 40 samples are a false a
              _labels(("still", 40)),  # declares still, b: b missed in its log
              _labels(("", 5), ("still", 35))]  # declares still: the unlabelled samples do not count
    sets = [{"still", "a"}, {"still"}, {"still", "b"}, {"still"}]
    fp_a = 4 / (40 + 40 + 35)  # the recordings without a (2, 3 and 4) name 4 of their 115 labelled samples a
    miss_b = 1.0  # the one log that declares b names none
    assert set_risk(labels, sets, ["x", "y", "z", "w"], classes) == pytest.approx((fp_a + miss_b) / 3)
    assert set_risk(labels, sets, None, classes) == pytest.approx(fp_a / 3)  # halves: no miss
    # b declared by a recording of log x, which names no b in any of its recordings: missed once of one
    assert set_risk(labels, sets, ["x", "y", "x", "w"], classes) == pytest.approx((fp_a + 1.0) / 3)
    # a declared in log x and named in another of its recordings counts as found
    relabelled = [_labels(("still", 40)), labels[1], _labels(("still", 30), ("a", 10)), labels[3]]
    assert set_risk(relabelled, [{"still", "a"}, {"still"}, {"still"}, {"still"}], ["x", "y", "x", "w"],
                    classes) == pytest.approx(14 / 115 / 3)  # but its 10 a stand outside recording 3's set


def test_set_risk_is_zero_for_labels_inside_every_set_that_find_every_class():
    labels = [_labels(("still", 20), ("a", 20)), _labels(("still", 40))]
    assert set_risk(labels, [{"still", "a"}, {"still"}], ["x", "y"], ["a", "still"]) == 0.0


def _recording(kinds: list[tuple[str, float]], rng: np.random.Generator, source: str) -> Recording:
    """Two channels: ``still`` noise, ``slow`` a 1-Hz and ``fast`` a 3-Hz rotation, ``strike`` a level of 3."""
    x, truth = [], []
    for kind, seconds in kinds:
        n = int(round(seconds * RATE))
        t = np.arange(n) / RATE
        phase = rng.uniform(0, 2 * np.pi)
        f = {"slow": 1.0, "fast": 3.0}.get(kind, 0.0)
        shape = (np.column_stack([np.sin(2 * np.pi * f * t + phase), np.cos(2 * np.pi * f * t + phase)]) if f else
                 np.tile([0.0, 3.0 if kind == "strike" else 0.0], (n, 1)))
        x.append(shape + rng.normal(0.0, 0.1, (n, 2)))
        truth += [kind] * n
    x = np.vstack(x)
    return Recording(time=np.arange(len(x)) / RATE, channels={"u": x[:, 0], "v": x[:, 1]}, rate=RATE, source=source,
                     truth={"label": np.array(truth)})


def test_folds_hold_each_declared_set_on_both_sides_and_halves_when_recordings_are_few():
    rng = np.random.default_rng(0)
    recs = [_recording([("still", 6)], rng, f"r{k}") for k in range(6)]
    sets = [{"still"}, {"still"}, {"still", "a"}, {"still", "a"}, {"still", "b"}, {"still", "b"}]
    folds = held_out_folds(recs, sets, np.random.default_rng(0), 20)
    assert len(folds) == 2 and all(f.whole for f in folds)
    for fold in folds:
        assert sorted(map(sorted, fold.test_sets)) == sorted(map(sorted, fold.train_sets))  # one of each set a side
        assert not {r.source for r in fold.test} & {r.source for r in fold.train}
    few = held_out_folds(recs[:2], sets[:2], np.random.default_rng(0), 20)
    assert len(few) == 2 and not any(f.whole for f in few)
    assert [len(r) for r in few[0].train] == [60, 60] and [len(r) for r in few[0].test] == [60, 60]
    assert held_out_folds(recs[:2], sets[:2], np.random.default_rng(0), 40) == []  # halves too short to score


def _protocol(rng):
    train = [_recording([("still", 4), ("slow", 5), ("still", 4)], rng, f"slow-{k}") for k in range(3)]
    train += [_recording([("still", 4), ("fast", 5), ("still", 4)], rng, f"fast-{k}") for k in range(3)]
    train += [_recording([("still", 13)], rng, f"still-{k}") for k in range(2)]
    sets = [{"still", "slow"}] * 3 + [{"still", "fast"}] * 3 + [{"still"}] * 2
    return train, sets


def test_given_settings_are_kept_and_said_given_and_nothing_is_searched_when_all_are_given():
    train, sets = _protocol(np.random.default_rng(1))
    assert SetSupervisedLearner().get_params()["window"] == 20  # the defaults are given values: no search
    learner = SetSupervisedLearner(trees=20, seed=0).fit(train, sets)
    assert learner.settings_ == FIXED
    assert [row["setting"] for row in learner.selection_] == list(SELECTED)
    assert all(row["given"] and row["candidates"] == {} for row in learner.selection_)
    assert learner.model_.summary["selection"] == learner.selection_
    assert {k: learner.model_.parameters[k] for k in SELECTED} == FIXED


def test_the_search_scores_every_candidate_keeps_a_given_one_and_repeats_itself():
    train, sets = _protocol(np.random.default_rng(2))
    learner = SetSupervisedLearner(**{**AUTO, "window": 20}, trees=20, seed=0).fit(train, sets)
    rows = {row["setting"]: row for row in learner.selection_}
    assert rows["window"]["given"] and rows["window"]["candidates"] == {} and learner.settings_["window"] == 20
    for name in ("share_power", "column_share", "smoothing"):
        assert not rows[name]["given"]
        assert set(rows[name]["candidates"]) == set(CANDIDATES[name])
        chosen = rows[name]["value"]
        assert rows[name]["candidates"][chosen] == min(rows[name]["candidates"].values()) or \
            rows[name]["candidates"][chosen] <= min(rows[name]["candidates"].values()) + 0.02
    again = SetSupervisedLearner(**{**AUTO, "window": 20}, trees=20, seed=0).fit(train, sets)
    assert again.settings_ == learner.settings_
    assert np.array_equal(again.model_.dictionary, learner.model_.dictionary)


@pytest.mark.parametrize("name, value", [("sharpen", 0.5), ("absence", -1.0), ("trees", 0), ("leaf", 1.5),
                                         ("landmarks", True), ("block_seconds", 0.0), ("fit_windows", "many"),
                                         ("changed", float("nan"))])
def test_the_learners_former_constants_are_validated_parameters(name, value):
    train, sets = _protocol(np.random.default_rng(3))
    with pytest.raises(InputError, match=name):
        SetSupervisedLearner(**FIXED, **{name: value}).fit(train, sets)


def test_the_search_picks_the_candidates_of_least_risk_and_keeps_the_defaults_within_the_tolerance(monkeypatch):
    """The coordinate descent of select_settings on a known risk: the rare-event settings (share power 1, column
    share 0.25) lower it clearly and are chosen; a 2-s window lowers it by less than the tolerance and is not."""
    import spotfree.selection as selection

    def risk(self, settings):
        value = 0.20
        if settings["window"] == 40:
            value -= TOLERANCE / 2
        if settings["share_power"] == 1.0:
            value -= 0.05
            if settings["column_share"] == 0.25:
                value -= 0.05
        return value - (0.02 if settings["smoothing"] == 0.25 and settings["column_share"] == 0.25 else 0.0)

    monkeypatch.setattr(selection._Search, "risk", risk)
    train, sets = _protocol(np.random.default_rng(4))
    chosen, rows = selection.select_settings(SetSupervisedLearner(**AUTO), train, sets)
    assert chosen == {"window": 20, "share_power": 1.0, "column_share": 0.25, "smoothing": 0.25}
    by_name = {row["setting"]: row for row in rows}
    assert by_name["window"]["candidates"] == {20: 0.2, 40: round(0.2 - TOLERANCE / 2, 4)}
    assert by_name["smoothing"]["candidates"][0.25] == round(0.08, 4)
    given, _ = selection.select_settings(SetSupervisedLearner(**{**AUTO, "share_power": 0.5}), train, sets)
    assert given["share_power"] == 0.5 and given["column_share"] == 0.5  # 0.25 pays only with share power 1
