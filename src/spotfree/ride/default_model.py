"""The model ``spotfree serve`` and ``spotfree fleet process`` use when given none: spotfree's braking model
(cruising, normal and sudden braking), shipped with the package as the model file ``models/braking.npz``
(:mod:`spotfree.model`) and read, never trained, at start.

``scripts/build_default_model.py`` builds the file from simulated rides with the ``braking`` preset and records
its recipe, every parameter of the learner included, in the model's summary under ``"build"``.
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
