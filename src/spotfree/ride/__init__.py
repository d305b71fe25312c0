"""The ride assistant application: the ride store, the assistant's warnings and trip figures, and exports.

The live service needs the ``serve`` extra (``pip install 'spotfree[serve]'``); the store alone, either extra. The
names below are imported when first used, so that the assistant (``spotfree.ride.assistant``) needs neither.
"""

from importlib import import_module

_LAZY = {
    "RideAssistant": "spotfree.ride.assistant", "RideWarning": "spotfree.ride.assistant",
    "Status": "spotfree.ride.assistant",
    "export_csv": "spotfree.ride.export", "export_geojson": "spotfree.ride.export",
    "export_gpx": "spotfree.ride.export", "export_ride": "spotfree.ride.export",
    "ride_geojson": "spotfree.ride.export", "ride_recording": "spotfree.ride.export",
    "FEATURE_COLUMNS": "spotfree.ride.records", "SAMPLE_COLUMNS": "spotfree.ride.records",
    "Event": "spotfree.ride.records", "Ride": "spotfree.ride.records",
    "AccessError": "spotfree.ride.store", "NotFoundError": "spotfree.ride.store", "RideStore": "spotfree.ride.store",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'spotfree.ride' has no attribute {name!r}")
