"""`spotfree train --recipe sets` and `--features body`: a raw IMU log that is not a ride trains and classifies on
body channels; the summary says which learner and channels a model uses; misuse exits 2 with one line."""

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.model import DictionaryModel
from spotfree.signal.body import ACC_BODY_CHANNELS, BODY_CHANNELS

runner = CliRunner()
RATE = 20.0


def _imu_log(path, parts, seed, gyroscope=True):
    """A raw IMU CSV of a phone in a pocket: standing still, or walking (a 2 Hz sway with gravity on y); without
    the gyroscope's columns unless ``gyroscope``."""
    rng = np.random.default_rng(seed)
    rows, label = [], []
    for kind, seconds in parts:
        n = int(seconds * RATE)
        t = np.arange(n) / RATE
        sway = np.sin(2 * np.pi * 2.0 * t + rng.uniform(0, 6)) if kind == "walking" else np.zeros(n)
        acc = np.column_stack([0.1 + 2.0 * sway, 9.81 + 3.0 * np.abs(sway), 0.2 * sway]) + rng.normal(0, 0.05, (n, 3))
        gyr = np.column_stack([1.5 * sway, 0.3 * sway, 0.8 * sway]) + rng.normal(0, 0.01, (n, 3))
        rows.append(np.hstack([acc, gyr]))
        label += [kind] * n
    x = np.vstack(rows)
    frame = pd.DataFrame(x, columns=["ax", "ay", "az", "gx", "gy", "gz"])
    frame.insert(0, "time", np.arange(len(x)) / RATE)
    frame["label"] = label
    frame.drop(columns=[] if gyroscope else ["gx", "gy", "gz"]).to_csv(path, index=False)


def test_body_features_train_and_classify_from_class_sets(tmp_path):
    _imu_log(tmp_path / "walk.csv", [("still", 8), ("walking", 10), ("still", 6), ("walking", 8), ("still", 6)], 1)
    _imu_log(tmp_path / "still.csv", [("still", 20)], 2)
    _imu_log(tmp_path / "test.csv", [("still", 6), ("walking", 8), ("still", 6)], 3)
    model = tmp_path / "m.npz"
    result = runner.invoke(app, ["train", "-o", str(model), "--features", "body",
                                 "--experiment", f"{tmp_path / 'walk.csv'}=still,walking",
                                 "--experiment", f"{tmp_path / 'still.csv'}=still"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "learner: sets" in result.output and "body channels" in result.output
    assert result.output.count("read: ") == 2 and "mount:" not in result.output  # what was read; not a ride
    loaded = DictionaryModel.load(model)
    assert loaded.features == "body" and loaded.channels == list(BODY_CHANNELS)
    out = tmp_path / "labels.csv"
    result = runner.invoke(app, ["classify", str(model), str(tmp_path / "test.csv"), "-o", str(out), "--centred"],
                           catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "model: body channels" in result.output and "mount:" not in result.output  # not a ride: no mount
    labels = pd.read_csv(out, keep_default_na=False)["label"].to_numpy()
    truth = pd.read_csv(tmp_path / "test.csv")["label"].to_numpy()
    away = np.ones(len(truth), bool)
    for change in np.flatnonzero(truth[1:] != truth[:-1]) + 1:
        away[max(0, change - 10):change + 10] = False
    scored = away & (labels != "")
    assert np.mean(labels[scored] == truth[scored]) >= 0.95


def test_logs_of_acceleration_alone_train_and_classify_on_its_body_channels(tmp_path):
    for name, parts, seed in (("walk", [("still", 8), ("walking", 10), ("still", 6), ("walking", 8)], 1),
                              ("still", [("still", 20)], 2), ("test", [("still", 6), ("walking", 8), ("still", 6)], 3)):
        _imu_log(tmp_path / f"{name}.csv", parts, seed, gyroscope=False)
    _imu_log(tmp_path / "full.csv", [("still", 8), ("walking", 10)], 4)
    declared = ["--experiment", f"{tmp_path / 'walk.csv'}=still,walking",
                "--experiment", f"{tmp_path / 'still.csv'}=still"]
    model = tmp_path / "acc.npz"
    result = runner.invoke(app, ["train", "-o", str(model), "--features", "body", *declared], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert f"summary of body channels {','.join(ACC_BODY_CHANNELS)};" in result.output
    assert DictionaryModel.load(model).channels == list(ACC_BODY_CHANNELS)
    for log in ("test.csv", "full.csv"):  # a log with a gyroscope too gives the same channels, and more
        out = tmp_path / f"labels_{log}"
        result = runner.invoke(app, ["classify", str(model), str(tmp_path / log), "-o", str(out), "--centred"],
                               catch_exceptions=False)
        assert result.exit_code == 0, result.output
        labels = pd.read_csv(out, keep_default_na=False)["label"].to_numpy()
        truth = pd.read_csv(tmp_path / log)["label"].to_numpy()
        assert np.mean(labels[40:100] == truth[40:100]) >= 0.95  # inside the first still and walking stretches
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "raw.npz"), *declared], catch_exceptions=False)
    assert "summary of the log's channels ax,ay,az;" in result.output  # not a ride log: read as it is


def test_a_model_of_every_body_channel_refuses_a_log_without_a_gyroscope(tmp_path):
    _imu_log(tmp_path / "walk.csv", [("still", 8), ("walking", 10), ("still", 6), ("walking", 8)], 1)
    _imu_log(tmp_path / "still.csv", [("still", 20)], 2)
    _imu_log(tmp_path / "acc.csv", [("still", 6), ("walking", 8)], 3, gyroscope=False)
    model = tmp_path / "m.npz"
    assert runner.invoke(app, ["train", "-o", str(model), "--features", "body", "--experiment",
                               f"{tmp_path / 'walk.csv'}=still,walking", "--experiment",
                               f"{tmp_path / 'still.csv'}=still"]).exit_code == 0
    result = runner.invoke(app, ["classify", str(model), str(tmp_path / "acc.csv"), "-o", str(tmp_path / "o.csv")])
    assert result.exit_code == 2
    assert "model expects channels ax,ay,az,gx,gy,gz" in result.output and "give the raw IMU log" in result.output


def test_ride_features_of_a_log_not_from_a_handlebar_say_so(tmp_path):
    """Trained on ride features (asked for), pocket logs tell the mount found in each and point to --features
    body; --mount flat takes the nominal mount without a doubt."""
    _imu_log(tmp_path / "walk.csv", [("still", 8), ("walking", 10), ("still", 6)], 1)
    _imu_log(tmp_path / "still.csv", [("still", 20)], 2)
    args = ["train", "-o", str(tmp_path / "m.npz"), "--experiment", f"{tmp_path / 'walk.csv'}=still,walking",
            "--experiment", f"{tmp_path / 'still.csv'}=still", "--features", "ride"]
    result = runner.invoke(app, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert result.output.count("read: ") == 2 and result.output.count("mount: ") == 2
    assert "from flat" in result.output and "train with --features body" in result.output
    result = runner.invoke(app, [*args, "--mount", "flat"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "--features body" not in result.output


@pytest.mark.parametrize("extra, message", [
    (["--recipe", "paper", "--prior", "ride"], "--prior is an option of --recipe sets"),
    (["--recipe", "paper", "--representation", "summary"], "--representation is an option of --recipe sets"),
    (["--recipe", "evidence"], "--recipe 'evidence': use one of sets, paper"),
    (["--prior", "lean"], "--prior 'lean': use one of ride"),
    (["--features", "wrist"], "--features 'wrist'"),
    (["--mount", "sideways"], "--mount 'sideways' is not known; give auto, estimate, flat, upright"),
])
def test_misuse_of_the_learner_options_exits_2(tmp_path, extra, message):
    _imu_log(tmp_path / "walk.csv", [("still", 5), ("walking", 5)], 1)
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"),
                                 "--experiment", f"{tmp_path / 'walk.csv'}=still,walking", *extra])
    assert result.exit_code == 2
    assert message in " ".join(result.output.split())
    assert not (tmp_path / "m.npz").exists()


def test_a_recording_shorter_than_a_window_exits_2_with_one_line(tmp_path):
    _imu_log(tmp_path / "walk.csv", [("still", 6), ("walking", 6)], 1)
    _imu_log(tmp_path / "short.csv", [("still", 0.5)], 2)
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"), "--features", "body",
                                 "--experiment", f"{tmp_path / 'walk.csv'}=still,walking",
                                 "--experiment", f"{tmp_path / 'short.csv'}=still"])
    assert result.exit_code == 2
    assert "short.csv: no gap-free stretch is as long as one window" in " ".join(result.output.split())
    assert not (tmp_path / "m.npz").exists()


def test_train_on_many_logs_says_what_they_share_once(tmp_path):
    """Six logs resampled alike: one read line for all and their shared note once, as the first says it, with its count; every line of
    each in the JSON summary."""
    args = []
    for k in range(6):
        path = tmp_path / f"clip{k}.csv"
        _imu_log(path, [("still", 4), ("walking", 4)], k)
        frame = pd.read_csv(path)
        frame["time"] += np.random.default_rng(k).uniform(-0.01, 0.01, len(frame))  # irregular steps: a repair note
        frame.to_csv(path, index=False)
        args += ["--experiment", f"{path}=still,walking"]
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"), "--features", "body", "--json", *args])
    assert result.exit_code == 0, result.output
    lines = result.stderr.splitlines()
    read = [line for line in lines if line.startswith("read: ")]
    notes = [line for line in lines if line.startswith("note: ")]
    assert len(read) == 1 and read[0].startswith("read: 6 logs, ") and str(tmp_path / "clip0.csv") in read[0]
    first = tmp_path / "clip0.csv"
    assert len(notes) == 1 and notes[0].startswith(f"note: 6 logs, the first {first}: time steps are irregular")
    summary = json.loads(result.stdout)
    assert len(summary["read"]) == 6 and len(summary["notes"]) == 6
    assert notes[0].endswith(summary["notes"][0].split(": ", 1)[1])


def test_train_on_more_logs_than_table_rows_shows_a_row_per_declared_set(tmp_path, monkeypatch):
    """Over the table's rows, recordings that declare the same set share a row: how many, and the windows named in
    them all (the sum of the per-recording counts, which the JSON summary keeps); the figure draws the first logs
    and says so."""
    import spotfree.cli as cli
    import spotfree.evaluation.figures as figures

    monkeypatch.setattr(cli, "TABLE_ROWS", 3)
    monkeypatch.setattr(figures, "FIGURE_ROWS", 2)
    args = []
    for k, parts in enumerate([[("still", 6), ("walking", 6)]] * 3 + [[("still", 8)]] * 2):
        path = tmp_path / f"log{k}.csv"
        _imu_log(path, parts, k)
        args += ["--experiment", f"{path}={'still,walking' if len(parts) == 2 else 'still'}"]
    result = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"), "--features", "body", "--json", *args])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    shown = runner.invoke(app, ["train", "-o", str(tmp_path / "m2.npz"), "--features", "body", *args, "--figure",
                                str(tmp_path / "names.png")]).stdout
    assert str(tmp_path / "log0.csv") not in shown  # no row per recording
    assert f"figure: {tmp_path / 'names.png'} (2 of 5 training logs)" in " ".join(shown.split())
    rows = [line for line in shown.splitlines() if "still,walking" in line or "│ still " in line]
    both = [r for r in summary["recordings"] if r["declared"] == ["still", "walking"]]
    named = {c: sum(r["windows"].get(c, 0) for r in both) for c in ("still", "walking")}
    assert len(rows) == 2 and "│ 3 " in rows[0] and f"still {named['still']} walking {named['walking']}" in rows[0]


def test_a_sets_file_of_spans_trains_the_model_of_the_same_spans_written_as_files(tmp_path):
    """`--sets`: rows naming spans of one log give the dictionary that the same spans, written as files of their own
    and declared with `--experiment`, give; the log is read once; each span is named in the summary."""
    rng = np.random.default_rng(4)
    n = int(60 * RATE)
    t = np.arange(n) / RATE
    moving = (t % 20) >= 12  # 12 s still, 8 s moving, three times
    x = np.where(moving, np.sin(2 * np.pi * 1.5 * t), 0.0) + rng.normal(0, 0.05, n)
    frame = pd.DataFrame({"time": t, "x": x, "y": np.where(moving, 1.0, 0.0) + rng.normal(0, 0.05, n)})
    frame.to_csv(tmp_path / "long.csv", index=False)
    spans = [(0, 10, "still"), (10, 22, "still;moving"), (22, 30, "still"), (45, 60, "still;moving")]
    pd.DataFrame([{"recording": "long.csv", "start": a, "end": b, "classes": c} for a, b, c in spans]).to_csv(
        tmp_path / "sets.csv", index=False)
    args = []
    for k, (a, b, c) in enumerate(spans):
        frame[(t >= a) & (t < b)].to_csv(tmp_path / f"part{k}.csv", index=False)
        args += ["--experiment", f"{tmp_path / f'part{k}.csv'}={c.replace(';', ',')}"]
    from_sets = runner.invoke(app, ["train", "-o", str(tmp_path / "sets.npz"), "--channels", "x,y", "--json",
                                    "--sets", str(tmp_path / "sets.csv"), "--figure", str(tmp_path / "names.png")])
    from_files = runner.invoke(app, ["train", "-o", str(tmp_path / "files.npz"), "--channels", "x,y", *args])
    assert from_sets.exit_code == 0 and from_files.exit_code == 0, from_sets.output + from_files.output
    a, b = DictionaryModel.load(tmp_path / "sets.npz"), DictionaryModel.load(tmp_path / "files.npz")
    np.testing.assert_array_equal(a.dictionary, b.dictionary)
    np.testing.assert_array_equal(a.column_class, b.column_class)
    summary = json.loads(from_sets.stdout)
    assert len(summary["read"]) == 1
    assert [r["source"] for r in summary["recordings"]] == [f"{tmp_path / 'long.csv'}[{a}-{b} s]"
                                                            for a, b, _ in spans]
    assert summary["recordings"][1]["declared"] == ["moving", "still"]
    assert (tmp_path / "names.png").stat().st_size > 0


def test_train_without_recordings_or_with_a_bad_sets_file_exits_2(tmp_path):
    none = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz")])
    assert none.exit_code == 2 and "give --experiment PATH=CLASS[,CLASS...] or --sets FILE" in none.output
    _imu_log(tmp_path / "walk.csv", [("still", 6), ("walking", 6)], 1)
    (tmp_path / "sets.csv").write_text("recording,classes,start,end\nwalk.csv,still,30,40\n")
    empty = runner.invoke(app, ["train", "-o", str(tmp_path / "m.npz"), "--features", "body",
                                "--sets", str(tmp_path / "sets.csv")])
    assert empty.exit_code == 2
    assert "walk.csv[30-40 s]: no sample in this span; the log runs from 0 s to 11.95 s" in " ".join(
        empty.output.split())
    assert not (tmp_path / "m.npz").exists()


def test_auto_settings_choose_the_settings_not_given_and_say_each_candidate_s_risk(tmp_path):
    """--auto-settings: the learner's settings not given are chosen from the sets (spotfree.selection), one line
    each with the set risk of its candidates; the features of raw IMU logs are chosen without it; a given one is said
    given; --json carries the rows."""
    args = ["train", "-o", str(tmp_path / "m.npz")]
    for k in (1, 2):
        _imu_log(tmp_path / f"walk{k}.csv", [("still", 6), ("walking", 8), ("still", 6)], k)
        _imu_log(tmp_path / f"still{k}.csv", [("still", 20)], 10 + k)
        args += ["--experiment", f"{tmp_path / f'walk{k}.csv'}=still,walking",
                 "--experiment", f"{tmp_path / f'still{k}.csv'}=still"]
    result = runner.invoke(app, [*args, "--auto-settings", "--window", "20", "--json"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    document = json.loads(result.output[result.output.index("{"):])
    rows = {row["setting"]: row for row in document["settings"]}
    assert rows["window"]["given"] == "option" and rows["window"]["value"] == 20
    assert set(rows["features"]["candidates"]) == {"ride", "body"}
    for name in ("share_power", "column_share", "smoothing"):
        assert rows[name]["given"] is False and len(rows[name]["candidates"]) >= 2
        assert rows[name]["value"] in [float(v) for v in rows[name]["candidates"]]
    plain = runner.invoke(app, args, catch_exceptions=False)
    assert "setting: share_power 0.5 (the learner's default)" in plain.output
    assert "setting: features " in plain.output and "(chosen; set risk ride " in plain.output
