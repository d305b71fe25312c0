"""Spotting-free training on simulated rides: purity against the hidden labels, beside the paper's literal recipe."""

import json

import numpy as np
import pytest

from spotfree.errors import InputError
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import manoeuvre_share, simulate_scenario
from spotfree.training import TrainingConfig, TrainingExperiment, dictionary_purity, train

NB = ["cruising", "normal-braking"]
SB = ["cruising", "normal-braking", "sudden-braking"]


def _experiments(seed=0, k=1):
    nb = simulate_scenario("normal-braking", repeats=k, seed=seed).select_experiment(k)
    sb = simulate_scenario("sudden-braking", repeats=k, seed=seed + 1).select_experiment(k)
    return [TrainingExperiment(ride_features(nb, derived=True), NB),
            TrainingExperiment(ride_features(sb, derived=True), SB)]


@pytest.fixture(scope="module")
def experiments():
    return _experiments()


@pytest.fixture(scope="module")
def evidence(experiments):
    return train(experiments, TrainingConfig(seed=0))


def test_sudden_braking_is_a_small_share_with_confounders(experiments):
    sb = experiments[1].recording
    assert manoeuvre_share(sb.truth["label"], "sudden-braking") < 0.10
    assert any(e for e in sb.truth["event"])


IMPURE = {
    1: "normal braking 0.84: a slow-down at 0.34 m/s^2 whose GPS speed falls at 0.47 m/s^2",
}
"""Seeds of the protocol where some class is below 0.98 or has no column (``benchmarks/training_purity.py --seeds 0 ...
479``, BENCHMARKS.md): every class is pure on the 39 others. Seeds 0-7 are the ones the training's defaults were
chosen on, seed 8 the one the lean depth was (:func:`spotfree.training._shallow_inner`); every class is pure on 159 of
seeds 0-159, 158 of seeds 160-319, 159 of seeds 320-479, 158 of seeds 480-639 and 157 of seeds 640-799."""


@pytest.mark.parametrize("seed", [
    pytest.param(s, marks=pytest.mark.xfail(strict=True, reason=f"measured: {IMPURE[s]}") if s in IMPURE else ())
    for s in range(40)
])
def test_dictionary_is_pure_and_beats_the_papers_literal_recipe(seed):
    experiments = _experiments(seed)
    ours = dictionary_purity(train(experiments, TrainingConfig(seed=0)), experiments)
    paper = dictionary_purity(train(experiments, TrainingConfig(recipe="paper", seed=0)), experiments)
    print(f"purity per class: evidence {ours}, paper recipe {paper}")
    assert set(ours) == set(SB)
    assert min(ours.values()) >= 0.98
    assert min(ours.values()) > min(paper.get(c, 0.0) for c in SB)


def test_every_column_comes_from_a_recording_that_declares_its_class():
    # on this seed a group named sudden braking also holds windows of the normal-braking ride (no sudden braking)
    experiments = _experiments(seed=1)
    result = train(experiments, TrainingConfig(seed=0))
    named = np.array(result.model.classes)[result.model.column_class]
    sources = np.array([r for r, _ in result.column_source])
    assert (sources[named == "sudden-braking"] == 1).all() and (named == "sudden-braking").any()
    assert all(name in experiments[r].classes for name, r in zip(named, sources))


def test_label_column_is_never_read_and_the_same_seed_gives_the_same_model_file(experiments, evidence, tmp_path):
    rng = np.random.default_rng(5)
    copies = [TrainingExperiment(e.recording.take(slice(None)), e.classes) for e in experiments]
    for e in copies:
        e.recording.truth["label"] = rng.permutation(e.recording.truth["label"])
    train(copies, TrainingConfig(seed=0)).model.save(tmp_path / "a.npz")
    evidence.model.save(tmp_path / "b.npz")
    a, b = np.load(tmp_path / "a.npz"), np.load(tmp_path / "b.npz")
    assert a.files == b.files
    assert all(np.array_equal(a[k], b[k]) for k in a.files)


def test_user_can_override_a_name(experiments):
    short = [TrainingExperiment(e.recording.take(slice(0, 400)), e.classes) for e in experiments]
    result = train(short, TrainingConfig(seed=0, overrides={0: "parked"}))
    assert result.names[0].name == "parked" and result.names[0].rule == "named by the user"


def test_each_window_takes_the_name_most_clusterings_gave_it(monkeypatch):
    """Runs with seeds 0, 1, 2 (stand-ins for the evidence recipe); a tie keeps the first run's name; levels and
    cluster names are the first run's; a user's override makes one run."""
    import spotfree.training as training

    given = {0: ["a", "a", "b", "c"], 1: ["b", "a", "b", "b"], 2: ["b", "c", "a", "a"]}
    seeds = []

    def recipe(windows, declared, background, lean, slopes, config, say):
        seeds.append(config.seed)
        return [np.array(given[config.seed])], f"levels {config.seed}", f"names {config.seed}", []

    monkeypatch.setattr(training, "_evidence_recipe", recipe)
    voted, levels, names, _ = training._voted_names([None], [SB], "cruising", None, None, TrainingConfig(votes=3),
                                                     print)
    assert voted[0].tolist() == ["b", "a", "b", "c"] and (levels, names) == ("levels 0", "names 0")
    assert seeds == [0, 1, 2]
    seeds.clear()
    training._voted_names([None], [SB], "cruising", None, None, TrainingConfig(votes=3, overrides={0: "x"}),
                          print)
    assert seeds == [0]
    with pytest.raises(InputError, match="votes"):
        train(_experiments(), TrainingConfig(votes=0))


def test_a_vote_of_five_clusterings_keeps_the_sudden_stop_one_clustering_lost():
    """Seed 113 without the deepest lean's name: with clustering seed 0 alone, sudden braking keeps one column, on the
    lean-in, 7 samples before the plateau; the vote of seeds 0-4 is pure. (Seed 48 showed it until the onset rule of
    ``_shallow_inner`` and the sudden stop's keep in ``_purify`` made one clustering pure there too.)"""
    experiments = _experiments(113)
    one = dictionary_purity(train(experiments, TrainingConfig(seed=0, deepest_inner=False)), experiments)
    voted = dictionary_purity(train(experiments, TrainingConfig(seed=0, votes=5, deepest_inner=False)), experiments)
    assert one.get("sudden-braking", 0.0) < 0.98
    assert set(voted) == set(SB) and min(voted.values()) >= 0.98


def test_a_manoeuvre_that_would_keep_no_window_keeps_the_centres_of_its_runs():
    """Normal braking's runs (windows 4-6 and 10-13) kept no window near the changes of name: they keep their centres,
    5 and 12. Sudden braking keeps a window elsewhere, so its short run 28-29 stays dropped; the background and
    unnamed windows are left alone; the input is not changed."""
    from spotfree.training import _short_run_centres

    per = np.array(["cruising"] * 4 + ["normal-braking"] * 3 + ["cruising"] * 3 + ["normal-braking"] * 4
                   + [""] * 3 + ["sudden-braking"] * 9 + ["cruising"] * 2 + ["sudden-braking"] * 2)
    kept = np.zeros(len(per), dtype=bool)
    kept[[0, 1, 19, 20, 21, 22, 23]] = True
    out = _short_run_centres([per], [kept], "cruising")[0]
    assert np.flatnonzero(out & ~kept).tolist() == [5, 12]
    assert out[kept].all() and kept.sum() == 7
    assert _short_run_centres([per], [kept | (per == "normal-braking")], "cruising")[0].tolist() == (
        kept | (per == "normal-braking")).tolist()


def test_the_centres_of_short_runs_give_normal_braking_its_columns(monkeypatch):
    """Seed 103: nesting names a group that holds only the deepest 2-5 windows of each normal stop; without the
    centres of those runs the model has no normal-braking column, with them every class is pure."""
    import spotfree.training

    experiments = _experiments(103)
    default = dictionary_purity(train(experiments, TrainingConfig(seed=0)), experiments)
    monkeypatch.setattr(spotfree.training, "_short_run_centres", lambda names, kept, background: kept)
    without = dictionary_purity(train(experiments, TrainingConfig(seed=0)), experiments)
    assert "normal-braking" not in without
    assert set(default) == set(SB) and min(default.values()) >= 0.98


def test_a_model_with_a_class_found_by_clustering_the_background_again_is_saved_and_loaded(tmp_path):
    """Seed 82 without GPS speed (with it, the background group that loses speed fastest names normal braking first):
    normal braking is found only among the background's windows clustered anew (the rule in the model's summary);
    the model file is written and read back with it."""
    from spotfree.model import DictionaryModel

    model = train(_experiments(82), TrainingConfig(seed=0, slowing=0.0)).model
    found = [c for c in model.summary["clusters"] if c["rule"].startswith("re-clustered background")]
    assert [c["name"] for c in found] == ["normal-braking"]
    model.save(tmp_path / "m.npz")
    assert DictionaryModel.load(tmp_path / "m.npz").summary["clusters"] == json.loads(json.dumps(
        model.summary["clusters"]))


def test_bad_declarations_are_clear_errors(experiments):
    with pytest.raises(InputError, match="every --experiment"):
        train([TrainingExperiment(experiments[0].recording, ["normal-braking"]),
               TrainingExperiment(experiments[1].recording, ["sudden-braking"])])
    with pytest.raises(InputError, match="shorter --window"):
        train(experiments, TrainingConfig(window=100_000))
    with pytest.raises(InputError, match="no column"):
        train(experiments, TrainingConfig(channels=("pitch", "speedometer")))


def test_a_class_every_recording_declares_and_no_cluster_takes_is_explained(experiments):
    """Without GPS speed nothing tells normal braking from cruising when every recording declares it; with it, the
    background group that loses speed fastest takes it, purely."""
    both_normal = [TrainingExperiment(experiments[0].recording, NB), TrainingExperiment(experiments[1].recording, NB)]
    with_gps = train(both_normal, TrainingConfig(seed=0))
    assert any(n.name == "normal-braking" and "loses speed fastest" in n.rule for n in with_gps.names)
    assert dictionary_purity(with_gps, both_normal)["normal-braking"] >= 0.98
    result = train(both_normal, TrainingConfig(seed=0, slowing=0.0))
    assert "normal-braking" not in result.model.classes
    warning = next(w for w in result.warnings if "'normal-braking' was given no cluster" in w)
    assert "every recording declares it" in warning and "--name CLUSTER=normal-braking" in warning


def test_causal_columns_include_the_first_windows_of_a_manoeuvre():
    """A causal column ends where its class begins even though purification dropped the centred window there."""
    from spotfree.training import _causal_columns
    from spotfree.windows import WindowedRecording

    names = np.array(["cruising"] * 12 + ["sudden-braking"] * 8 + ["cruising"] * 12, dtype=object).astype(str)
    matrix = np.arange(len(names), dtype=float)[None, :].repeat(3, axis=0)  # column k holds k
    windows = [WindowedRecording(matrix, np.arange(len(names)), None)]
    config = TrainingConfig(window=8, train_step=1)  # shift: 4 windows
    kept = [np.abs(np.arange(len(names)) - 12) >= 4]  # purification drops the windows near the change at 12
    dictionary, column_class = _causal_columns(windows, [names], kept, ["cruising", "sudden-braking"], 3, config)
    sudden = np.sort(dictionary[0, column_class == 1]).astype(int)
    np.testing.assert_array_equal(sudden, np.arange(12 - 4, 20 - 4))
    config.causal_onsets = False  # only where the centred window was kept: the first four are gone
    dictionary, column_class = _causal_columns(windows, [names], kept, ["cruising", "sudden-braking"], 3, config)
    np.testing.assert_array_equal(np.sort(dictionary[0, column_class == 1]).astype(int), np.arange(12, 20 - 4))


def test_causal_names_give_the_ends_of_a_nested_run_to_the_class_it_passes_through():
    """Half a window at each end of a sudden-braking run is normal braking for the causal columns; short runs,
    recordings that do not declare both classes, and training where no window was named normal braking (seed 12 of
    the purity protocol) are left alone."""
    from spotfree.training import _causal_names

    names = np.array(["cruising"] * 12 + ["sudden-braking"] * 12 + ["cruising"] * 4 + ["sudden-braking"] * 8
                     + ["cruising"] * 4 + ["normal-braking"] * 3, dtype=object).astype(str)
    config = TrainingConfig(window=8, train_step=1)  # half a window: 4 windows
    cut, alone = _causal_names([names, names], [SB, ["cruising", "sudden-braking"]], SB, config)
    expected = names.copy()
    expected[12:16] = expected[20:24] = "normal-braking"
    np.testing.assert_array_equal(cut, expected)
    np.testing.assert_array_equal(alone, names)
    assert (names[12:16] == "sudden-braking").all()  # the input is not changed
    unnamed = np.where(names == "normal-braking", "cruising", names)
    np.testing.assert_array_equal(_causal_names([unnamed], [SB], ["cruising", "sudden-braking"], config)[0], unnamed)


def test_a_model_without_an_outer_class_still_trains():
    """Seed 12 without the lean's naming of normal braking, without the second look among the background's windows
    and without GPS speed (each gives it a group there): sudden braking named, normal braking given no cluster; the
    causal columns used to fail on it."""
    experiments = _experiments(12)
    result = train(experiments, TrainingConfig(seed=0, outer_depth=0.0, recluster=False, slowing=0.0))
    assert "normal-braking" not in result.model.classes and "sudden-braking" in result.model.classes
    assert any("'normal-braking' was given no cluster" in w for w in result.warnings)


def test_a_class_named_but_left_without_columns_is_warned_about():
    """Seed 239: a group is named normal braking, but none of its windows becomes a column; the model says so."""
    experiments = _experiments(239)
    result = train(experiments, TrainingConfig(seed=0))
    assert result.model.summary["columns_per_class"]["normal-braking"] == 0
    assert any("'normal-braking' was named but none of its windows was kept" in w for w in result.warnings)
    assert result.model.summary["warnings"] == result.warnings


def test_the_model_carries_the_landmarks_its_kernel_classifier_uses(evidence):
    from dataclasses import replace

    from spotfree.classify.batch import dictionary_classifier

    model = evidence.model
    assert model.parameters["landmarks"] == 64
    assert dictionary_classifier(model, "kcrc", causal=True).landmarks == 64
    assert dictionary_classifier(model, "kcrc", causal=True, landmarks=16).landmarks == 16
    older = replace(model, parameters={k: v for k, v in model.parameters.items() if k != "landmarks"})
    assert dictionary_classifier(older, "kcrc", causal=True).landmarks == 32


def test_names_are_moved_to_the_timing_of_the_lean():
    """Windows named braking three windows after the lean drops are moved three windows earlier; without the
    channel, or with timing off, names stay as clustered."""
    from types import SimpleNamespace

    from spotfree.training import _align_names
    from spotfree.windows import WindowedRecording

    n = 60
    names = np.array(["cruising"] * n, dtype=object).astype("<U16")
    names[20:32] = "normal-braking"
    config = TrainingConfig(window=20, train_step=2)  # half a window: 5 windows
    ends = 19 + 2 * np.arange(n)
    lean = np.zeros(ends[-1] + 1)
    lean[ends[17:29] - 10] = -1.0  # the lean drops 3 windows before the names say braking
    windows = [WindowedRecording(np.zeros((3, n)), ends, None)]
    rides = [SimpleNamespace(recording=SimpleNamespace(channels={"lean": lean}))]
    (aligned,), lags = _align_names([names], rides, windows, "cruising", config, lambda m: None)
    assert lags == [3]
    assert (np.flatnonzero(aligned == "normal-braking") == np.arange(17, 29)).all()
    assert (aligned[-3:] == "").all()
    config.timing = None
    unaligned = _align_names([names], rides, windows, "cruising", config, lambda m: None)[0][0]
    np.testing.assert_array_equal(unaligned, names)
    config.timing = "lean"
    bare = [SimpleNamespace(recording=SimpleNamespace(channels={}))]
    assert _align_names([names], bare, windows, "cruising", config, lambda m: None)[1] is None


def test_a_half_of_a_nested_group_shared_by_the_rides_goes_to_the_background():
    """Seed 0 of the training protocol: nesting named a group normal braking whose halves hold 175 / 39 windows
    (normal braking, in the ride made for it) and 129 / 149 (cruising, shared); only the shared half is renamed, and
    only when the other half is enriched."""
    from spotfree.training import _shared_half

    recording = np.r_[np.zeros(680, dtype=int), np.ones(760, dtype=int)]
    windows_of = lambda n0, n1, start=0: np.r_[np.arange(start, start + n0), 680 + np.arange(start, start + n1)]
    enriched, shared = windows_of(175, 39), windows_of(129, 149, start=200)
    named = _shared_half(recording, shared, enriched, [NB, SB], "cruising", "normal-braking")
    assert named is not None and named.name == "cruising"
    assert _shared_half(recording, enriched, shared, [NB, SB], "cruising", "normal-braking") is None
    assert _shared_half(recording, windows_of(82, 50), windows_of(10, 5, start=100), [NB, SB], "cruising",
                        "normal-braking") is None  # neither half enriched: the group keeps its name


def test_causal_columns_are_named_by_the_state_their_window_ends_in(experiments, evidence):
    """Causal classification (batch and stream) uses the columns named at their window's end; centred, the others."""
    from spotfree.classify.batch import classify_recording, dictionary_classifier
    from spotfree.classify.stream import RideClassifier

    model = evidence.model
    assert model.causal_dictionary is not None and set(model.causal_column_class) == set(range(len(model.classes)))
    ride = simulate_scenario("sudden-braking", repeats=2, seed=5).select_experiment(2)
    causal = classify_recording(model, ride).label
    assert (causal == classify_recording(model, ride, classifier=dictionary_classifier(model, causal=True)).label).all()
    assert (causal != classify_recording(model, ride, classifier=dictionary_classifier(model)).label).any()
    stream = RideClassifier(model)
    acc, gyr, speed = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.channels["speed"]
    streamed = np.array([stream.update(a, w, t, v) or "" for a, w, t, v in zip(acc, gyr, ride.time, speed)])
    np.testing.assert_array_equal(streamed, causal)


def test_a_manoeuvre_takes_its_columns_only_from_the_recordings_made_for_it(experiments, evidence):
    """Normal braking is passed through in the sudden-braking ride: its windows there are no normal-braking columns;
    the background's and sudden braking's are."""
    from spotfree.training import _away_from_home

    per = np.array(["cruising", "normal-braking", "sudden-braking", "", "cruising"])
    away = _away_from_home([per[:2], per], [NB, SB], "cruising")
    assert away[0].tolist() == [False, False]
    assert away[1].tolist() == [False, True, False, False, False]
    named = np.array(evidence.model.classes)[evidence.model.column_class]
    sources = np.array([r for r, _ in evidence.column_source])
    assert (named == "normal-braking").any() and (sources[named == "normal-braking"] == 0).all()


def test_the_inner_class_keeps_only_its_most_confident_quarter_and_is_pure():
    """Seed 660: every sudden-braking window would take in the plateau of a near-sudden normal stop, which the
    margin ranks below the hard stops' (seeds 21 and 64 showed it before the sudden stop's onset rule)."""
    experiments = _experiments(660)
    every = dictionary_purity(train(experiments, TrainingConfig(seed=0, inner_quantile=0.0)), experiments)
    quarter = dictionary_purity(train(experiments, TrainingConfig(seed=0)), experiments)
    assert every["sudden-braking"] < 0.98 <= quarter["sudden-braking"]
    assert min(quarter.values()) >= 0.98


def test_the_inner_class_takes_no_column_where_the_lean_is_shallow_in_its_run_or_the_recording():
    """Window k is centred on sample k + 2; a run's windows keep the inner name only where |lean - median| is at
    least ``inner_depth`` of the run's deepest, each run on its own scale, and ``inner_floor`` of the deepest window
    named the inner class in the recording, and where the window before is too (the lean leads: window 10, the
    deepest, follows a shallow one); unless that leaves the recording no inner window, when the window before does
    not count. Other classes are never marked."""
    from types import SimpleNamespace

    from spotfree.training import _shallow_inner, _timing_offset

    lean = np.r_[np.zeros(10), [-0.1, -0.5, -1.0, -0.9, -0.3], np.zeros(5), [0.05, 0.2, 0.1], np.zeros(9)]
    names = np.array(["cruising"] * 8 + ["sudden-braking"] * 5 + ["cruising"] * 5 + ["sudden-braking"] * 3
                     + ["normal-braking"] * 7, dtype=object).astype(str)
    recording = SimpleNamespace(recording=SimpleNamespace(channels={"lean": lean}))
    windows = [SimpleNamespace(ends=np.arange(len(names)) + 4)]
    def shallow_inner(config):
        return _shallow_inner([names], _timing_offset([recording], windows, config), config)[0]

    assert np.flatnonzero(shallow_inner(TrainingConfig(window=4, inner_floor=0.0))).tolist() == [
        8, 9, 10, 12, 18, 19, 20]
    assert np.flatnonzero(shallow_inner(TrainingConfig(window=4, inner_depth=0.0, inner_floor=0.15))).tolist() == [
        8, 9, 18, 19, 20]  # 0.1 and 0.05 are below 0.15 of the recording's deepest, 1.0; 9 and 19 follow them
    assert np.flatnonzero(shallow_inner(TrainingConfig(window=4))).tolist() == [8, 9, 10, 12, 18, 19, 20]
    assert np.flatnonzero(shallow_inner(TrainingConfig(window=4, inner_depth=0.95, inner_floor=0.0))).tolist() == [
        8, 9, 11, 12, 18, 20]  # only window 10 reaches 0.95 of its run, and it follows a shallow one
    assert not shallow_inner(TrainingConfig(window=4, inner_depth=0.0, inner_floor=0.0)).any()
    assert not shallow_inner(TrainingConfig(window=4, timing=None)).any()
    with pytest.raises(InputError, match="inner_depth"):
        train(_experiments(), TrainingConfig(inner_depth=1.5))
    with pytest.raises(InputError, match="inner_floor"):
        train(_experiments(), TrainingConfig(inner_floor=-0.1))


@pytest.mark.parametrize("seed", [320, 383, 476])
def test_a_sudden_stop_gives_columns_from_its_plateau_not_from_its_onset(seed):
    """Seeds where the one sudden-braking column of a stop lay one sample before its plateau (purity 0.83 / 0.83 /
    0.5): leave-run-out had dropped the plateau (nearer to normal braking than to the ride's other, softer stop), and
    the lean, which leads, was already deep at the onset. Every column is now centred on the plateau."""
    experiments = _experiments(seed)
    result = train(experiments, TrainingConfig(seed=0))
    sudden = result.model.classes.index("sudden-braking")
    centres = [(r, end - result.model.window // 2) for (r, end), c in zip(result.column_source,
                                                                           result.model.column_class) if c == sudden]
    labels = [experiments[r].recording.truth["label"][c] for r, c in centres]
    assert labels and set(labels) == {"sudden-braking"}
    assert min(dictionary_purity(result, experiments).values()) >= 0.98


def test_the_deepest_lean_beyond_the_other_recordings_names_the_inner_class_with_its_margin():
    """Window k is centred on sample k + 2; the normal-braking ride leans at most 0.3 from its median, the sudden
    one to 1.0 at windows 10-11: those two (>= 0.8 of 1.0 and beyond 0.3) and the purification margin (one window
    each side for a 4-sample window at training step 2) take the inner name; a shallower second dip does not."""
    from types import SimpleNamespace

    from spotfree.training import _deepest_inner, _timing_offset

    def ride(lean, classes):
        return SimpleNamespace(recording=SimpleNamespace(channels={"lean": np.asarray(lean)}), classes=classes)

    calm = np.r_[np.zeros(10), -0.3, np.zeros(13)]
    stop = np.r_[np.zeros(10), -0.2, -0.5, -0.9, -1.0, -0.6, np.zeros(3), -0.7, np.zeros(6)]
    names = [np.full(20, "cruising", dtype=object).astype(str) for _ in range(2)]
    windows = [SimpleNamespace(ends=np.arange(20) + 4)] * 2
    experiments = [ride(calm, NB), ride(stop, SB)]
    config = TrainingConfig(window=4, inner_depth=0.8)
    def deepest_inner(names, experiments, windows, config):
        offset = _timing_offset(experiments, windows, config)
        return _deepest_inner(names, offset, [e.classes for e in experiments], config)

    named = deepest_inner(names, experiments, windows, config)
    assert np.flatnonzero(named[1] == "sudden-braking").tolist() == [9, 10, 11, 12]
    assert (named[0] == "cruising").all() and (names[1] == "cruising").all()  # the input is not changed
    for off in (TrainingConfig(window=4, deepest_inner=False), TrainingConfig(window=4, timing=None)):
        assert (deepest_inner(names, experiments, windows, off)[1] == "cruising").all()
    shallow = [ride(np.r_[stop[:14], -0.2, stop[15:]] * 0.25, SB), ride(calm, NB)]
    assert (deepest_inner(names, shallow, windows, config)[0] == "cruising").all()  # never beyond 0.3


def test_a_class_no_window_was_named_is_looked_for_again_among_the_background_windows():
    """Two recordings, the second declaring X: its 30 windows near (4, 4) were all named the background by the first
    clustering; clustered anew, they form a group present only where X is declared and take X, and the background
    windows keep their name. With every class named nothing changes."""
    from spotfree.training import _recluster_background

    rng = np.random.default_rng(0)
    pooled = np.hstack([rng.normal(0, 0.3, (2, 100)), rng.normal(0, 0.3, (2, 70)), rng.normal(4, 0.3, (2, 30))])
    recording = np.r_[np.zeros(100, dtype=int), np.ones(100, dtype=int)]
    per_window = np.full(200, "bg", dtype=object)
    declared = [["bg"], ["bg", "X"]]
    names, level2 = [], np.zeros(200, dtype=int)
    config = TrainingConfig(extra_clusters=1, clustering="kmeans")
    found, levels = _recluster_background(pooled, recording, per_window, level2, names, declared, "bg", None, config,
                                          lambda message: None)
    assert (found[170:] == "X").all() and (found[:170] == "bg").all()
    assert (per_window == "bg").all()  # the input is left as it was
    assert len(set(levels[170:])) == 1 and levels[170] > 0 and (levels[:100] == 0).all()
    assert [n.name for n in names] == ["X"] and names[0].rule.startswith("re-clustered background: present only")
    assert type(names[0].cluster) is int  # the model file's JSON summary holds it
    again, _ = _recluster_background(pooled, recording, found, levels, names, declared, "bg", None, config,
                                     lambda message: None)
    assert (again == found).all() and len(names) == 1


def test_the_background_takes_no_column_where_the_lean_goes_towards_the_stop():
    """Lean in units of the usual depth, pooled over two recordings: only windows named the background above the
    share are marked; the other names, the share 0 and a missing lean mark none."""
    from spotfree.training import _leaning_background

    names = [np.array(["cruising", "cruising", "normal-braking", "cruising"]), np.array(["cruising", "sudden-braking"])]
    lean = np.array([0.2, 0.9, 3.0, -2.0, 0.61, 5.0])
    marked = _leaning_background(names, lean, "cruising", TrainingConfig(background_lean=0.6))
    assert [m.tolist() for m in marked] == [[False, True, False, False], [True, False]]
    for config, depth in ((TrainingConfig(background_lean=0.0), lean), (TrainingConfig(), None)):
        assert not any(m.any() for m in _leaning_background(names, depth, "cruising", config))
    with pytest.raises(InputError, match="background_lean"):
        train(_experiments(), TrainingConfig(background_lean=-1.0))


NO_GPS = {"slowing": 0.0}


@pytest.mark.parametrize("seed, changed, cls, base", [
    (2, {"inner_depth": 0.0, "inner_floor": 0.0}, "sudden-braking", {}),
    (91, {"inner_floor": 0.0}, "sudden-braking", {}),
    (82, {"recluster": False}, "normal-braking", NO_GPS),
    (225, {"background_lean": 0.0}, "cruising", NO_GPS),
    (131, {"outer_quantile": 0.0}, "normal-braking", {}),
    (18, {"deepest_inner": False}, "sudden-braking", {}),
    (29, {"outer_depth": 0.0}, "normal-braking", NO_GPS),
    (34, {"upright": 0.0}, "normal-braking", {})])
def test_each_lean_rule_and_the_outer_quantile_make_a_class_pure(seed, changed, cls, base):
    """Seed 2: the sudden-braking runs start half a window before the hard plateau, and their first centred windows
    are normal braking (seed 8 before the deepest lean was named); the run's depth or the ride's floor each drops
    them. Seed 131: normal braking also takes
    cruising at the edge of a stop, where the GPS speed's trend over 3 s already falls; its most confident half does
    not. Seed 18: no group is named sudden
    braking, but the stop leans deeper than anything in the normal-braking ride. Seed 29: no group is named normal
    braking (both rides hold it), but one leans four times the usual depth in the normal-braking ride. Seed 34: the
    normal-braking rider's cruising is named normal braking (enriched), though it leans no deeper than usual (seed
    53 showed the same for sudden braking before the sudden stop's onset rule; no seed of 0-479 does now, with GPS
    speed or without). Seed 91: without the ride's floor, half the sudden-braking columns are
    wrong (seed 33 showed it before the onset rule). Seed 82: six groups of sudden stops leave normal braking inside
    a group of cruising, enriched x2.2; clustering the background's windows anew gives it a group of its own. Seeds 82 and
    29 without GPS speed: with it, the background group that loses speed fastest names normal braking first. Seed
    225, without GPS speed (with it, the background takes no column that loses speed): a stretch of gentle braking
    in a cruising group gives cruising columns leaning x1.1-x1.8 of the usual depth."""
    experiments = _experiments(seed)
    without = dictionary_purity(train(experiments, TrainingConfig(seed=0, **base, **changed)), experiments)
    default = dictionary_purity(train(experiments, TrainingConfig(seed=0, **base)), experiments)
    assert without.get(cls, 0.0) < 0.98 <= default[cls]
    assert set(default) == set(SB) and min(default.values()) >= 0.98


def test_closing_the_gaps_joins_a_stop_clustered_in_pieces_into_pure_columns(experiments):
    """Seed 0 (seed 4 before the simulator's first-sample fix): each sudden stop is named in pieces split by a few
    background windows, so purification drops nearly every piece and the dictionary's one sudden-braking column is
    the lean-in of a stop (the deepest lean's name, off here, now also keeps the deepest piece)."""
    apart = dictionary_purity(train(experiments, TrainingConfig(seed=0, close_gaps=0, deepest_inner=False)),
                              experiments)
    joined = train(experiments, TrainingConfig(seed=0, deepest_inner=False))
    assert apart.get("sudden-braking", 0.0) < 0.98
    purity = dictionary_purity(joined, experiments)
    assert set(purity) == set(SB) and min(purity.values()) >= 0.98


def test_close_gaps_fills_only_short_background_runs_between_runs_of_one_manoeuvre():
    from spotfree.training import _close_gaps

    per = np.array(["c", "s", "s", "c", "c", "s", "n", "s", "c", "c", "c", "n", "c", "s"])
    closed = _close_gaps([per], "c", 2)[0]
    assert closed.tolist() == ["c", "s", "s", "s", "s", "s", "n", "s", "c", "c", "c", "n", "c", "s"]
    assert _close_gaps([per], "c", 0)[0].tolist() == per.tolist()
    with pytest.raises(InputError, match="close_gaps"):
        train(_experiments(), TrainingConfig(close_gaps=-1))


def test_the_inner_class_quantile_keeps_the_columns_at_or_above_it():
    from spotfree.training import _cap

    column_class = np.r_[np.zeros(4, dtype=int), np.ones(9, dtype=int)]
    margin = np.r_[np.full(4, 0.5), 0.1, np.linspace(0.2, 0.8, 8)]  # class 1: one column below min_margin
    chosen, fallback = _cap(column_class, margin, 2, 600, 0.15, [0.0, 0.75])
    assert chosen.tolist() == [0, 1, 2, 3, 11, 12] and fallback == []
    chosen, _ = _cap(column_class, margin, 2, 600, 0.15, [0.0, 0.0])
    assert chosen.tolist() == [0, 1, 2, 3] + list(range(5, 13))
    with pytest.raises(InputError, match="inner_quantile"):
        train(_experiments(), TrainingConfig(inner_quantile=1.0))
    with pytest.raises(InputError, match="outer_quantile"):
        train(_experiments(), TrainingConfig(outer_quantile=-0.1))


def test_the_speed_trend_is_the_least_squares_slope_of_the_fixes_near_each_sample():
    from spotfree.training import speed_slope

    rng = np.random.default_rng(0)
    speed = np.full(400, np.nan)
    fixes = np.sort(rng.choice(400, 30, replace=False))
    speed[fixes] = rng.normal(5.0, 1.0, 30)
    at = np.arange(0, 400, 7)
    slope = speed_slope(speed, 20.0, at, span=1.5)
    for k, value in zip(at, slope):
        near = fixes[np.abs(fixes - k) <= 30]
        if len(near) < 2:
            assert np.isnan(value)
        else:
            assert value == pytest.approx(np.polyfit(near / 20.0, speed[near], 1)[0], abs=1e-9)
    assert np.isnan(slope).any() and np.isfinite(slope).any()
    assert np.isnan(speed_slope(np.full(50, np.nan), 20.0, np.arange(50))).all()


@pytest.mark.parametrize("seed", [17, 23])
def test_a_braking_column_loses_speed(seed):
    """Seeds 17 and 23: normal braking also takes windows of steady cruising that ``acc_long`` reads as braking
    (0.97 pure without the GPS). With it, every braking column's GPS speed falls at 0.4 m/s^2 or more around its
    centre, and no cruising column's does; a recording without ``speed`` leaves the rule off."""
    from spotfree.training import speed_slope

    experiments = _experiments(seed)
    assert all("speed" in e.recording.channels for e in experiments)
    without = dictionary_purity(train(experiments, TrainingConfig(seed=0, slowing=0.0)), experiments)
    result = train(experiments, TrainingConfig(seed=0))
    default = dictionary_purity(result, experiments)
    assert without["normal-braking"] < 0.98 and set(default) == set(SB) and min(default.values()) >= 0.98
    model = result.model
    for (r, end), c in zip(result.column_source, model.column_class):
        trend = speed_slope(experiments[r].recording.channels["speed"], 20.0, np.array([end - model.window // 2]))
        assert (not trend[0] <= -0.4) if model.classes[c] == "cruising" else (trend[0] <= -0.4)  # NaN: no fix
    no_gps = [TrainingExperiment(e.recording.with_channels(
        {k: v for k, v in e.recording.channels.items() if k != "speed"}), e.classes) for e in experiments]
    off = train(no_gps, TrainingConfig(seed=0, slowing=0.0)).model
    assert np.array_equal(train(no_gps, TrainingConfig(seed=0)).model.dictionary, off.dictionary)
    from spotfree.training import _window_slopes
    from spotfree.windows import recording_windows

    mixed = [no_gps[0], experiments[1]]  # the rule reads the GPS where there is one
    windows = [recording_windows(e.recording, ("acc_long",), 20, 2) for e in mixed]
    slopes = _window_slopes(mixed, windows, TrainingConfig())
    assert np.isnan(slopes[0]).all() and np.isfinite(slopes[1]).mean() > 0.9
    assert _window_slopes(mixed, windows, TrainingConfig(slowing=0.0)) is None
    with pytest.raises(InputError, match="slowing"):
        train(experiments, TrainingConfig(slowing=-0.1))


def test_the_gps_speed_marks_braking_that_keeps_speed_and_background_that_loses_it():
    """Per window, the trend (m/s^2) against the name: braking above -0.4 and the background at or below it are
    marked, an unknown trend never; the background only where a braking class is declared."""
    from spotfree.training import _speed_disagrees

    names = [np.array(["cruising", "cruising", "normal-braking", "sudden-braking", "cruising", "normal-braking"])]
    slopes = [np.array([-0.5, 0.2, -0.3, -1.5, np.nan, np.nan])]
    marked = _speed_disagrees(names, slopes, "cruising", [SB], TrainingConfig())
    assert marked[0].tolist() == [True, False, True, False, False, False]
    lateral = _speed_disagrees([np.array(["straight", "straight"])], [np.array([-0.5, 0.2])], "straight",
                               [["straight", "turn"]], TrainingConfig())
    assert not lateral[0].any()
    assert not _speed_disagrees(names, None, "cruising", [SB], TrainingConfig())[0].any()


@pytest.mark.parametrize("seed, wrong", [(67, "normal-braking"), (409, "normal-braking"), (452, "cruising"),
                                         (450, "normal-braking")])
def test_the_gps_speed_names_normal_braking_and_keeps_it_out_of_the_background(seed, wrong):
    """Seed 67: nesting named normal braking after the shared group nearest to the hard stops, steady cruising whose
    columns the GPS check then dropped (no normal-braking column); the nearest group that loses speed names it now.
    Seeds 409 and 452: normal braking left in cruising groups gave cruising columns that lose speed (452: 0.96 pure),
    or, 409, a mixed group that nesting named (normal braking 0.56). Seed 450: no group was named normal braking at
    all; the background group that loses speed fastest in the normal-braking ride takes it. Without the GPS rules the
    class fails."""
    experiments = _experiments(seed)
    result = train(experiments, TrainingConfig(seed=0))
    purity = dictionary_purity(result, experiments)
    assert set(purity) == set(SB) and min(purity.values()) >= 0.98
    assert dictionary_purity(train(experiments, TrainingConfig(seed=0, slowing=0.0)), experiments).get(
        wrong, 0.0) < 0.98
    rule = {67: "passes through normal-braking", 450: "loses speed fastest"}.get(seed)
    assert rule is None or any(rule in n.rule and "median GPS trend" in n.rule for n in result.names)


def test_a_braking_group_the_background_explains_keeps_its_name_when_it_loses_speed():
    """Seed 246: the group nesting names normal braking is explained by cruising's windows (66 %) and went to the
    background, leaving normal braking without a column; its GPS speed falls at 0.65 m/s^2, so it stays."""
    from spotfree.training import _speed_loss

    experiments = _experiments(246)
    result = train(experiments, TrainingConfig(seed=0))
    assert any("keeps normal-braking: it loses speed" in n.rule for n in result.names)
    purity = dictionary_purity(result, experiments)
    assert set(purity) == set(SB) and min(purity.values()) >= 0.98
    assert "normal-braking" not in dictionary_purity(train(experiments, TrainingConfig(seed=0, slowing=0.0)),
                                                      experiments)
    slope = np.array([-0.9, -0.5, np.nan, 0.1, -0.2])
    config = TrainingConfig()
    assert _speed_loss(slope, np.array([0, 1, 2]), "normal-braking", config) == pytest.approx(-0.7)
    assert _speed_loss(slope, np.array([1, 3, 4]), "normal-braking", config) is None  # median -0.2
    assert _speed_loss(slope, np.array([0, 1]), "cruising", config) is None  # not a braking class
    assert _speed_loss(None, np.array([0, 1]), "normal-braking", config) is None  # no GPS
