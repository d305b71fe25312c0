"""The ride assistant application: the ride store, the assistant's warnings and trip figures, and exports."""

from spotfree.ride.records import FEATURE_COLUMNS, SAMPLE_COLUMNS, Event, Ride
from spotfree.ride.store import AccessError, NotFoundError, RideStore

__all__ = ["AccessError", "Event", "FEATURE_COLUMNS", "NotFoundError", "Ride", "RideStore", "SAMPLE_COLUMNS"]
