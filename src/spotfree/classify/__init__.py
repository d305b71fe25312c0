"""Classifiers over a dictionary of class representatives: CRC_RLS (and, for comparison, SRC and B_SRC), and two
amplitude-aware rules that are not in the paper: kernel CRC_RLS and the nearest-columns rule.

All share :class:`~spotfree.classify.base.ResidualClassifier`: ``fit(atoms, labels)``, ``decision_function``
(class residuals, smaller is better), ``predict``, ``predict_one`` (one window, for streaming) and the rejection
option (label :data:`UNKNOWN`). ``METHODS`` maps the names the command line accepts (``--method``) to the estimator
classes; ``make_classifier(method, **params)`` builds one by name.
"""

from spotfree.classify.base import UNKNOWN, ResidualClassifier
from spotfree.classify.bsrc import BlockSparseClassifier
from spotfree.classify.crc import CRCClassifier
from spotfree.classify.kcrc import KernelCRCClassifier
from spotfree.classify.neighbours import NearestColumnsClassifier
from spotfree.classify.src import SRCClassifier
from spotfree.errors import InputError

METHODS = {"crc": CRCClassifier, "kcrc": KernelCRCClassifier, "src": SRCClassifier,
           "bsrc": BlockSparseClassifier, "nearest": NearestColumnsClassifier}

DEFAULT_METHOD = "kcrc"
"""The method used when none is named: kernel CRC_RLS, amplitude-aware, at a few times the cost per window of CRC_RLS
(``benchmarks/crc_speed.py`` times both)."""


def make_classifier(method: str, **params):
    """An unfitted classifier of ``method`` (one of ``METHODS``) with the given parameters."""
    try:
        cls = METHODS[method]
    except (KeyError, TypeError):
        raise InputError(
            f"classifier method {method!r} is unknown: use one of {', '.join(sorted(METHODS))}"
        ) from None
    return cls(**params)


__all__ = ["DEFAULT_METHOD", "METHODS", "UNKNOWN", "BlockSparseClassifier", "CRCClassifier", "KernelCRCClassifier",
           "NearestColumnsClassifier", "ResidualClassifier", "SRCClassifier", "make_classifier"]
