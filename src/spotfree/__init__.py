"""spotfree: ride assistance for two-wheeled mobility robots by spotting-free continuous signal classification.

The public names are importable from here; the heavy ones (numba, scikit-learn) load on first use, so that the
command line starts quickly.
"""

from importlib import import_module

from spotfree.errors import InputError, NotBuiltError, SpotfreeError
from spotfree.io.recording import Gap, Recording

__version__ = "0.1.0"

_LAZY = {
    "BlockSparseClassifier": "spotfree.classify.bsrc",
    "CRCClassifier": "spotfree.classify.crc",
    "FeatureStream": "spotfree.signal.features",
    "KernelCRCClassifier": "spotfree.classify.kcrc",
    "OrderedSubspaceClustering": "spotfree.cluster.osc",
    "PaperRecipe": "spotfree.paper_recipe",
    "RideAssistant": "spotfree.ride.assistant",
    "RideClassifier": "spotfree.classify.stream",
    "RideStore": "spotfree.ride.store",
    "SRCClassifier": "spotfree.classify.src",
    "SetSupervisedLearner": "spotfree.learner",
    "preset_learner": "spotfree.presets",
    "SparseSubspaceClustering": "spotfree.cluster.osc",
    "classify_recording": "spotfree.classify.batch",
    "decision_latency": "spotfree.classify.latency",
    "make_classifier": "spotfree.classify",
    "read_recording": "spotfree.io",
    "ride_features": "spotfree.signal.features",
    "simulate_scenario": "spotfree.sim.scenarios",
}

__all__ = ["Gap", "InputError", "NotBuiltError", "Recording", "SpotfreeError", "__version__", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'spotfree' has no attribute {name!r}")
