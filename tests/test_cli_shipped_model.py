"""A shipped model is named on the command line (``spotfree classify braking LOG``) and says what it learnt from."""

from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.ride.default_model import default_model_path, shipped_model_path, shipped_models, trained_on
from spotfree.model import DictionaryModel

runner = CliRunner()


def test_the_shipped_models_are_the_files_of_the_package_folder_by_name():
    assert shipped_models() == {"braking": default_model_path()}
    assert shipped_model_path("braking") == default_model_path() and shipped_model_path("brakes") is None
    assert trained_on(DictionaryModel.load(default_model_path())) == (
        "trained on 2 recording(s): simulate normal-braking (cruising,normal-braking); simulate sudden-braking "
        "(cruising,normal-braking,sudden-braking) by scripts/build_default_model.py with --preset braking, seed 0")


def test_classify_takes_a_shipped_model_by_name_and_says_what_it_was_trained_on(tmp_path):
    ride = tmp_path / "ride.csv"
    assert runner.invoke(app, ["simulate", "sudden-braking", "-o", str(ride), "--repeats", "1"]).exit_code == 0
    named = runner.invoke(app, ["classify", "braking", str(ride), "-o", str(tmp_path / "named.csv")])
    assert named.exit_code == 0, named.output
    assert "model braking: shipped with spotfree, trained on 2 recording(s): simulate normal-braking" in named.output
    by_file = runner.invoke(app, ["classify", str(default_model_path()), str(ride), "-o", str(tmp_path / "file.csv")])
    assert by_file.exit_code == 0, by_file.output
    assert (tmp_path / "named.csv").read_text() == (tmp_path / "file.csv").read_text()


def test_a_model_that_is_neither_a_file_nor_a_shipped_name_is_refused_naming_the_shipped_ones(tmp_path):
    ride = tmp_path / "ride.csv"
    ride.write_text("time,ax\n0,1\n0.05,1\n")
    result = runner.invoke(app, ["classify", "brakes", str(ride), "-o", str(tmp_path / "out.csv")])
    assert result.exit_code == 2
    assert "classify: brakes is neither a model file nor a shipped model (braking); give a file written by " \
           "'spotfree train' or that name" in result.output
    result = runner.invoke(app, ["classify", str(ride), "braking", "-o", str(tmp_path / "out.csv")])
    assert result.exit_code == 2 and "classify: braking is a model file among the logs" in result.output
