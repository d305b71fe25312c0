"""`spotfree classify MODEL.npz IN -o OUT.csv`: a trained model file on simulated logs, gaps stated, bad input."""

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.io import read_recording
from spotfree.io.csvlog import write_csv
from spotfree.pipeline import feature_recording
from spotfree.sim.scenarios import simulate_scenario
from spotfree.presets import preset_learner

runner = CliRunner()


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A model trained (no labels read) on the first 40 s of two simulated rides, and a two-ride log."""
    root = tmp_path_factory.mktemp("classify")
    recordings, sets = [], []
    for scenario, seed, classes in (("normal-braking", 0, ["cruising", "normal-braking"]),
                                    ("sudden-braking", 1, ["cruising", "normal-braking", "sudden-braking"])):
        write_csv(simulate_scenario(scenario, repeats=1, seed=seed).take(slice(0, 800)), root / f"{scenario}.csv")
        recordings.append(feature_recording(str(root / f"{scenario}.csv")))
        sets.append(classes)
    preset_learner("braking", seed=0).fit(recordings, sets).model_.save(root / "model.npz")
    result = runner.invoke(app, ["simulate", "sudden-braking", "-o", str(root / "ride.csv"), "--repeats", "2",
                                 "--seed", "7"])
    assert result.exit_code == 0, result.output
    return root


def invoke(*argv):
    return runner.invoke(app, [str(a) for a in argv], catch_exceptions=False)


def test_every_sample_gets_a_label_after_the_first_window_of_each_ride(folder):
    result = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "labels.csv")
    assert result.exit_code == 0, result.output
    assert "windows: causal" in result.output and "ending at it" in result.output
    ride = pd.read_csv(folder / "ride.csv")
    labels = pd.read_csv(folder / "labels.csv", keep_default_na=False)
    assert list(labels.columns) == ["experiment", "time", "label"]
    np.testing.assert_array_equal(labels["experiment"], ride["experiment"])
    np.testing.assert_allclose(labels["time"], ride["time"])
    for _, part in labels.groupby("experiment"):
        assert (part["label"].iloc[:19] == "").all() and (part["label"].iloc[19:] != "").all()
    assert set(labels["label"]) - {""} <= {"cruising", "normal-braking", "sudden-braking"}
    assert labels["label"].nunique() >= 3


def test_the_default_method_is_the_library_default_and_is_said(folder):
    from spotfree.classify import DEFAULT_METHOD

    result = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "default.csv")
    assert result.exit_code == 0, result.output
    assert f"by {DEFAULT_METHOD}" in result.output
    explicit = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "named.csv",
                      "--method", DEFAULT_METHOD)
    assert explicit.exit_code == 0, explicit.output
    assert (folder / "default.csv").read_text() == (folder / "named.csv").read_text()


def test_centred_windows_and_smoothing_are_said_and_used(folder):
    assert invoke("classify", folder / "model.npz", f"{folder / 'ride.csv'}@2", "-o", folder / "causal2.csv").exit_code == 0
    result = invoke("classify", folder / "model.npz", f"{folder / 'ride.csv'}@2", "-o", folder / "centred.csv",
                    "--centred", "--smooth", "5")
    assert result.exit_code == 0, result.output
    assert "windows: centred" in result.output and "offset 10 samples" in result.output
    assert "majority vote over 5 samples" in result.output
    labels = pd.read_csv(folder / "centred.csv", keep_default_na=False)
    assert list(labels.columns) == ["experiment", "time", "label"] and set(labels["experiment"]) == {2}
    assert (labels["label"].iloc[:9] == "").all() and (labels["label"].iloc[-10:] == "").all()
    causal = pd.read_csv(folder / "causal2.csv", keep_default_na=False)
    assert (causal["label"].iloc[:19] == "").all() and (causal["label"].iloc[-10:] != "").all()


def test_centred_labels_are_voted_over_each_model_s_smoothing_span_by_default(folder, tmp_path):
    from spotfree.model import DictionaryModel

    model = DictionaryModel.load(folder / "model.npz")
    assert model.parameters["smoothing"] == 0.5  # 0.5 s at 20 Hz: 11 samples
    result = invoke("classify", folder / "model.npz", f"{folder / 'ride.csv'}@2", "-o", tmp_path / "one.csv",
                    "--centred", "--json")
    assert result.exit_code == 0, result.output
    assert '"smoothing": 11' in result.output
    model.parameters["smoothing"] = 0.1  # a model decoded with a shorter switching cost: 3 samples
    model.save(tmp_path / "short.npz")
    result = invoke("classify", folder / "model.npz", tmp_path / "short.npz", f"{folder / 'ride.csv'}@2", "-o",
                    tmp_path / "two.csv", "--centred")
    assert result.exit_code == 0, result.output
    assert "majority vote over model 11, short 3 samples" in result.output
    two = pd.read_csv(tmp_path / "two.csv", keep_default_na=False)
    one = pd.read_csv(tmp_path / "one.csv", keep_default_na=False)
    assert (two["model"] == one["label"]).all() and (two["short"] != two["model"]).any()
    live = invoke("classify", folder / "model.npz", f"{folder / 'ride.csv'}@2", "-o", tmp_path / "live.csv")
    assert "majority vote" not in live.output


def test_labels_stop_at_a_gap_and_resume_after_it_and_say_so(folder):
    ride = pd.read_csv(folder / "ride.csv", keep_default_na=False)
    one = ride[ride["experiment"] == 1].drop(columns="experiment")
    holed = one[(one["time"] < 20.0) | (one["time"] >= 23.0)]
    holed.to_csv(folder / "holed.csv", index=False)
    result = invoke("classify", folder / "model.npz", folder / "holed.csv", "-o", folder / "holed_labels.csv")
    assert result.exit_code == 0, result.output
    assert "experiment 1: labels stop after 19.95 s and resume at 23.95 s" in result.output
    assert "no label across it" in result.output
    labels = pd.read_csv(folder / "holed_labels.csv", keep_default_na=False)
    assert list(labels.columns) == ["time", "label"]
    inside = (labels["time"] >= 20.0) & (labels["time"] < 23.95)
    assert (labels.loc[inside, "label"] == "").all() and (labels.loc[~inside, "label"].iloc[19:] != "").all()


def test_the_segment_vote_is_said_and_keeps_the_labelled_samples_of_the_centred_windows_it_implies(folder):
    assert invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "plain.csv",
                  "--centred").exit_code == 0
    result = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "voted.csv",
                    "--segments", "4", "--keep", "sudden-braking")
    assert result.exit_code == 0, result.output
    assert "segment vote at penalty 4, sudden-braking kept" in result.output
    assert "centred on it" in " ".join(result.output.split())
    events = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "events.csv",
                    "--events", "cruising")
    assert events.exit_code == 0 and "; event vote outside cruising" in events.output, events.output
    edges = invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", folder / "edges.csv",
                   "--events", "cruising", "--edges", "pitch_rate=0.05")
    assert edges.exit_code == 0, edges.output
    said = " ".join(edges.output.split())
    assert "event vote outside cruising and event edges at pitch_rate 0.05 off its background median" in said
    voted = pd.read_csv(folder / "voted.csv", keep_default_na=False)
    plain = pd.read_csv(folder / "plain.csv", keep_default_na=False)
    np.testing.assert_array_equal(voted["label"] == "", plain["label"] == "")
    flips = lambda lab: int((lab.to_numpy()[1:] != lab.to_numpy()[:-1]).sum())  # noqa: E731
    assert flips(voted["label"]) < flips(plain["label"])


def test_a_log_at_another_rate_is_read_onto_the_models_grid(folder):
    source = folder / "fast.csv"
    assert invoke("simulate", "cruising", "-o", source, "--repeats", "1", "--rate", "50").exit_code == 0
    result = invoke("classify", folder / "model.npz", source, "-o", folder / "fast_labels.csv")
    assert result.exit_code == 0, result.output
    assert "sampled at 50 Hz; resampled onto the 20 Hz grid" in result.output
    labels = pd.read_csv(folder / "fast_labels.csv", keep_default_na=False)
    simulated = pd.read_csv(source)
    assert abs(len(labels) / 20.0 - len(simulated) / 50.0) <= 0.1


@pytest.mark.parametrize("case", ["model", "method", "smooth", "segments", "keep", "events", "edges",
                                  "edge-level", "edges-alone"])
def test_bad_input_is_one_line_and_exit_2_and_writes_nothing(folder, case):
    source, model, extra = folder / "ride.csv", folder / "model.npz", []
    if case == "model":
        model = folder / "missing.npz"
    elif case == "method":
        extra = ["--method", "lasso"]
    elif case == "smooth":
        extra = ["--smooth", "-3"]
    elif case == "segments":
        extra = ["--segments", "-1"]
    elif case == "keep":
        extra = ["--segments", "4", "--keep", "kerb"]
    elif case == "events":
        extra = ["--events", "straight"]
    elif case == "edges":
        extra = ["--events", "cruising", "--edges", "yaw_rate=0.09"]
    elif case == "edge-level":
        extra = ["--events", "cruising", "--edges", "pitch_rate=steep"]
    else:
        extra = ["--edges", "pitch_rate=0.05"]
    result = invoke("classify", model, source, "-o", folder / f"bad_{case}.csv", *extra)
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1, result.output
    expected = {"model": "missing.npz: no such model file", "method": "'lasso' is unknown",
                "smooth": r"\(--smooth\).* got -3", "segments": r"\(--segments\).* got -1",
                "keep": "--keep kerb: not a class of the model",
                "events": "--events straight: not a class of the model",
                "edges": r"--edges yaw_rate: not a channel of the model \(acc_long, pitch_rate\)",
                "edge-level": "--edges pitch_rate=steep: give CHANNEL=LEVEL",
                "edges-alone": "--edges pitch_rate: the model runs no event vote"}[case]
    assert pd.Series(lines).str.contains(expected).any(), result.output
    assert not (folder / f"bad_{case}.csv").exists()


def test_a_phone_upright_in_a_holder_gets_the_flat_phones_labels_and_the_mount_is_said(folder, tmp_path):
    ride = read_recording(folder / "ride.csv")
    q = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])  # flat -> upright, screen to the rider
    channels = dict(ride.channels)
    for names in (["ax", "ay", "az"], ["gx", "gy", "gz"]):
        channels.update(zip(names, (ride.array(names) @ q.T).T))
    write_csv(ride.with_channels(channels), tmp_path / "upright.csv")
    result = runner.invoke(app, ["classify", str(folder / "model.npz"), str(tmp_path / "upright.csv"), "-o",
                                 str(tmp_path / "upright_labels.csv")])
    assert result.exit_code == 0, result.output
    assert "mount: up is" in result.stderr and "using the estimate" in result.stderr
    invoke("classify", folder / "model.npz", folder / "ride.csv", "-o", tmp_path / "flat_labels.csv")
    upright = pd.read_csv(tmp_path / "upright_labels.csv", keep_default_na=False)["label"]
    flat = pd.read_csv(tmp_path / "flat_labels.csv", keep_default_na=False)["label"]
    assert (upright == flat).mean() > 0.95
    forced = runner.invoke(app, ["classify", str(folder / "model.npz"), str(tmp_path / "upright.csv"), "-o",
                                 str(tmp_path / "forced.csv"), "--mount", "flat"])
    assert forced.exit_code == 0 and "using the --mount flat choice" in forced.stderr


def test_a_sensor_logger_export_without_gyroscope_is_refused_in_the_apps_terms(folder, tmp_path):
    ride = read_recording(folder / "ride.csv").select_experiment(1)
    export = tmp_path / "export"
    export.mkdir()
    t = ride.time - ride.time[0]
    acc = ride.array(["ax", "ay", "az"])
    pd.DataFrame({"time": 1_700_000_000_000_000_000 + np.round(t * 1e9).astype(np.int64), "seconds_elapsed": t,
                  "z": acc[:, 2], "y": acc[:, 1], "x": acc[:, 0]}).to_csv(export / "TotalAcceleration.csv", index=False)
    pd.DataFrame([{"platform": "android", "appVersion": "1.40"}]).to_csv(export / "Metadata.csv", index=False)
    result = runner.invoke(app, ["classify", str(folder / "model.npz"), str(export), "-o", str(tmp_path / "l.csv")])
    assert result.exit_code == 2
    errors = [line for line in result.output.splitlines() if line.strip()]
    assert len(errors) == 1 and "no Gyroscope.csv: enable Gyroscope in Sensor Logger" in errors[0]
    assert "give the raw IMU log" not in result.output


def test_several_logs_in_one_call_write_what_one_call_each_writes(folder, tmp_path):
    """`classify MODEL IN1 IN2 -o FOLDER`: one CSV per log, named by the log (NAME@K for PATH@K), equal to the file
    a call per log writes; the JSON document holds one document per log."""
    import json

    out = tmp_path / "new" / "labels"  # a new folder is made
    logs = [folder / "ride.csv", f"{folder / 'ride.csv'}@2", folder / "normal-braking.csv"]
    result = runner.invoke(app, ["classify", str(folder / "model.npz"), *map(str, logs), "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    assert sorted(p.name for p in out.iterdir()) == ["normal-braking.csv", "ride.csv", "ride@2.csv"]
    document = json.loads(result.stdout)
    assert [d["output"] for d in document["logs"]] == [str(out / n) for n in ("ride.csv", "ride@2.csv",
                                                                             "normal-braking.csv")]
    for log, name in zip(logs, ("ride.csv", "ride@2.csv", "normal-braking.csv")):
        alone = invoke("classify", folder / "model.npz", log, "-o", tmp_path / "alone.csv")
        assert alone.exit_code == 0
        assert (tmp_path / "alone.csv").read_text() == (out / name).read_text()


@pytest.mark.parametrize("argv, message", [
    (["ride.csv", "normal-braking.csv", "-o", "several.csv"], "with 2 logs give a folder, existing or a new name"),
    (["ride.csv", "normal-braking.csv", "-o", "model.npz"], "with 2 logs give a folder, existing or a new name"),
    (["ride.csv", "ride.csv", "-o", "."], "ride.csv is given twice"),
    (["ride.csv", "model.npz", "-o", "."], "model.npz is a model file among the logs; give the model files first"),
    (["-o", "x.csv"], "at least one model file and the log"),
])
def test_several_logs_misgiven_exit_2_with_one_line(folder, argv, message, monkeypatch):
    monkeypatch.chdir(folder)
    before = sorted(folder.iterdir())
    result = invoke("classify", "model.npz", *argv)
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())
    assert sorted(folder.iterdir()) == before


def test_several_models_on_several_logs_write_what_one_call_each_writes(folder, tmp_path):
    import shutil

    shutil.copy(folder / "model.npz", tmp_path / "other.npz")
    out = tmp_path / "labels"
    out.mkdir()
    models = [folder / "model.npz", tmp_path / "other.npz"]
    logs = [folder / "ride.csv", folder / "normal-braking.csv"]
    result = invoke("classify", *models, *logs, "-o", out, "--segments", "4")
    assert result.exit_code == 0, result.output
    for log in logs:
        alone = invoke("classify", *models, log, "-o", tmp_path / "alone.csv", "--segments", "4")
        assert alone.exit_code == 0
        table = pd.read_csv(out / f"{log.stem}.csv", keep_default_na=False)
        assert list(table.columns)[-2:] == ["model", "other"] and (table["model"] == table["other"]).all()
        assert (tmp_path / "alone.csv").read_text() == (out / f"{log.stem}.csv").read_text()
