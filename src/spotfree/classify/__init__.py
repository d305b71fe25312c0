"""Classifiers over a dictionary of class representatives: CRC_RLS (and, for comparison, SRC and B_SRC)."""

from spotfree.classify.crc import CRCClassifier

__all__ = ["CRCClassifier"]
