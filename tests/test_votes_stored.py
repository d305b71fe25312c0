"""A model's offline votes stored in its file: `spotfree votes`, `classify --offline`, bad input keeps the file."""

import numpy as np
import pandas as pd
import pytest
from classify_fixtures import truth_model
from typer.testing import CliRunner

from spotfree.classify.multi import classify_models
from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.io.csvlog import write_csv
from spotfree.model import DictionaryModel
from spotfree.sim.scenarios import simulate_scenario
from spotfree.votes.options import Votes, describe, stored_votes, voted_labels, with_votes

LATERAL = Votes(segments=4.0, events=("straight",), edges={"yaw_rate": 0.09})


@pytest.fixture(scope="module")
def models():
    """Truth-named lateral and braking dictionaries (mechanics only; not trained models)."""
    return {"lateral": truth_model(simulate_scenario("lateral", repeats=1, seed=3), channels=("yaw_rate", "roll_rate"),
                                   window=30),
            "braking": truth_model(simulate_scenario("sudden-braking", repeats=1, seed=3))}


@pytest.fixture(scope="module")
def ride():
    rec = simulate_scenario("lateral", repeats=2, seed=11)
    return rec.take(np.flatnonzero(rec.experiment == 1)[:900])


def test_votes_survive_the_file_and_label_as_the_same_options_do(models, ride, tmp_path):
    lateral = with_votes(models["lateral"], LATERAL)
    lateral.save(tmp_path / "lateral.npz")
    loaded = DictionaryModel.load(tmp_path / "lateral.npz")
    assert stored_votes(loaded) == LATERAL and loaded.parameters["votes"]["segments"] == 4.0
    assert describe(stored_votes(loaded)) == "--segments 4 --events straight --edges yaw_rate=0.09"
    np.testing.assert_array_equal(voted_labels(loaded, ride, stored_votes(loaded)).label,
                                  voted_labels(models["lateral"], ride, LATERAL).label)
    cleared = with_votes(loaded)
    assert "votes" not in cleared.parameters and stored_votes(cleared) == Votes()


def test_votes_a_model_cannot_run_are_refused(models):
    for bad, message in [({"keep": ("kerb",)}, "--keep kerb: not a class of the model"),
                         ({"events": ("smooth",)}, "--events smooth: not a class of the model"),
                         ({"edges": {"yaw_rate": 0.09}}, "--edges yaw_rate: the model runs no event vote"),
                         ({"events": ("straight",), "edges": {"roll": 0.1}}, "--edges roll: not a channel"),
                         ({"segments": -1.0}, r"\(--segments\)")]:
        with pytest.raises(InputError, match=message):
            with_votes(models["lateral"], Votes(**bad))


def test_cli_stores_shows_uses_and_clears_the_votes_and_bad_input_keeps_the_file(models, ride, tmp_path):
    for name, model in models.items():
        model.save(tmp_path / f"{name}.npz")
    write_csv(ride, tmp_path / "ride.csv")
    run = lambda *args: CliRunner().invoke(app, [str(a) for a in args])  # noqa: E731
    said = lambda *args: " ".join(run(*args).output.split())  # noqa: E731 (the console wraps long lines)
    path = tmp_path / "lateral.npz"
    assert "no offline vote stored" in said("votes", path)
    stored = said("votes", path, "--segments", "4", "--events", "straight", "--edges", "yaw_rate=0.09")
    assert "stored in" in stored and "--segments 4 --events straight --edges yaw_rate=0.09" in stored
    before = path.read_bytes()
    for bad in (["--edges", "yaw_rate=0.09"], ["--keep", "kerb"], ["--clear", "--segments", "2"]):
        result = run("votes", path, *bad)
        assert result.exit_code == 2 and len(result.output.strip().splitlines()) == 1, result.output
        assert path.read_bytes() == before

    offline = run("classify", path, tmp_path / "ride.csv", "-o", tmp_path / "offline.csv", "--offline")
    assert offline.exit_code == 0
    assert "offline votes stored in the model: --segments 4" in " ".join(offline.output.split())
    explicit = voted_labels(models["lateral"], ride, LATERAL).label
    labels = pd.read_csv(tmp_path / "offline.csv", keep_default_na=False)["label"].astype(str).to_numpy()
    np.testing.assert_array_equal(labels, explicit)

    both = run("classify", tmp_path / "braking.npz", path, tmp_path / "ride.csv", "-o", tmp_path / "both.csv",
               "--offline")
    assert both.exit_code == 0 and "braking none, lateral --segments 4" in " ".join(both.output.split())
    table = pd.read_csv(tmp_path / "both.csv", keep_default_na=False)
    expected = classify_models(models, ride, centred=True)  # offline: the model without votes labels centred too
    np.testing.assert_array_equal(table["lateral"].astype(str).to_numpy(), explicit)
    np.testing.assert_array_equal(table["braking"].astype(str).to_numpy(), expected["braking"].to_numpy())
    mixed = run("classify", path, tmp_path / "ride.csv", "-o", tmp_path / "x.csv", "--offline", "--segments", "4")
    assert mixed.exit_code == 2 and "give either --offline or the vote options" in mixed.output
    assert not (tmp_path / "x.csv").exists()

    assert "removed the offline votes" in said("votes", path, "--clear")
    assert "no offline vote stored" in said("votes", path)
