"""Naming clusters by evidence across recordings: presence, enrichment, background."""

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.naming import (ClusterName, background_class, median_trend, name_clusters, name_deep_outer, name_nested,
                             name_slowing_outer, presence_matrix, rename_habits, rename_upright, single_manoeuvre_names)

NB = ["cruising", "normal-braking"]
SB = ["cruising", "normal-braking", "sudden-braking"]


def _names(counts, declared=(NB, SB)):
    declared = [list(d) for d in declared]
    return [n.name for n in name_clusters(np.array(counts), declared, background_class(declared))]


def test_group_present_only_where_a_class_is_declared_takes_that_class():
    # columns: normal-braking recording, sudden-braking recording
    names = _names([[600, 700], [300, 40], [1, 60]])
    assert names == ["cruising", "normal-braking", "sudden-braking"]


def test_confounder_spread_over_every_recording_stays_background():
    # a turn group, equally common in both rides, is not forced into a manoeuvre class
    names = _names([[600, 700], [250, 60], [1, 60], [50, 55]])
    assert names[3] == "cruising"


def test_larger_cluster_is_not_needed_to_find_the_background():
    # the normal-braking recording is half braking: size alone would name the wrong group
    names = _names([[480, 800], [520, 90], [0, 60]])
    assert names[:2] == ["cruising", "normal-braking"]


def test_group_in_recordings_with_no_common_class_goes_to_background():
    declared = [["cruising", "normal-braking"], ["cruising", "sudden-braking"]]
    names = _names([[500, 500], [100, 0], [0, 100], [10, 0]], declared)
    assert names == ["cruising", "normal-braking", "sudden-braking", "normal-braking"]


def test_background_must_be_declared_everywhere():
    with pytest.raises(InputError, match="every --experiment"):
        background_class([["cruising"], ["sudden-braking"]])
    with pytest.raises(InputError, match="not declared in every"):
        background_class([NB, SB], background="sudden-braking")
    assert background_class([NB, SB], background="normal-braking") == "normal-braking"


def test_presence_matrix_counts_windows():
    counts = presence_matrix(np.array([0, 1, 1, 2]), np.array([0, 0, 1, 1]), 3, 2)
    np.testing.assert_array_equal(counts, [[1, 0], [1, 1], [0, 1]])


def test_a_riders_habit_enriched_like_a_manoeuvre_goes_to_the_background():
    rng = np.random.default_rng(0)

    def windows(level, n):
        return level + 0.2 * rng.normal(size=(n, 8))

    # both rides cruise at 0 and accelerate at +1.0 (clusters 0 and 1, shared: the background); the sudden-braking
    # ride's rider also accelerates briskly at +1.1 (cluster 2, only there) and stops hard at -3 (cluster 3)
    parts = [(0, 0, windows(0.0, 60)), (0, 1, windows(1.0, 20)), (1, 0, windows(0.0, 60)), (1, 1, windows(1.0, 20)),
             (1, 2, windows(1.1, 40)), (1, 3, windows(-3.0, 10))]
    pooled = np.vstack([w for _, _, w in parts]).T
    recording = np.concatenate([np.full(len(w), r) for r, _, w in parts])
    labels = np.concatenate([np.full(len(w), j) for _, j, w in parts])
    declared = [["cruising", "normal-braking"], ["cruising", "normal-braking", "sudden-braking"]]
    names = name_clusters(presence_matrix(labels, recording, 4, 2), declared, "cruising")
    assert [n.name for n in names] == ["cruising", "cruising", "sudden-braking", "sudden-braking"]
    renamed = rename_habits(pooled, recording, labels, names, declared, "cruising")
    assert [n.name for n in renamed] == ["cruising", "cruising", "cruising", "sudden-braking"]
    assert "not novel" in renamed[2].rule


def _nested_case():
    """Both rides cruise at 0 (cluster 0) and brake at -1 (cluster 1, as often in both: no enrichment); the
    sudden-braking ride also stops hard at -3 (cluster 2) and its rider accelerates at +1 (cluster 3, shared)."""
    rng = np.random.default_rng(1)
    parts = [(0, 0, 0.0, 80), (0, 1, -1.0, 15), (0, 3, 1.0, 15), (1, 0, 0.0, 80), (1, 1, -1.0, 15),
             (1, 3, 1.0, 15), (1, 2, -3.0, 10)]
    pooled = np.vstack([level + 0.2 * rng.normal(size=(n, 8)) for _, _, level, n in parts]).T
    recording = np.concatenate([np.full(n, r) for r, _, _, n in parts])
    labels = np.concatenate([np.full(n, j) for _, j, _, n in parts])
    names = name_clusters(presence_matrix(labels, recording, 4, 2), [NB, SB], "cruising")
    assert [n.name for n in names] == ["cruising", "cruising", "sudden-braking", "cruising"]
    return pooled, recording, labels, names


def test_a_class_the_specific_one_passes_through_takes_the_shared_group_nearest_to_it():
    pooled, recording, labels, names = _nested_case()
    nested = name_nested(pooled, recording, labels, names, [NB, SB], "cruising",
                         [("sudden-braking", "normal-braking")])
    assert [n.name for n in nested] == ["cruising", "normal-braking", "sudden-braking", "cruising"]
    assert "passes through normal-braking" in nested[1].rule and 0 < nested[1].confidence < 1


def test_nesting_passes_over_a_group_that_does_not_lose_speed():
    """The braking group 1 is nearest to the hard stop; by the GPS trend (m/s^2 per window) it must also lose speed.
    The accelerating group 3 does not lie nearer to the stop than the background's largest group does, so no group is
    named when group 1 keeps its speed."""
    pooled, recording, labels, names = _nested_case()
    pair = [("sudden-braking", "normal-braking")]

    def nested(group_1_trend, slowing=0.4):
        trend = np.where(labels == 1, group_1_trend, np.where(labels == 3, 0.8, 0.0))
        return name_nested(pooled, recording, labels, names, [NB, SB], "cruising", pair, trend, slowing)

    assert [n.name for n in nested(-1.0)][1] == "normal-braking" and "median GPS trend -1.00" in nested(-1.0)[1].rule
    assert [n.name for n in nested(-0.1)] == [n.name for n in names]  # keeps its speed: no group
    assert [n.name for n in nested(-0.1, slowing=0.0)][1] == "normal-braking"  # the rule off
    unknown = nested(np.nan)
    assert unknown[1].name == "normal-braking" and "GPS" not in unknown[1].rule  # no fix: it passes
    assert np.isnan(median_trend(None, labels == 1)) and np.isnan(median_trend(np.full(3, np.nan), [0, 1]))
    assert median_trend(np.array([-1.0, np.nan, -0.5, 3.0]), np.array([0, 1, 2])) == -0.75


def test_as_a_last_resort_the_background_group_losing_speed_fastest_takes_the_outer_class():
    """No group is named normal braking; in its home ride (the first) groups 1 and 3 lose speed, group 1 faster,
    and group 2 has too few windows there to count."""
    labels = np.array([0] * 10 + [1] * 5 + [3] * 5 + [2] * 2 + [0] * 10 + [2] * 6)
    recording = np.array([0] * 22 + [1] * 16)
    trend = np.select([labels == 1, labels == 3, labels == 2], [-1.5, -0.6, -3.0], 0.1)
    names = [ClusterName(j, "cruising", "shared", 1.0, []) for j in range(4)]
    names[2] = ClusterName(2, "sudden-braking", "present only where sudden-braking is declared", 1.0, [])
    pair = [("sudden-braking", "normal-braking")]
    named = name_slowing_outer(labels, recording, names, [NB, SB], "cruising", pair, trend, 0.4)
    assert [n.name for n in named] == ["cruising", "normal-braking", "sudden-braking", "cruising"]
    assert "median GPS trend -1.50" in named[1].rule and named[1].confidence == 1.0
    assert name_slowing_outer(labels, recording, names, [NB, SB], "cruising", pair, trend, 2.0) == names  # too slow
    assert name_slowing_outer(labels, recording, names, [NB, SB], "cruising", pair, None, 0.4) == names
    assert name_slowing_outer(labels, recording, named, [NB, SB], "cruising", pair, trend, 0.4) == named  # has one


@pytest.mark.parametrize("nesting, declared", [
    ((), (NB, SB)),  # no pair given: declarations alone do not make a class nested
    ([("sudden-braking", "normal-braking")], (["cruising"], ["cruising", "sudden-braking"])),  # outer undeclared
    ([("sudden-braking", "normal-braking")], (NB, ["cruising", "sudden-braking"])),  # inner where outer is not
])
def test_nesting_needs_the_pair_and_declarations_that_agree_with_it(nesting, declared):
    pooled, recording, labels, names = _nested_case()
    nested = name_nested(pooled, recording, labels, names, [list(d) for d in declared], "cruising", nesting)
    assert [n.name for n in nested] == [n.name for n in names]


def test_a_group_absent_from_the_straight_rides_takes_the_one_manoeuvre_of_each_recording():
    declared = [["straight", "gentle"], ["straight", "sharp"], ["straight", "gentle", "sharp"], ["straight"]]
    # group 0: straight everywhere; group 1: turning windows of every kind, never in the straight-only ride;
    # group 2: mostly straight-ride windows with a few in the gentle ride
    labels = np.array([0, 0, 1, 1, 2] + [0, 0, 1, 1, 1] + [0, 1, 1, 0, 0] + [0, 0, 0, 2, 2])
    recording = np.repeat(np.arange(4), 5)
    per_window = np.array(["straight"] * 20, dtype=object)
    names = name_clusters(presence_matrix(labels, recording, 3, 4), declared, "straight")
    assert [n.name for n in names] == ["straight"] * 3
    out, renamed = single_manoeuvre_names(labels, recording, per_window, declared, "straight", names)
    assert out.tolist() == (["straight", "straight", "gentle", "gentle", "straight"]
                            + ["straight", "straight", "sharp", "sharp", "sharp"]
                            + ["straight", "", "", "straight", "straight"]  # two manoeuvres declared: unnamed
                            + ["straight"] * 5)
    assert renamed[1].name == "gentle/sharp" and "declare only straight" in renamed[1].rule
    assert renamed[0] is names[0] and renamed[2] is names[2] and names[1].name == "straight"
    named = per_window.copy()
    named[2] = "slalom"  # a window named otherwise keeps its name
    assert single_manoeuvre_names(labels, recording, named, declared, "straight", names)[0][2] == "slalom"
    user = [*names[:1], ClusterName(1, "straight", "named by the user", 1.0), names[2]]
    assert single_manoeuvre_names(labels, recording, per_window, declared, "straight", user)[0].tolist() == (
        ["straight"] * 20)
    without = [d for d in declared if d != ["straight"]]  # no straight-only recording: nothing changes
    keep = recording < 3
    assert single_manoeuvre_names(labels[keep], recording[keep], per_window[keep], without, "straight",
                                  names)[0].tolist() == ["straight"] * 15


def test_a_background_group_leaning_deep_where_the_outer_class_is_at_home_takes_it():
    """Groups 1 and 2 lean x4 and x-4 (away from the hard stop: speeding up) in the normal-braking ride, group 0 is
    the usual stance, group 3 is sudden braking; only group 1 becomes normal braking, and nothing changes once a
    group is named normal braking, at a higher ratio, or when group 1 leans as usual."""
    labels = np.repeat([0, 1, 2, 3, 0, 3], [20, 5, 5, 2, 20, 8])
    recording = np.repeat([0, 0, 0, 0, 1, 1], [20, 5, 5, 2, 20, 8])
    depth = np.repeat([1.0, 4.0, -4.0, 4.0, 1.0, 4.0], [20, 5, 5, 2, 20, 8])
    names = [ClusterName(j, "cruising", "shared", 0.5) for j in range(3)] + [ClusterName(3, "sudden-braking", "x", 1)]
    named = name_deep_outer(labels, recording, names, [NB, SB], "cruising", [("sudden-braking", "normal-braking")],
                            depth)
    assert [n.name for n in named] == ["cruising", "normal-braking", "cruising", "sudden-braking"]
    assert "x4.0" in named[1].rule and named[1].confidence == pytest.approx(0.25)
    assert [n.name for n in names] == ["cruising"] * 3 + ["sudden-braking"]  # the input is not changed
    assert name_deep_outer(labels, recording, named, [NB, SB], "cruising", [("sudden-braking", "normal-braking")],
                           depth * 2)[2].name == "cruising"
    for ratio, d in ((5.0, depth), (3.0, np.where(labels == 1, 1.0, depth))):
        kept = name_deep_outer(labels, recording, names, [NB, SB], "cruising",
                               [("sudden-braking", "normal-braking")], d, ratio)
        assert [n.name for n in kept] == [n.name for n in names]


def test_a_group_named_a_braking_class_that_does_not_lean_where_that_class_is_at_home_goes_to_the_background():
    """Group 1, named sudden braking, is upright in the sudden-braking ride (a way of riding, median x0.2); group 2,
    named normal braking, leans away from the stop in the normal-braking ride (speeding up); group 3 leans x4 in the
    sudden-braking ride and keeps its name, and so do a user's name, a name given by nesting, and every name at a
    lower threshold or with the rule off."""
    nesting = [("sudden-braking", "normal-braking")]
    labels = np.repeat([0, 1, 2, 3, 0, 1, 2, 3], [20, 2, 6, 1, 20, 8, 2, 6])
    recording = np.repeat([0, 0, 0, 0, 1, 1, 1, 1], [20, 2, 6, 1, 20, 8, 2, 6])
    depth = np.repeat([0.1, 5.0, -2.0, 4.0, 0.1, 0.2, 5.0, 4.0], [20, 2, 6, 1, 20, 8, 2, 6])
    names = [ClusterName(0, "cruising", "shared", 0.5), ClusterName(1, "sudden-braking", "enriched x5", 0.8),
             ClusterName(2, "normal-braking", "enriched x4", 0.7), ClusterName(3, "sudden-braking", "enriched x6", 0.8)]
    named = rename_upright(labels, recording, names, [NB, SB], "cruising", nesting, depth)
    assert [n.name for n in named] == ["cruising", "cruising", "cruising", "sudden-braking"]
    assert "x0.20" in named[1].rule and named[1].confidence == pytest.approx(0.6)
    assert "x-2.00" in named[2].rule and named[2].confidence == 1.0
    assert [n.name for n in names][1:] == ["sudden-braking", "normal-braking", "sudden-braking"]  # input unchanged
    assert [n.name for n in rename_upright(labels, recording, names, [NB, SB], "cruising", nesting, depth, 0.1)] == [
        "cruising", "sudden-braking", "cruising", "sudden-braking"]
    kept = [names[0], ClusterName(1, "sudden-braking", "named by the user", 1.0),
            ClusterName(2, "normal-braking", "nearest", 0.5, nested=True), names[3]]
    assert [n.name for n in rename_upright(labels, recording, kept, [NB, SB], "cruising", nesting, depth)] == [
        n.name for n in kept]
