"""The ride prior engages by what a class is (its role in a preset, or the one a user gives it), not by its name."""

import re

import numpy as np
import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.io.recording import Recording
from spotfree.presets import PRESET_ROLES
from spotfree.ride_prior import RidePrior, with_roles

runner = CliRunner()


@pytest.mark.parametrize("preset", ["braking", "lateral", "road"])
def test_a_presets_own_classes_keep_the_prior_itself(preset):
    prior = RidePrior()
    assert with_roles(prior, list(PRESET_ROLES[preset]), PRESET_ROLES[preset], {}) == (prior, [])
    assert with_roles(prior, list(PRESET_ROLES[preset]), PRESET_ROLES[preset], {})[0] is prior


def test_a_users_class_given_a_role_gets_the_prior_the_presets_class_of_that_role_gets():
    n = 200
    speed = np.full(n, np.nan)
    speed[::20] = np.linspace(6.0, 0.0, 10)  # a 1 Hz GPS speed that falls by 0.67 m/s^2
    rec = Recording(np.arange(n) / 20.0, {"speed": speed}, 20.0)
    preset = RidePrior().log_prior(rec, np.arange(n), ["cruising", "normal-braking"])
    prior, warnings = with_roles(RidePrior(), ["cruising", "braking"], PRESET_ROLES["braking"], {"braking": "slowing"})
    assert warnings == [] and "braking" in prior.braking
    np.testing.assert_array_equal(prior.log_prior(rec, np.arange(n), ["cruising", "braking"]), preset)
    assert preset[:, 1].max() > 0  # the prior did engage
    # a preset class given another role leaves its own
    prior, _ = with_roles(RidePrior(), ["cruising", "normal-braking"], PRESET_ROLES["braking"],
                          {"normal-braking": "none"})
    assert "normal-braking" not in prior.braking and not prior.log_prior(rec, np.arange(n), ["cruising",
                                                                                             "normal-braking"]).any()


def test_a_class_of_no_role_is_warned_about_with_what_to_do():
    prior, warnings = with_roles(RidePrior(), ["cruising", "braking"], PRESET_ROLES["braking"], {})
    assert prior == RidePrior()
    assert warnings == [
        "the ride prior does not know what class 'braking' is and takes it as neither slowing nor turning; it engages "
        "for no class of this training; give it a role: --role braking=slowing (loses GPS speed: a braking, a stop), "
        "--role braking=turn (yaws) or --role braking=none"]
    _, warnings = with_roles(RidePrior(), ["cruising", "normal-braking", "hard-stop"], PRESET_ROLES["braking"], {})
    assert warnings[0].startswith("the ride prior does not know what class 'hard-stop' is and takes it as neither "
                                  "slowing nor turning; give it a role: --role hard-stop=slowing")


@pytest.fixture(scope="module")
def declared(tmp_path_factory):
    """``--sets`` of two 25-s spans of simulated rides, their classes named by the user, not by the preset."""
    folder = tmp_path_factory.mktemp("roles")
    for scenario, seed in (("normal-braking", "0"), ("sudden-braking", "1")):
        result = runner.invoke(app, ["simulate", scenario, "-o", str(folder / f"{scenario}.csv"), "--repeats", "1",
                                     "--seed", seed])
        assert result.exit_code == 0, result.output
    sets = folder / "sets.csv"
    sets.write_text('recording,start,end,classes\nnormal-braking.csv,0,25,"cruising,braking"\n'
                    'sudden-braking.csv,0,25,"cruising,braking,hard-stop"\n')
    return folder, sets


def test_train_says_when_a_users_classes_have_no_role_and_uses_the_roles_given(declared):
    folder, sets = declared
    result = runner.invoke(app, ["train", "-o", str(folder / "none.npz"), "--preset", "braking", "--sets", str(sets)])
    assert result.exit_code == 0, result.output
    assert "the ride prior does not know what classes 'braking', 'hard-stop' are" in result.output
    assert "it engages for no class of this training; give each a role: --role braking=slowing" in result.output
    result = runner.invoke(app, ["train", "-o", str(folder / "roles.npz"), "--preset", "braking", "--sets", str(sets),
                                 "--role", "braking=slowing", "--role", "hard-stop=slowing"])
    assert result.exit_code == 0, result.output
    assert "prior: ride (slowing: braking,hard-stop)" in result.output and "does not know" not in result.output
    braking, cruising = map(int, re.search(r"normal-braking\.csv.*?│ braking,cruising +│ braking (\d+) cruising (\d+)",
                                          result.output).groups())
    assert cruising > braking  # with the prior, braking no longer claims the cruising


@pytest.mark.parametrize("options, message", [
    (["--preset", "braking", "--role", "stopping=slowing"], "--role 'stopping=slowing': no recording declares class "
                                                            "'stopping'; declared: cruising, braking, hard-stop"),
    (["--preset", "braking", "--role", "braking=fast"], "--role 'braking=fast': write CLASS=ROLE with ROLE one of "
                                                        "slowing, turn, none"),
    (["--preset", "road", "--role", "braking=slowing"], "--role gives classes their role in the ride prior: add "
                                                        "--prior ride, or train with --preset braking or lateral"),
])
def test_a_role_that_cannot_be_used_is_refused_in_one_line(declared, options, message):
    folder, sets = declared
    result = runner.invoke(app, ["train", "-o", str(folder / "refused.npz"), "--sets", str(sets), *options])
    assert result.exit_code == 2 and message in result.output, result.output
    assert not (folder / "refused.npz").exists()
