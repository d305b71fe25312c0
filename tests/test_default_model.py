"""The default ride model: a model file shipped as package data, read (never trained) by ``serve`` and ``fleet
process``, and exactly what ``scripts/build_default_model.py`` builds."""

import importlib.util
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import spotfree.ride
from spotfree.model import DictionaryModel
from spotfree.presets import PRESETS
from spotfree.ride.default_model import default_model, default_model_path
from spotfree.sim.scenarios import CLASSES

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = ROOT / "scripts" / "build_default_model.py"
REBUILD = f"rebuild it: python {SCRIPT.relative_to(ROOT)}"


def _script():
    spec = importlib.util.spec_from_file_location("build_default_model", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_shipped_model_is_the_braking_preset_on_the_braking_classes():
    model = default_model()
    preset = PRESETS["braking"]
    assert default_model_path() == Path(spotfree.ride.__file__).parent / "models" / "braking.npz"
    assert model.channels == list(preset["channels"]) and model.window == preset["window"]
    assert model.representation == preset["representation"] and model.features == "ride"
    assert set(model.classes) == {c for s in ("normal-braking", "sudden-braking") for c in CLASSES[s]}
    assert set(model.column_class) == set(range(len(model.classes)))  # every class has columns


def test_the_recorded_recipe_is_the_scripts_with_the_presets_current_learner():
    script, build = _script(), default_model().summary["build"]
    assert build == json.loads(json.dumps(script.recipe())), f"the shipped model was built otherwise; {REBUILD}"
    assert build["learner"]["prior"].startswith("RidePrior(") and build["learner"]["window"] == 20


@pytest.mark.slow
def test_the_script_builds_the_shipped_file_again(tmp_path):
    proc = subprocess.run([sys.executable, str(SCRIPT), "-o", str(tmp_path / "braking.npz")], capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith(f"wrote {tmp_path / 'braking.npz'}: ")
    with np.load(default_model_path()) as shipped, np.load(tmp_path / "braking.npz") as built:
        assert sorted(shipped.files) == sorted(built.files)
        assert json.loads(str(shipped["metadata"])) == json.loads(str(built["metadata"])), REBUILD
        changed = [k for k in shipped.files if not np.array_equal(shipped[k], built[k])]
        assert not changed, f"{', '.join(changed)} differ from the shipped file's; {REBUILD}"


def test_the_package_data_puts_the_model_file_in_the_installed_package(tmp_path):
    source = tmp_path / "source"
    shutil.copytree(ROOT / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__", "*.egg-info"))
    shutil.copy(ROOT / "pyproject.toml", source)
    shutil.copy(ROOT / "README.md", source)
    proc = subprocess.run([sys.executable, "-c", "from setuptools import setup; setup()", "-q", "build_py",
                           "--build-lib", str(tmp_path / "lib")], cwd=source, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    installed = tmp_path / "lib" / "spotfree" / "ride" / "models" / default_model_path().name
    assert installed.read_bytes() == default_model_path().read_bytes()
    assert DictionaryModel.load(installed).classes == default_model().classes


def test_serve_without_a_model_loads_the_shipped_one(tmp_path):
    pytest.importorskip("fastapi")
    from spotfree.ride.server import build_service

    service = build_service(str(tmp_path / "rides.db"), None)
    try:
        assert service.model.metadata() == default_model().metadata()
        assert np.array_equal(service.model.dictionary, default_model().dictionary)
    finally:
        service.close()
