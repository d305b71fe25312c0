"""Build spotfree's default ride model: the file ``spotfree serve`` and ``spotfree fleet process`` load when given
no model, shipped with the package as ``src/spotfree/ride/models/braking.npz``.

    python scripts/build_default_model.py              rewrite the shipped file
    python scripts/build_default_model.py -o OUT.npz   write it elsewhere (the test of the shipped file does)

Training set: the paper's protocol, as ``spotfree evaluate`` uses it: experiment :data:`TRAINING_EXPERIMENT` of the
simulator's :data:`SCENARIOS` files (:data:`REPEATS` experiments each, seed :data:`SEED`), ride features with the
derived channels, each recording declaring its scenario's classes (no sample is labelled), learnt by the
:data:`PRESET` preset (:func:`spotfree.presets.preset_learner`). The learner is deterministic, and the script runs
with numpy's AVX-512 kernels off (:mod:`spotfree.reproducible`), so the same code gives the same model on every
machine. The recipe and every parameter of the learner are recorded in the model's summary under
``"build"`` (:func:`recipe`).

Rerun it after any change to the learner, the preset, the ride features or the simulator:
``tests/test_default_model.py`` fails while the shipped file is not what this script builds.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from spotfree.reproducible import rerun_pinned  # noqa: E402
from spotfree.ride.default_model import default_model_path  # noqa: E402

PRESET = "braking"
"""The preset the default model is learnt by."""
SCENARIOS = ("normal-braking", "sudden-braking")
"""Simulated scenarios the default model is trained on."""
REPEATS = 7
"""Experiments per simulated file (the paper's seven)."""
TRAINING_EXPERIMENT = 1
"""The experiment of each file trained on."""
SEED = 0
"""Seed of the simulated rides and of the learner."""


def learner_parameters(learner) -> dict:
    """Every parameter of ``learner`` (``get_params(deep=True)``) as JSON values: tuples as lists, objects (the
    prior) by their ``repr``."""
    return json.loads(json.dumps(learner.get_params(deep=True), default=repr))


def recipe() -> dict:
    """What the default model is built from (module docstring): recorded in its summary under ``"build"``."""
    from spotfree.presets import preset_learner

    return {"script": "scripts/build_default_model.py", "preset": PRESET, "scenarios": list(SCENARIOS),
            "repeats": REPEATS, "experiment": TRAINING_EXPERIMENT, "seed": SEED,
            "learner": learner_parameters(preset_learner(PRESET, seed=SEED))}


def build():
    """The default model (a :class:`~spotfree.model.DictionaryModel`), trained on the simulated rides."""
    from spotfree.presets import preset_learner
    from spotfree.signal.features import ride_features
    from spotfree.sim.scenarios import CLASSES, simulate_scenario

    recordings = [ride_features(simulate_scenario(scenario, repeats=REPEATS, seed=SEED), derived=True)
                  .select_experiment(TRAINING_EXPERIMENT) for scenario in SCENARIOS]
    model = preset_learner(PRESET, seed=SEED).fit(recordings, [list(CLASSES[s]) for s in SCENARIOS]).model_
    model.summary["build"] = recipe()
    return model


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("-o", "--output", type=Path, default=default_model_path(),
                        help="model file to write (default: the shipped file)")
    output = parser.parse_args(argv).output
    model = build()
    model.save(output)
    columns = ", ".join(f"{c} {k}" for c, k in model.summary["columns_per_class"].items())
    print(f"wrote {output}: {model.dictionary.shape[1]} columns ({columns})")


if __name__ == "__main__":
    rerun_pinned()  # the same file on every machine (spotfree.reproducible)
    main()
