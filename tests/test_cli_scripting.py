"""The CLI for scripts: ``--json`` prints one JSON document on standard output and nothing else there; ``--quiet``
prints nothing but errors."""

import json
import shutil

import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.model import DictionaryModel

runner = CliRunner()
DECLARED = {"nb.csv@1": ["cruising", "normal-braking"], "sb.csv@1": ["cruising", "normal-braking", "sudden-braking"]}


def _run(*argv: str):
    result = runner.invoke(app, list(argv), catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return result


@pytest.fixture(scope="module")
def rides(tmp_path_factory):
    """Two simulated files, a braking model trained on their first rides and the train command's JSON."""
    folder = tmp_path_factory.mktemp("rides")
    _run("simulate", "normal-braking", "-o", str(folder / "nb.csv"), "--repeats", "2")
    _run("simulate", "sudden-braking", "-o", str(folder / "sb.csv"), "--repeats", "2", "--seed", "1")
    result = _run("train", "-o", str(folder / "m.npz"), "--preset", "braking", "--json",
                  *[a for path, classes in DECLARED.items()
                    for a in ("--experiment", f"{folder / path}={','.join(classes)}")])
    return folder, result


def test_train_json_is_the_whole_stdout_and_describes_the_model_written(rides):
    folder, result = rides
    summary = json.loads(result.stdout)
    model = DictionaryModel.load(folder / "m.npz")
    assert summary["output"] == str(folder / "m.npz") and summary["learner"] == "sets"
    assert summary["channels"] == ["acc_long", "pitch_rate"] and summary["representation"] == "hankel"
    assert summary["prior"] == "ride" and summary["window"] == 20 and summary["column_share"] == 0.75
    assert summary["classes"] == model.classes == ["cruising", "normal-braking", "sudden-braking"]
    assert summary["columns"] == model.dictionary.shape[1] == sum(summary["columns_per_class"].values())
    assert summary["columns_per_class"] == model.summary["columns_per_class"]
    assert [r["declared"] for r in summary["recordings"]] == list(DECLARED.values())
    for recording in summary["recordings"]:
        assert set(recording["windows"]) <= set(recording["declared"]) and all(recording["windows"].values())
    assert summary["rounds_changed"] and all(0 <= h <= 1 for h in summary["rounds_changed"])
    learned = model.summary["warnings"]  # after the logs' and the mounts' own
    assert summary["warnings"][len(summary["warnings"]) - len(learned):] == learned and summary["figure"] is None


def test_train_with_the_papers_recipe_gives_the_same_document(rides, tmp_path):
    folder, _ = rides
    summary = json.loads(_run("train", "-o", str(tmp_path / "p.npz"), "--recipe", "paper", "--json",
                              "--channels", "acc_long,pitch_rate", "--experiment",
                              f"{folder / 'sb.csv@1'}=cruising,normal-braking,sudden-braking").stdout)
    assert summary["learner"] == "paper" and summary["prior"] is None and summary["recordings"] == []
    assert summary["columns"] == sum(summary["columns_per_class"].values()) > 0


def test_classify_json_counts_the_labels_it_wrote(rides, tmp_path):
    folder, _ = rides
    result = _run("classify", str(folder / "m.npz"), str(folder / "sb.csv@2"), "-o", str(tmp_path / "l.csv"),
                  "--json")
    summary = json.loads(result.stdout)
    written = pd.read_csv(tmp_path / "l.csv", keep_default_na=False)["label"]
    assert summary["samples"] == len(written) and summary["method"] == "kcrc"
    assert summary["alignment"] == "causal" and summary["votes"] is None and summary["breaks"] == []
    model = summary["models"]["m"]
    assert model["labelled"] == int((written != "").sum()) == sum(model["labels"].values())
    assert model["labels"] == {c: int((written == c).sum()) for c in ["cruising", "normal-braking",
                                                                      "sudden-braking"]}
    assert summary["read"].startswith(f"{folder / 'sb.csv'}: CSV log") and summary["read"] in result.stderr
    assert summary["mount"]["line"].startswith("mount: ") and summary["mount"]["line"] in result.stderr
    assert summary["notes"] == [] and summary["warnings"] == []


def test_classify_json_with_two_models_has_one_entry_per_model(rides, tmp_path):
    folder, _ = rides
    (tmp_path / "twin.npz").write_bytes((folder / "m.npz").read_bytes())
    summary = json.loads(_run("classify", str(folder / "m.npz"), str(tmp_path / "twin.npz"), str(folder / "nb.csv"),
                              "-o", str(tmp_path / "l.csv"), "--json", "--segments", "4").stdout)
    table = pd.read_csv(tmp_path / "l.csv", keep_default_na=False)
    assert list(summary["models"]) == ["m", "twin"] and summary["votes"] == "segment vote at penalty 4"
    for name, model in summary["models"].items():
        assert model["labelled"] == int((table[name] != "").sum())
    assert summary["models"]["m"] == summary["models"]["twin"]


def test_features_json_names_the_channels_of_the_file(rides, tmp_path):
    folder, _ = rides
    summary = json.loads(_run("features", str(folder / "nb.csv@1"), "-o", str(tmp_path / "f.csv"), "--json").stdout)
    table = pd.read_csv(tmp_path / "f.csv")
    assert summary["features"] == "ride" and summary["samples"] == len(table) and summary["rate"] == 20.0
    assert summary["channels"] == [c for c in table.columns if c not in ("experiment", "time")]
    assert summary["orientation"] == "default" and isinstance(summary["mount"]["warnings"], list)


@pytest.mark.parametrize("command", ["simulate", "features", "train", "classify"])
def test_quiet_prints_nothing_and_still_writes(rides, tmp_path, command):
    folder, _ = rides
    argv = {"simulate": ["simulate", "cruising", "--repeats", "1"],
            "features": ["features", str(folder / "sb.csv@1")],
            "train": ["train", "--preset", "braking", "--experiment", f"{folder / 'sb.csv@1'}=cruising,normal-braking,"
                      "sudden-braking", "--experiment", f"{folder / 'sb.csv@2'}=cruising"],
            "classify": ["classify", str(folder / "m.npz"), str(folder / "sb.csv@1")]}[command]
    written = tmp_path / ("out.npz" if command == "train" else "out.csv")
    result = _run(*argv, "-o", str(written), "--quiet")
    assert result.stdout == "" and result.stderr == ""
    assert written.stat().st_size > 0


def test_quiet_with_json_prints_the_json_alone_and_errors_still_show(rides, tmp_path):
    folder, _ = rides
    result = _run("classify", str(folder / "m.npz"), str(folder / "sb.csv@1"), "-o", str(tmp_path / "l.csv"), "-q",
                  "--json")
    assert result.stderr == "" and json.loads(result.stdout)["models"]["m"]["labelled"] > 0
    failed = runner.invoke(app, ["classify", str(folder / "m.npz"), str(tmp_path / "nope.csv"), "-o",
                                 str(tmp_path / "l.csv"), "--quiet", "--json"])
    assert failed.exit_code == 2 and failed.stdout == ""
    assert failed.stderr.strip().splitlines() == [f"error: {tmp_path / 'nope.csv'}: file not found; check the path"]
    after = _run("simulate", "cruising", "--repeats", "1", "-o", str(tmp_path / "c.csv"))
    assert after.stdout.startswith("wrote "), "a quiet command leaves the consoles as they were"


def test_train_warnings_stay_on_stderr_and_are_in_the_document(rides, tmp_path):
    folder, _ = rides
    result = _run("train", "-o", str(tmp_path / "w.npz"), "--preset", "braking", "--json",
                  "--experiment", f"{folder / 'nb.csv@1'}=cruising,normal-braking",
                  "--experiment", f"{folder / 'sb.csv@1'}=cruising,normal-braking,sudden-braking,"
                  + ",".join(f"ghost{k}" for k in range(9)))
    summary = json.loads(result.stdout)
    assert any(w.startswith("recording 2 declares 12 classes over ") for w in summary["warnings"])
    lines = result.stderr.splitlines()
    assert [line.removeprefix("warning: ") for line in lines if line.startswith("warning: ")] == summary["warnings"]
    assert [line.removeprefix("read: ") for line in lines if line.startswith("read: ")] == summary["read"]
    assert len(summary["read"]) == len(summary["mounts"]) == 2


def test_train_on_many_ride_logs_tells_each_mount_once_per_kind(rides, tmp_path):
    """Six ride logs (over the few told one by one): one read line, each mount said once with how many logs it
    fits, every line of each log in the JSON summary. (A log declared twice is read once: two copies of one log
    share a mount.)"""
    folder, _ = rides
    shutil.copy(folder / "nb.csv", tmp_path / "copy.csv")
    logs = [f"{folder / name}@{k}" for name in ("nb.csv", "sb.csv") for k in (1, 2)] + [str(folder / "nb.csv"),
                                                                                       str(tmp_path / "copy.csv")]
    args = [a for log in logs for a in ("--experiment", f"{log}=cruising,normal-braking,sudden-braking")]
    result = _run("train", "-o", str(folder / "many.npz"), "--preset", "braking", "--json", *args)
    summary = json.loads(result.stdout)
    lines = result.stderr.splitlines()
    read = [line for line in lines if line.startswith("read: ")]
    mounts = [line for line in lines if line.startswith("mount: ")]
    assert len(read) == 1 and read[0].startswith("read: 6 logs, ")
    assert len(summary["read"]) == len(summary["mounts"]) == 6
    assert 1 <= len(mounts) < 6 and any(line.startswith("mount: 2 logs, the first ") for line in mounts)
    assert all(m.startswith("mount: up is ") for m in summary["mounts"])
