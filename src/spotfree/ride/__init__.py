"""The ride assistant application: the ride store, the assistant's warnings and trip figures, and exports.

The live service needs the ``serve`` extra (``pip install 'spotfree[serve]'``); the store alone, either extra.
"""

from spotfree.ride.assistant import RideAssistant, RideWarning, Status
from spotfree.ride.export import export_csv, export_geojson, export_gpx, export_ride, ride_geojson, ride_recording
from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS, Event, Ride
from spotfree.ride.store import AccessError, NotFoundError, RideStore

__all__ = [
    "AccessError", "Event", "FEATURE_COLUMNS", "NotFoundError", "Ride", "RideAssistant", "RideStore", "RideWarning",
    "SAMPLE_COLUMNS", "Status", "export_csv", "export_geojson", "export_gpx", "export_ride", "ride_geojson",
    "ride_recording",
]
