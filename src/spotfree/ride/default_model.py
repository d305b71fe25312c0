"""The model ``spotfree serve`` uses when none is given: trained once on simulated rides, then cached.

Training set: :data:`TRAINING_RIDES` experiments of each braking scenario of the simulator (seed
:data:`SEED`), ride features with the derived channels, each recording declaring its scenario's classes
(no sample is labelled), :class:`~spotfree.training.TrainingConfig` defaults. About a minute on one core; the
file is written to ``$SPOTFREE_CACHE`` (default ``$XDG_CACHE_HOME/spotfree`` or ``~/.cache/spotfree``) under a
name that carries the spotfree version and the training recipe, so a new version trains afresh.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Callable

from spotfree.model import DictionaryModel

SCENARIOS = ("sudden-braking", "normal-braking", "cruising")
"""Simulated scenarios the default model is trained on."""
TRAINING_RIDES = 3
"""Experiments per scenario."""
SEED = 0


def cache_dir() -> Path:
    """Where the default model is kept (see the module docstring)."""
    if os.environ.get("SPOTFREE_CACHE"):
        return Path(os.environ["SPOTFREE_CACHE"])
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "spotfree"


def _recipe_key() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        release = version("spotfree")
    except PackageNotFoundError:
        release = "0"
    recipe = {"scenarios": SCENARIOS, "rides": TRAINING_RIDES, "seed": SEED, "version": release}
    return hashlib.sha256(json.dumps(recipe, sort_keys=True).encode()).hexdigest()[:12]


def train_default_model(progress: Callable[[str], None] | None = None) -> DictionaryModel:
    """Train the default model on simulated rides (see the module docstring)."""
    from spotfree.signal.features import ride_features
    from spotfree.sim.scenarios import CLASSES, simulate_scenario
    from spotfree.training import TrainingExperiment, train

    experiments = []
    for scenario in SCENARIOS:
        feats = ride_features(simulate_scenario(scenario, repeats=TRAINING_RIDES, seed=SEED), derived=True)
        experiments += [TrainingExperiment(part, list(CLASSES[scenario])) for _, part in feats.experiments()]
    return train(experiments, progress=progress).model


def default_model(progress: Callable[[str], None] | None = None) -> DictionaryModel:
    """The cached default model, trained and written to :func:`cache_dir` on first use."""
    path = cache_dir() / f"default-model-{_recipe_key()}.npz"
    if path.exists():
        return DictionaryModel.load(path)
    if progress:
        progress(f"training the default model on simulated rides (once; cached in {path})")
    model = train_default_model(progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    model.save(path)
    return model
