"""Classifiers over a dictionary of class representatives: CRC_RLS (and, for comparison, SRC and B_SRC).

``METHODS`` maps the names the command line accepts (``--method``) to the estimator classes;
``make_classifier(method, **params)`` builds one by name.
"""

from spotfree.classify.crc import CRCClassifier
from spotfree.errors import InputError

METHODS = {"crc": CRCClassifier}


def make_classifier(method: str, **params):
    """An unfitted classifier of ``method`` (one of ``METHODS``) with the given parameters."""
    try:
        cls = METHODS[method]
    except (KeyError, TypeError):
        raise InputError(
            f"classifier method {method!r} is unknown: use one of {', '.join(sorted(METHODS))}"
        ) from None
    return cls(**params)


__all__ = ["METHODS", "CRCClassifier", "make_classifier"]
