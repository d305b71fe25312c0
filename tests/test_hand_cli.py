"""The hand train and hand run commands: model files, the output stream, bad logs."""

import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.hand.commands import COMMANDS
from spotfree.hand.log import write_hand_log
from spotfree.hand.vocabulary import GESTURES, POSTURES
from spotfree.sim.hand import simulate_hands

runner = CliRunner()


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("hand")
    write_hand_log(simulate_hands(people=2, seed=4, rounds=3, protocol="training"), root / "train.jsonl")
    write_hand_log(simulate_hands(people=1, seed=6, rounds=1, first=50), root / "test.jsonl")
    result = runner.invoke(app, ["hand", "train", "-o", str(root / "m.npz"), str(root / "train.jsonl")])
    assert result.exit_code == 0, result.output
    return root


def test_train_writes_three_stage_files_and_run_writes_the_stream(files):
    assert all((files / n).exists() for n in ("m.npz", "m.live-state.npz", "m.posture.npz", "m.gesture.npz"))
    result = runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(files / "test.jsonl"),
                                 "-o", str(files / "out.csv")])
    assert result.exit_code == 0, result.output
    out = pd.read_csv(files / "out.csv", keep_default_na=False)
    assert list(out.columns) == ["time", "state", "label", "command"]
    assert set(out.state) <= {"", "posture", "gesture"}
    assert set(out.label[out.state == "posture"]) <= set(POSTURES)
    assert set(out.label[out.state == "gesture"]) <= set(GESTURES)
    assert set(out.command) <= set(COMMANDS.values())
    assert (out.label[out.state == ""] == "").all() and (out.command[out.state == ""] == "stop").all()
    assert np.all(np.diff(out.time) > 0) and (out.state != "").mean() > 0.9


def test_run_offline_names_each_gesture_stretch_once(files):
    result = runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(files / "test.jsonl"), "--offline",
                                 "-o", str(files / "offline.csv")])
    assert result.exit_code == 0, result.output
    out = pd.read_csv(files / "offline.csv", keep_default_na=False)
    gesture = (out.state == "gesture").to_numpy()
    edges = np.diff(np.r_[0, gesture.astype(int), 0])
    stretches = list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))
    assert stretches and all(out.label[a:b].nunique() == 1 for a, b in stretches)
    runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(files / "test.jsonl"), "-o", str(files / "live.csv")])
    live = pd.read_csv(files / "live.csv", keep_default_na=False)
    assert len(out) == len(live) and (out.time == live.time).all()


def test_run_writes_the_gesture_events_on_request(files):
    """Offline, each gesture stretch of the stream is one event, with the stretch's times and gesture."""
    result = runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(files / "test.jsonl"), "--offline",
                                 "-o", str(files / "stream.csv"), "--events", str(files / "events.csv")])
    assert result.exit_code == 0, result.output
    out = pd.read_csv(files / "stream.csv", keep_default_na=False)
    events = pd.read_csv(files / "events.csv", keep_default_na=False)
    assert list(events.columns) == ["start", "stop", "gesture"] and f"{len(events)} gesture event(s)" in result.output
    assert len(events) and set(events.gesture) <= set(GESTURES) and (events.stop >= events.start).all()
    for start, stop, gesture in events.itertuples(index=False):
        inside = out[(out.time >= start - 1e-9) & (out.time <= stop + 1e-9)]
        assert (inside.state == "gesture").all() and (inside.label == gesture).all()


def test_bad_frames_are_clear_errors_and_no_labels_are_invented(files, tmp_path):
    lines = (files / "test.jsonl").read_text().splitlines()
    bad = tmp_path / "bad.jsonl"
    bad.write_text("\n".join(lines[:100] + ["{not json"] + lines[100:]) + "\n")
    result = runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(bad), "-o", str(tmp_path / "o.csv")])
    assert result.exit_code == 2 and "line 101" in result.output and not (tmp_path / "o.csv").exists()
    frames = [json.loads(line) for line in lines]
    for frame in frames[300:500]:
        frame["hands"], frame["pointables"] = [], []
    holed = tmp_path / "holed.jsonl"
    holed.write_text("".join(json.dumps(f) + "\n" for f in frames))
    result = runner.invoke(app, ["hand", "run", str(files / "m.npz"), str(holed), "-o", str(tmp_path / "h.csv")])
    assert result.exit_code == 0, result.output
    assert "no data from" in result.output
    out = pd.read_csv(tmp_path / "h.csv", keep_default_na=False)
    t0, t1 = frames[300]["timestamp"] * 1e-6, frames[499]["timestamp"] * 1e-6
    inside = (out.time > t0 + 0.1) & (out.time < t1 - 0.1)
    assert inside.sum() > 10 and (out.label[inside] == "").all() and (out.command[inside] == "stop").all()


def test_a_log_that_is_not_a_training_protocol_and_a_missing_model_are_refused(files, tmp_path):
    result = runner.invoke(app, ["hand", "train", "-o", str(tmp_path / "x.npz"), str(files / "test.jsonl")])
    assert result.exit_code == 2 and "9 sessions per person" in result.output
    result = runner.invoke(app, ["hand", "run", str(tmp_path / "none.npz"), str(files / "test.jsonl"),
                                 "-o", str(tmp_path / "o.csv")])
    assert result.exit_code == 2 and "no such model file" in result.output


def test_hand_train_simulates_the_library_s_number_of_training_people_by_default():
    import inspect

    from spotfree.cli import hand_train
    from spotfree.evaluation.hand import evaluate_hand
    from spotfree.sim.hand import TRAINING_PEOPLE

    assert inspect.signature(hand_train).parameters["people"].default.default == TRAINING_PEOPLE
    assert inspect.signature(evaluate_hand).parameters["train_people"].default == TRAINING_PEOPLE
