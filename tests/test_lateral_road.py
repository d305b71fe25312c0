"""Lateral and road models: declarations as a rider would make them, held-out split, scoring by true class."""

import numpy as np
import pytest

from spotfree.evaluation.lateral_road import (KIND_RIDES, MODELS, Split, declared_classes, event_classes, score,
                                              spec_votes, spec_split, split)
from spotfree.evaluation.metrics import Score


def test_declarations_name_only_the_classes_present_background_first():
    assert declared_classes(np.array(["slalom", "straight", "slalom"]), "lateral") == ["straight", "slalom"]
    assert event_classes(np.array(["", "turn", "braking+turn"]), "lateral") == ["straight", "gentle-turn"]
    assert event_classes(np.array(["bump", "", "cobblestone+speed-change"]), "road") == [
        "smooth", "cobblestone", "kerb"]
    assert event_classes(np.array(["", "braking"]), "road") == ["smooth"]


@pytest.fixture(scope="module")
def road_split() -> Split:
    return split("road", seed=5, repeats=3, n_train=2)


def test_split_holds_out_riders_and_declares_from_the_rides_not_from_labels(road_split):
    data = road_split
    assert data.test_experiments == [3]
    assert set(np.unique(data.test.experiment)) == {3}
    assert len(data.training) == 4  # two road rides and two lateral rides
    sources = [rec.source for rec, _ in data.training]
    assert sources == ["road seed 5 experiment 1", "road seed 5 experiment 2",
                       "lateral seed 5 experiment 1", "lateral seed 5 experiment 2"]
    for rec, classes in data.training[:2]:
        assert classes == declared_classes(rec.truth["label"], "road")
    for rec, classes in data.training[2:]:
        assert classes[0] == "smooth" and classes == event_classes(rec.truth["event"], "road")


def test_score_counts_every_labelled_sample_of_each_true_class(road_split):
    data = road_split
    recordings, sets = zip(*data.training)
    model = MODELS["road"].learner(5).fit(list(recordings), list(sets)).model_
    per_class, overall = score(model, data.test, "road")
    truth = data.test.truth["label"]
    assert set(per_class) == {"smooth", "rough-asphalt", "cobblestone", "kerb"}
    total = sum(per_class.values(), Score(0, 0))
    assert total == overall
    # every sample but the first window - 1 of the ride is labelled and counted under its true class
    assert overall.total == len(truth) - (model.window - 1)
    assert per_class["smooth"].total == int(np.sum(truth[model.window - 1:] == "smooth"))
    votes = spec_votes(MODELS["road"], model)
    assert votes.segments == MODELS["road"].segments and set(votes.keep) <= {"kerb"}
    voted, voted_overall = score(model, data.test, "road", votes)
    assert voted_overall.total == overall.total and set(voted) == set(per_class)
    print(f"centred {overall.rate:.3f}, segment vote {voted_overall.rate:.3f}")
    assert voted_overall.rate >= overall.rate - 0.02  # a short test ride; benchmarks/lateral_road.py over seeds


def test_one_kind_protocol_gives_each_training_rider_one_ride_per_manoeuvre_and_a_straight_one():
    data = spec_split(MODELS["lateral"], seed=5, repeats=3, n_train=2)
    assert MODELS["lateral"].one_kind and data.test_experiments == [3]
    assert len(data.training) == 2 * len(KIND_RIDES["lateral"])
    assert [rec.source for rec, _ in data.training[:2]] == ["lateral (gentle) seed 5 experiment 1",
                                                            "lateral (gentle) seed 5 experiment 2"]
    assert data.training[-1][0].source == "lateral (straight) seed 5 experiment 2"
    for rec, classes in data.training:
        assert classes == declared_classes(rec.truth["label"], "lateral")
        assert classes[0] == "straight" and len(classes) <= 2
    assert [classes for _, classes in data.training[-2:]] == [["straight"], ["straight"]]


def test_one_kind_road_rides_hold_one_surface_event_each_or_none():
    data = spec_split(MODELS["road"], seed=5, repeats=3, n_train=1)
    assert [classes for _, classes in data.training] == [["smooth", "rough-asphalt"], ["smooth", "cobblestone"],
                                                  ["smooth", "kerb"], ["smooth"]]


@pytest.mark.parametrize("name", ["braking", "lateral", "road"])
def test_a_preset_s_learner_holds_its_settings_and_a_parameter_given_overrides_them(name):
    from spotfree.presets import PRESETS, preset_learner

    preset, learner = PRESETS[name], preset_learner(name, seed=3)
    assert (learner.channels, learner.window, learner.representation) == (
        preset["channels"], preset["window"], preset["representation"])
    assert learner.column_share == preset["column_share"] and learner.seed == 3
    assert learner.max_columns == preset["max_columns"] and preset_learner(name, max_columns=7).max_columns == 7
    assert (learner.prior is None) == (preset["prior"] is None)
    assert preset_learner(name, column_share=0.25, window=7).get_params()["column_share"] == 0.25
    # the ride models trained on rides of one manoeuvre or surface each draw from every window of a class
    assert preset["column_share"] == (1.0 if name in MODELS else 0.75)
