"""The model ``spotfree serve`` uses when none is given: trained once on simulated rides, then cached.

Training set: the paper's protocol, as ``spotfree evaluate`` uses it, so the served model is the one its report
measures: experiment :data:`TRAINING_EXPERIMENT` of the simulator's :data:`SCENARIOS` files (seven experiments,
seed :data:`SEED`), ride features with the derived channels, each recording declaring its scenario's classes (no
sample is labelled), learnt by the ``braking`` preset (:func:`~spotfree.presets.preset_learner`). A few seconds; the file is written to
``$SPOTFREE_CACHE`` (default ``$XDG_CACHE_HOME/spotfree`` or ``~/.cache/spotfree``) under a name that carries the
spotfree version, the training recipe, the learner's parameters and a digest of the learner's code, so a change of
any of them trains afresh.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Callable

from spotfree.model import DictionaryModel

SCENARIOS = ("normal-braking", "sudden-braking")
"""Simulated scenarios the default model is trained on."""
REPEATS = 7
"""Experiments per simulated file (the paper's seven)."""
TRAINING_EXPERIMENT = 1
"""The experiment of each file trained on."""
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

    import spotfree.learner
    import spotfree.representation
    import spotfree.presets
    import spotfree.ride_prior
    from spotfree.presets import preset_learner

    code = hashlib.sha256(b"".join(Path(m.__file__).read_bytes()
                                   for m in (spotfree.learner, spotfree.representation, spotfree.ride_prior,
                                             spotfree.presets)))
    recipe = {"scenarios": SCENARIOS, "repeats": REPEATS, "experiment": TRAINING_EXPERIMENT, "seed": SEED,
              "version": release, "learner": repr(preset_learner("braking", seed=SEED)), "code": code.hexdigest()}
    return hashlib.sha256(json.dumps(recipe, sort_keys=True).encode()).hexdigest()[:12]


def train_default_model(progress: Callable[[str], None] | None = None) -> DictionaryModel:
    """Train the default model on simulated rides (see the module docstring)."""
    from spotfree.presets import preset_learner
    from spotfree.signal.features import ride_features
    from spotfree.sim.scenarios import CLASSES, simulate_scenario

    recordings = [ride_features(simulate_scenario(scenario, repeats=REPEATS, seed=SEED), derived=True)
                  .select_experiment(TRAINING_EXPERIMENT) for scenario in SCENARIOS]
    if progress:
        progress("learning the default model from class sets")
    return preset_learner("braking", seed=SEED).fit(recordings, [list(CLASSES[s]) for s in SCENARIOS]).model_


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
    return DictionaryModel.load(path)  # the file's copy, as every later call returns: the same digest
