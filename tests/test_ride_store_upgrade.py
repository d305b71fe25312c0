"""A ride store written before some feature channels existed is opened, gains them, and loses nothing."""

import sqlite3

import numpy as np

from ride_fixtures import batch
from spotfree.ride.records import FEATURE_COLUMNS
from spotfree.ride.store import RideStore


def test_older_store_gains_new_feature_columns_and_keeps_its_rows(tmp_path):
    path = tmp_path / "old.db"
    newer = FEATURE_COLUMNS[-2:]
    with RideStore(path) as store:
        _, token = store.register_device("phone")
        ride = store.start_ride(token, "segway-i2", "rider-7")
        store.append_samples(token, ride, batch(0.0, 10), features={"pitch": np.linspace(0, 0.1, 10)})
    with sqlite3.connect(path) as db:  # as a spotfree without the newest channels wrote it
        for column in newer:
            db.execute(f"ALTER TABLE features DROP COLUMN {column}")
    with RideStore(path) as store:
        old = store.features(ride)
        np.testing.assert_array_equal(old["pitch"], np.linspace(0, 0.1, 10))
        assert all(np.isnan(old[c]).all() for c in newer)
        _, token = store.register_device("phone 2")
        again = store.start_ride(token, "segway-i2", "rider-7")
        store.append_samples(token, again, batch(0.0, 5), features={newer[0]: np.ones(5)})
        np.testing.assert_array_equal(store.features(again)[newer[0]], np.ones(5))
        assert len(store.samples(ride)["time"]) == 10
