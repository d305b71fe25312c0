"""From a log on disk to the feature Recording that windows, training and classification consume."""

from __future__ import annotations

from spotfree.io import read_recording
from spotfree.io.recording import Recording
from spotfree.limits import check_recording
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS, ride_features


def feature_recording(spec: str, orientation: str = "default", rate: float = 20.0) -> Recording:
    """Read ``spec`` (``PATH`` or ``PATH@K``); a raw IMU log becomes the ride features with the derived channels
    (:data:`~spotfree.signal.features.DERIVED_CHANNELS`), any other log is used as is.

    A log outside what a phone records is refused (:func:`spotfree.limits.check_recording`).
    ``meta['features']`` says which: ``"ride"`` (with ``meta['orientation']``) or ``"channels"``.
    """
    rec = read_recording(spec, rate=rate)
    check_recording(rec)
    if rec.has_imu:
        feats = ride_features(rec, orientation=orientation, derived=True)
        feats.meta.update(raw_meta=dict(rec.meta))
        return feats
    rec.meta.update(features="channels")
    return rec


__all__ = ["DERIVED_CHANNELS", "FEATURE_CHANNELS", "feature_recording"]
