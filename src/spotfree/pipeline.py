"""From a log on disk to the feature Recording that windows, training and classification consume."""

from __future__ import annotations

from spotfree.errors import InputError
from spotfree.io import read_recording
from spotfree.io.recording import GPS_CHANNELS, Recording
from spotfree.limits import check_recording
from spotfree.signal.body import body_features
from spotfree.signal.features import DERIVED_CHANNELS, FEATURE_CHANNELS, ride_features


FEATURES = ("ride", "body")


def feature_recording(spec: str | Recording, orientation: str = "default", rate: float = 20.0,
                      features: str = "ride") -> Recording:
    """Read ``spec`` (``PATH`` or ``PATH@K``, or a Recording already read); a raw IMU log becomes, by ``features``,
    the ride features with the derived channels (:data:`~spotfree.signal.features.DERIVED_CHANNELS`: a phone on a
    vehicle's handlebar) or the body channels (:mod:`spotfree.signal.body`: a phone in a pocket, a watch; a log of
    acceleration alone gives the acceleration's); any other log is used as is, but a GPS-only log (a track: nothing
    for a model to learn from but where and how fast) is refused, naming the motion sensors it lacks.

    ``meta['features']`` says which: ``"ride"`` (with ``meta['orientation']``), ``"body"`` or ``"channels"``.
    A log outside what a phone records is refused (:func:`spotfree.limits.check_recording`).
    """
    if features not in FEATURES:
        raise InputError(f"--features {features!r}: use one of {', '.join(FEATURES)}")
    rec = spec if isinstance(spec, Recording) else read_recording(spec, rate=rate)
    check_recording(rec)
    if rec.has_accelerometer and features == "body":
        return body_features(rec)
    if not rec.has_imu and set(rec.names) <= set(GPS_CHANNELS):
        rec.require_imu("a model's features; `spotfree features` gives a track's GPS features")
    if rec.has_imu:
        feats = ride_features(rec, orientation=orientation, derived=True)
        feats.meta.update(raw_meta=dict(rec.meta))
        return feats
    rec.meta.update(features="channels")
    return rec


__all__ = ["DERIVED_CHANNELS", "FEATURE_CHANNELS", "FEATURES", "feature_recording"]
