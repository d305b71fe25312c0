"""Several models on one stream: batch table, streaming equal to batch, one feature pass, the CLI, bad input."""

import numpy as np
import pandas as pd
import pytest
from classify_fixtures import truth_model, with_gap
from typer.testing import CliRunner

from spotfree.classify.batch import classify_recording
from spotfree.classify.multi import MultiModelStream, classify_models, model_names
from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io.csvlog import write_csv
from spotfree.sim.scenarios import simulate_scenario
from spotfree.votes.options import Votes, model_penalties, voted_labels, voted_models, votes_per_model


def voted(models, ride, **options):
    """The label table of ``models`` on ``ride`` after the votes of ``options`` given for all of them."""
    return voted_models(models, ride, votes_per_model(models, **options))


@pytest.fixture(scope="module")
def models():
    """Truth-named braking, lateral and road dictionaries (mechanics only; not trained models)."""
    lateral = simulate_scenario("lateral", repeats=1, seed=3)
    road = simulate_scenario("road", repeats=1, seed=3)
    braking = simulate_scenario("sudden-braking", repeats=1, seed=3)
    return {
        "braking": truth_model(braking),
        "lateral": truth_model(lateral, channels=("yaw_rate", "roll_rate"), window=30),
        "road": truth_model(road, channels=("vib_y", "vib_z"), window=12, step=2),
    }


@pytest.fixture(scope="module")
def ride():
    """Two lateral rides of other riders, the first 600 samples of each, with a gap in the first."""
    rec = simulate_scenario("lateral", repeats=2, seed=11)
    keep = np.concatenate([np.flatnonzero(rec.experiment == k)[:600] for k in (1, 2)])
    return with_gap(rec.take(keep), 300, 310)


def test_batch_table_has_one_column_per_model_equal_to_each_model_alone(models, ride):
    table = classify_models(models, ride)
    assert list(table.columns) == ["experiment", "time", "braking", "lateral", "road"]
    for name, model in models.items():
        np.testing.assert_array_equal(table[name].to_numpy(), classify_recording(model, ride).label)
    # each model keeps its own window: the first label of a segment comes window - 1 samples in
    for name, model in models.items():
        assert np.flatnonzero(table[name].to_numpy() != "")[0] == model.window - 1
    assert set(table["lateral"]) - {""} <= {"straight", "gentle-turn", "sharp-turn", "slalom"}


def test_stream_labels_equal_batch_causal_labels(models, ride):
    table = classify_models(models, ride)
    stream = MultiModelStream(models)
    assert stream.names == ("braking", "lateral", "road")
    acc, gyr, speed = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.channels["speed"]
    got = [stream.update(a, w, t, s) for a, w, t, s in zip(acc, gyr, ride.time, speed)]
    for k, name in enumerate(stream.names):
        streamed = np.array(["" if labels[k] is None else labels[k] for labels in got])
        np.testing.assert_array_equal(streamed, table[name].to_numpy())


def test_stream_labels_equal_batch_for_summary_models_of_different_windows(models, ride):
    """Summary models run in the compiled step too; their windows of different lengths share the ring. (Their
    dictionaries are drawn from the rides themselves: a window far from every column leaves kernel CRC_RLS's residuals
    tied at 1, which the batch and the single-window arithmetic may break differently.)"""
    rides = simulate_scenario("lateral", repeats=2, seed=11)
    mixed = {"braking": models["braking"],
             "lateral": truth_model(rides, channels=("yaw_rate",), window=30, representation="summary"),
             "road": truth_model(rides, channels=("rough_y", "rough_z"), window=10, representation="summary")}
    table = classify_models(mixed, ride)
    stream = MultiModelStream(mixed)
    assert stream._ring.models_["compiled"].all() and list(stream._ring.models_["summary"]) == [False, True, True]
    acc, gyr, speed = ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.channels["speed"]
    got = [stream.update(a, w, t, s) for a, w, t, s in zip(acc, gyr, ride.time, speed)]
    for k, name in enumerate(stream.names):
        streamed = np.array(["" if labels[k] is None else labels[k] for labels in got])
        np.testing.assert_array_equal(streamed, table[name].to_numpy())
        assert len(set(streamed) - {""}) > 1  # the labels move: equality is not trivial


def test_models_that_cannot_share_one_feature_pass_are_refused(models):
    other = dict(models, road=models["road"].__class__(**{**vars(models["road"]), "rate": 50.0}))
    with pytest.raises(InputError, match="cannot share one feature pass"):
        MultiModelStream(other)
    with pytest.raises(InputError, match="no model given"):
        classify_models({}, None)
    with pytest.raises(InputError, match="share the name braking"):
        model_names(["a/braking.npz", "b/braking.npz"])


@pytest.mark.parametrize("change, said", [
    ({"rate": 50.0}, "road is of 20 Hz, other of 50 Hz; train them at one rate"),
    ({"features": "body"}, "road is of ride features, other of body features; classify the log with each model in "
                           "its own call, or train both with the same --features"),
    ({"orientation": "paper"}, "road is of --orientation default, other of --orientation paper; train them with the "
                               "same --orientation"),
])
def test_models_that_cannot_share_a_feature_pass_are_refused_naming_what_differs(models, change, said):
    pair = {"road": models["road"], "other": models["road"].__class__(**{**vars(models["road"]), **change})}
    with pytest.raises(InputError) as refused:
        MultiModelStream(pair)
    assert str(refused.value) == f"models road and other cannot share one feature pass: {said}"


def test_cli_classify_with_several_models_writes_a_column_per_model_and_keeps_the_single_contract(
        models, ride, tmp_path):
    for name, model in models.items():
        model.save(tmp_path / f"{name}.npz")
    write_csv(ride, tmp_path / "ride.csv")
    runner = CliRunner()
    paths = [str(tmp_path / f"{name}.npz") for name in models]
    result = runner.invoke(app, ["classify", *paths, str(tmp_path / "ride.csv"), "-o", str(tmp_path / "out.csv")])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(tmp_path / "out.csv", keep_default_na=False)
    assert list(table.columns) == ["experiment", "time", "braking", "lateral", "road"]
    expected = classify_models(models, ride)
    for name in models:
        np.testing.assert_array_equal(table[name].astype(str).to_numpy(), expected[name].to_numpy())
    single = runner.invoke(app, ["classify", paths[1], str(tmp_path / "ride.csv"), "-o", str(tmp_path / "one.csv")])
    assert single.exit_code == 0, single.output
    assert list(pd.read_csv(tmp_path / "one.csv").columns) == ["experiment", "time", "label"]
    twice = runner.invoke(app, ["classify", paths[0], paths[0], str(tmp_path / "ride.csv"), "-o",
                                str(tmp_path / "x.csv")])
    assert twice.exit_code == 2 and "share the name braking" in twice.output


def test_the_segment_and_event_votes_run_per_model_with_only_the_classes_each_has(models, ride):
    table = voted(models, ride, segments=4.0, keep=("kerb",), events=("straight", "smooth"))
    for name, model in models.items():
        own = lambda names: tuple(c for c in names if c in model.classes)  # noqa: E731
        alone = voted_labels(model, ride, Votes(4.0, own(("kerb",)), own(("straight", "smooth"))))
        np.testing.assert_array_equal(table[name].to_numpy(), alone.label)
    plain, events = classify_models(models, ride, centred=True), voted(models, ride, events=("straight",))
    assert not np.array_equal(events["lateral"], plain["lateral"])
    np.testing.assert_array_equal(events[["braking", "road"]], plain[["braking", "road"]])
    for option in ("keep", "events"):
        with pytest.raises(InputError, match=f"--{option} slalm: not a class of any model"):
            voted(models, ride, segments=4.0, **{option: ("slalm",)})


def test_event_edges_run_on_the_model_with_the_channel_and_are_refused_elsewhere(models, ride):
    edged = voted(models, ride, segments=4.0, events=("straight",), edges={"yaw_rate": 0.09})
    events = voted(models, ride, segments=4.0, events=("straight",))
    alone = voted_labels(models["lateral"], ride, Votes(4.0, (), ("straight",), {"yaw_rate": 0.09}))
    np.testing.assert_array_equal(edged["lateral"].to_numpy(), alone.label)
    assert not np.array_equal(edged["lateral"], events["lateral"])
    np.testing.assert_array_equal(edged[["braking", "road"]], events[["braking", "road"]])
    with pytest.raises(InputError, match="--edges yaw: not a channel of any model"):
        voted(models, ride, events=("straight",), edges={"yaw": 0.09})
    with pytest.raises(InputError, match="--edges vib_z: model road runs no event vote"):
        voted(models, ride, events=("straight",), edges={"vib_z": 0.5})


def test_penalties_are_given_for_every_model_or_per_model_name():
    names = ["braking", "lateral", "road"]
    assert model_penalties(["4", "road=8"], names) == {"braking": 4.0, "lateral": 4.0, "road": 8.0}
    assert model_penalties(["lateral=4"], names) == {"braking": 0.0, "lateral": 4.0, "road": 0.0}
    assert model_penalties([], names) == dict.fromkeys(names, 0.0)
    with pytest.raises(InputError, match="--segments latral=4: no model is named latral"):
        model_penalties(["latral=4"], names)
    with pytest.raises(InputError, match="--segments road=high: give a penalty"):
        model_penalties(["road=high"], names)


def test_cli_segments_per_model_vote_each_model_at_its_own_penalty(models, ride, tmp_path):
    for name, model in models.items():
        model.save(tmp_path / f"{name}.npz")
    write_csv(ride, tmp_path / "ride.csv")
    paths = [str(tmp_path / f"{name}.npz") for name in models]
    run = lambda out, *extra: CliRunner().invoke(  # noqa: E731
        app, ["classify", *paths, str(tmp_path / "ride.csv"), "-o", str(tmp_path / out), *extra])
    result = run("votes.csv", "--segments", "lateral=4", "--segments", "road=8", "--keep", "kerb")
    assert result.exit_code == 0, result.output
    assert "segment vote at penalty lateral 4, road 8, kerb kept" in result.output
    table = pd.read_csv(tmp_path / "votes.csv", keep_default_na=False)
    expected = voted(models, ride, segments={"lateral": 4.0, "road": 8.0}, keep=("kerb",))
    for name in models:
        np.testing.assert_array_equal(table[name].astype(str).to_numpy(), expected[name].to_numpy())
    np.testing.assert_array_equal(expected["braking"], classify_models(models, ride, centred=True)["braking"])
    assert not np.array_equal(expected["road"], voted(models, ride, segments=4.0, keep=("kerb",))["road"])
    bad = run("bad.csv", "--segments", "latral=4")
    assert bad.exit_code == 2 and "no model is named latral" in bad.output
    assert not (tmp_path / "bad.csv").exists()
