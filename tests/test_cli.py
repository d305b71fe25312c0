"""The command-line contract of DESIGN.md: commands listed, each answers --help, bad input exits 2."""

import os
import stat
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.io import read_recording

runner = CliRunner()

CONTRACT = ["simulate", "features", "train", "classify", "evaluate", "serve", "hand", "fleet"]
SUBCOMMANDS = [["hand", "simulate"], ["hand", "train"], ["hand", "run"],
               ["fleet", "generate"], ["fleet", "ingest"], ["fleet", "process"], ["fleet", "stats"]]


def test_help_lists_every_command_of_the_contract():
    result = runner.invoke(app, ["--help"])
    assert result.exit_code == 0
    for command in CONTRACT:
        assert command in result.output


@pytest.mark.parametrize("argv", [[c] for c in CONTRACT] + SUBCOMMANDS, ids=" ".join)
def test_every_contract_command_answers_help(argv):
    result = runner.invoke(app, [*argv, "--help"], catch_exceptions=False)
    assert result.exit_code == 0
    assert "Usage" in result.output and "not built yet" not in result.output


def test_console_script_exits_2_with_one_line_on_missing_file(tmp_path):
    missing = tmp_path / "nope.csv"
    proc = subprocess.run(
        [sys.executable, "-m", "spotfree.cli", "features", str(missing), "-o", str(tmp_path / "f.csv")],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "nope.csv" in lines[0]


def test_simulate_then_features_end_to_end(tmp_path):
    ride = tmp_path / "ride.csv"
    feats = tmp_path / "features.csv"
    result = runner.invoke(app, ["simulate", "sudden-braking", "-o", str(ride), "--repeats", "2", "--seed", "3"])
    assert result.exit_code == 0, result.output
    table = pd.read_csv(ride)
    assert list(table.columns) == [
        "experiment", "time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed", "label", "event",
    ]
    assert sorted(table["experiment"].unique()) == [1, 2]

    result = runner.invoke(app, ["features", f"{ride}@2", "-o", str(feats)])
    assert result.exit_code == 0, result.output
    out = pd.read_csv(feats)
    assert list(out.columns)[-7:] == ["roll", "pitch", "pitch_rate", "acc_x", "acc_y", "acc_z", "speed"]
    assert len(out) == int((table["experiment"] == 2).sum())
    np.testing.assert_allclose(out["speed"], table.loc[table["experiment"] == 2, "speed"], atol=1e-6)
    assert np.isfinite(out[["roll", "pitch", "acc_x"]].to_numpy()).all()


def test_features_rejects_unknown_orientation(tmp_path):
    ride = tmp_path / "ride.csv"
    assert runner.invoke(app, ["simulate", "cruising", "-o", str(ride), "--repeats", "1"]).exit_code == 0
    result = runner.invoke(app, ["features", str(ride), "-o", str(tmp_path / "f.csv"), "--orientation", "kalman"])
    assert result.exit_code == 2
    assert "kalman" in result.output
    assert not (tmp_path / "f.csv").exists()


def test_simulate_unknown_scenario_exits_2(tmp_path):
    result = runner.invoke(app, ["simulate", "wheelie", "-o", str(tmp_path / "x.csv")])
    assert result.exit_code == 2
    assert "wheelie" in result.output and "sudden-braking" in result.output
    assert not (tmp_path / "x.csv").exists()


def test_simulate_lateral_rides_of_chosen_manoeuvres_and_refuses_unknown_ones(tmp_path):
    path = tmp_path / "straight.csv"
    assert runner.invoke(app, ["simulate", "lateral", "-o", str(path), "--repeats", "1", "--manoeuvres",
                               "none"]).exit_code == 0
    assert set(read_recording(str(path)).truth["label"]) == {"straight"}
    result = runner.invoke(app, ["simulate", "lateral", "-o", str(tmp_path / "z.csv"), "--manoeuvres", "zigzag"])
    assert result.exit_code == 2 and "zigzag" in result.output and not (tmp_path / "z.csv").exists()


def test_simulate_is_deterministic_under_the_seed(tmp_path):
    a, b = tmp_path / "a.csv", tmp_path / "b.csv"
    for path in (a, b):
        assert runner.invoke(app, ["simulate", "normal-braking", "-o", str(path), "--repeats", "2", "--seed", "9"]).exit_code == 0
    assert a.read_bytes() == b.read_bytes()


BAD_LOGS = {
    "empty.csv": ("", "empty"),
    "in_g.csv": ("time,ax,ay,az,gx,gy,gz\n" + "".join(f"{k * 0.05},0,0,1,0,0,0\n" for k in range(40)), "9.80665"),
    "misspelt.csv": ("tme,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n", "'tme' should be 'time'"),
    "text_cell.csv": ("time,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.05,0,abc,9.8,0,0,0\n", "'ay'"),
    "backwards.csv": ("time,ax,ay,az,gx,gy,gz\n0,0,0,9.8,0,0,0\n0.1,0,0,9.8,0,0,0\n0.05,0,0,9.8,0,0,0\n"
                      "0.05,0,0,9.8,0,0,0\n0.15,0,0,9.8,0,0,0\n", "'time'"),
}


@pytest.mark.parametrize("name", sorted(BAD_LOGS))
def test_features_on_bad_logs_exits_2_with_one_line_naming_file_and_column(name, tmp_path):
    text, expected = BAD_LOGS[name]
    (tmp_path / name).write_text(text)
    existing = tmp_path / "features.csv"
    existing.write_text("kept\n")
    result = runner.invoke(app, ["features", str(tmp_path / name), "-o", str(existing)])
    assert result.exit_code == 2
    lines = [line for line in result.output.splitlines() if line.strip()]
    assert len(lines) == 1 and name in lines[0] and expected in lines[0], result.output
    assert existing.read_text() == "kept\n"


def test_serve_refuses_an_unknown_sync_mode_before_starting(tmp_path):
    result = runner.invoke(app, ["serve", "--sync", "off", "--database", str(tmp_path / "r.db")])
    assert result.exit_code == 2
    assert "--sync off: use full or normal" in result.output
    assert list(tmp_path.iterdir()) == []


def test_train_writes_a_model_its_summary_and_its_figure(tmp_path):
    from spotfree.model import DictionaryModel

    normal, sudden = tmp_path / "normal.csv", tmp_path / "sudden.csv"
    for scenario, path in (("normal-braking", normal), ("sudden-braking", sudden)):
        assert runner.invoke(app, ["simulate", scenario, "-o", str(path), "--repeats", "1"]).exit_code == 0
    declared = ["--experiment", f"{normal}@1=cruising,normal-braking",
                "--experiment", f"{sudden}@1=cruising,normal-braking,sudden-braking", "--preset", "braking"]
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"), *declared, "--figure",
                                 str(tmp_path / "m.png")])
    assert result.exit_code == 0, result.output
    assert "sets (hankel of ride channels acc_long,pitch_rate; prior: ride; column share 0.75)" in result.output
    assert "columns per class: cruising" in result.output
    assert (tmp_path / "m.png").stat().st_size > 0
    model = DictionaryModel.load(tmp_path / "m.npz")
    assert model.parameters["max_columns"] == 300 and model.parameters["prior"] == "RidePrior"
    assert set(model.classes) == {"cruising", "normal-braking", "sudden-braking"}

    result = runner.invoke(app, ["train", "-o", str(tmp_path / "few.npz"), *declared, "--max-columns", "20"])
    assert result.exit_code == 0, result.output
    few = DictionaryModel.load(tmp_path / "few.npz")
    assert np.bincount(few.column_class).max() <= 20 < np.bincount(model.column_class).max()
    assert not (tmp_path / "few.png").exists()  # a figure only when asked for
    # an option given beside the preset overrides it
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "summary.npz"), *declared, "--representation",
                                 "summary", "--window", "10"])
    said = "learner: sets (summary of ride channels acc_long,pitch_rate; prior: ride; column share 0.75)"
    assert said in result.output
    assert DictionaryModel.load(tmp_path / "summary.npz").window == 10
    assert model.parameters["share_power"] == 0.5
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "rare.npz"), *declared, "--share-power", "1"])
    assert result.exit_code == 0, result.output
    assert DictionaryModel.load(tmp_path / "rare.npz").parameters["share_power"] == 1.0
    for bad in ("-1", "nan"):
        refused = runner.invoke(app, ["train", "-o", str(tmp_path / "bad.npz"), *declared, "--share-power", bad])
        assert refused.exit_code == 2 and "share_power=" in refused.output and "give a number >= 0" in refused.output
        assert not (tmp_path / "bad.npz").exists()
    assert model.parameters["column_share"] == 0.75  # the braking preset's
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "all.npz"), *declared, "--column-share", "1"])
    assert result.exit_code == 0, result.output
    assert DictionaryModel.load(tmp_path / "all.npz").parameters["column_share"] == 1.0
    assert "prior: ride; column share 1)" in result.output
    refused = runner.invoke(app, ["train", "-o", str(tmp_path / "bad.npz"), *declared, "--column-share", "0"])
    assert refused.exit_code == 2 and "column_share=0.0: give a share > 0 and <= 1" in refused.output
    assert not (tmp_path / "bad.npz").exists()


def test_train_paper_recipe_is_the_baseline_and_takes_no_learner_option(tmp_path):
    from spotfree.model import DictionaryModel

    ride = tmp_path / "sb.csv"
    assert runner.invoke(app, ["simulate", "sudden-braking", "-o", str(ride), "--repeats", "1"]).exit_code == 0
    declared = ["--experiment", f"{ride}=cruising,normal-braking,sudden-braking", "--recipe", "paper"]
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "p.npz"), *declared])
    assert result.exit_code == 0, result.output
    assert "learner: the paper's recipe" in result.output
    assert DictionaryModel.load(tmp_path / "p.npz").parameters["learner"] == "paper recipe"
    for option, value in (("--prior", "ride"), ("--share-power", "1"), ("--column-share", "1")):
        refused = runner.invoke(app, ["train", "-o", str(tmp_path / "q.npz"), *declared, option, value])
        assert refused.exit_code == 2 and f"{option} is an option of --recipe sets" in refused.output
        assert not (tmp_path / "q.npz").exists()


@pytest.mark.parametrize("option, value", [("--window", "0"), ("--step", "0"), ("--max-columns", "0"),
                                           ("--recipe", "evidence"), ("--representation", "raw"),
                                           ("--prior", "speed"), ("--features", "vehicle"), ("--preset", "turns")])
def test_train_refuses_an_option_out_of_range_and_keeps_the_model_there(tmp_path, option, value):
    ride = tmp_path / "sb.csv"
    assert runner.invoke(app, ["simulate", "sudden-braking", "-o", str(ride), "--repeats", "1"]).exit_code == 0
    model = tmp_path / "m.npz"
    model.write_bytes(b"an older model")
    result = runner.invoke(app, ["train", "-o", str(model), "--experiment",
                                 f"{ride}=cruising,normal-braking,sudden-braking", option, value])
    assert result.exit_code == 2
    assert option in result.output, result.output
    assert model.read_bytes() == b"an older model"


def test_output_piped_to_a_file_is_not_wrapped(tmp_path):
    deep = tmp_path / ("a-folder-with-a-long-name-" * 3)
    deep.mkdir()
    proc = subprocess.run([sys.executable, "-m", "spotfree.cli", "simulate", "cruising", "-o", str(deep / "ride.csv"),
                           "--repeats", "1"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert len(lines) == 1 and len(lines[0]) > 120 and lines[0].endswith(" s")


def test_files_are_written_with_the_users_umask_and_replace_the_old_one_whole(tmp_path):
    from classify_fixtures import truth_model

    ride, model_path = tmp_path / "ride.csv", tmp_path / "m.npz"
    previous = os.umask(0o027)
    try:
        assert runner.invoke(app, ["simulate", "cruising", "-o", str(ride), "--repeats", "1"]).exit_code == 0
        truth_model(read_recording(str(ride))).save(model_path)
        model_path.chmod(0o600)  # replaced by a new file, which takes the umask's mode
        truth_model(read_recording(str(ride))).save(model_path)
    finally:
        os.umask(previous)
    assert stat.S_IMODE(ride.stat().st_mode) == 0o640 and stat.S_IMODE(model_path.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.npz", "ride.csv"]  # no temporary file left
