"""The model ``spotfree serve`` and ``spotfree fleet process`` use when given none: spotfree's braking model
(cruising, normal and sudden braking), shipped with the package as the model file ``models/braking.npz``
(:mod:`spotfree.model`) and read, never trained, at start.

``scripts/build_default_model.py`` builds the file from simulated rides with the ``braking`` preset and records
its recipe, every parameter of the learner included, in the model's summary under ``"build"``.

Every model file in that folder is a *shipped model*, named by its file stem: ``spotfree classify braking LOG``
takes it by that name (:func:`shipped_model_path`), and :func:`trained_on` says what it learnt from.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from spotfree.model import DictionaryModel

DEFAULT_MODEL = "braking.npz"
"""File name of the default model in the package folder ``spotfree/ride/models``."""


def default_model_path() -> Path:
    """Where the installed package holds the default model file."""
    return Path(str(files("spotfree.ride") / "models" / DEFAULT_MODEL))


def default_model() -> DictionaryModel:
    """The default model, read from :func:`default_model_path`."""
    return DictionaryModel.load(default_model_path())


def shipped_models() -> dict[str, Path]:
    """The shipped model files (``spotfree/ride/models/*.npz``) by name, their file stem."""
    folder = default_model_path().parent
    return {path.stem: path for path in sorted(folder.glob("*.npz"))}


def shipped_model_path(name: str) -> Path | None:
    """The file of the shipped model ``name`` (``braking``), or None when no shipped model has that name."""
    return shipped_models().get(name)


def trained_on(model: DictionaryModel) -> str:
    """What ``model`` was trained on, in one phrase from its summary: each training recording's source and declared
    classes, and, for a model built by a script (its summary's ``"build"``), the script, the preset and the seed."""
    recordings = model.summary.get("recordings") or []
    said = "; ".join(f"{rec['source']} ({','.join(rec['classes'])})" for rec in recordings[:5])
    more = f" and {len(recordings) - 5} more" if len(recordings) > 5 else ""
    build = model.summary.get("build") or {}
    how = (f" by {build['script']}" + (f" with --preset {build['preset']}" if build.get("preset") else "")
           + (f", seed {build['seed']}" if "seed" in build else "")) if build.get("script") else ""
    return f"trained on {len(recordings)} recording(s): {said}{more}{how}" if recordings else "training data not recorded"
