"""Exports of a stored ride: the CSV and GPX read back with spotfree's own readers, GeoJSON per RFC 7946."""

from __future__ import annotations

import json

import numpy as np
import pytest
from ride_fixtures import batch

from spotfree.errors import InputError
from spotfree.io import read_csv, read_gpx
from spotfree.ride.export import export_csv, export_geojson, export_gpx, export_ride, ride_geojson, ride_recording
from spotfree.ride.records import Event
from spotfree.ride.store import RideStore

STARTED = 1_760_000_000.0


@pytest.fixture
def recorded(tmp_path):
    """A stored 6 s ride at 20 Hz with fixes every second, labels of two models and two events."""
    store = RideStore(tmp_path / "rides.db", synchronous="normal")
    _, token = store.register_device("phone")
    ride = store.start_ride(token, "segway", "rider-1", model="m1", started=STARTED)
    samples = batch(0.0, 120)
    labels = np.where(samples["time"] >= 3.0, "sudden-braking", "cruising").astype(object)
    labels[:10] = None
    store.append_samples(token, ride, samples, labels={"m1": list(labels), "m2": ["x"] * 120})
    store.add_event(token, ride, Event("sudden-braking", 3.0, 4.0, "peak 5 m/s^2"))
    store.add_event(token, ride, Event("lateral", 3.5, 3.6))
    store.add_event(token, ride, Event("bump", 0.0, 0.0))
    yield store, ride, samples, labels
    store.close()


def test_csv_export_reads_back(recorded, tmp_path):
    store, ride, samples, labels = recorded
    export_csv(store, ride, tmp_path / "ride.csv")
    back = read_csv(tmp_path / "ride.csv")
    np.testing.assert_allclose(back.time, samples["time"], atol=1e-9)
    for name in ("ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed"):
        np.testing.assert_allclose(back.channels[name], samples[name], rtol=1e-9, atol=1e-12, err_msg=name)
    expected = np.where(labels == None, "", labels)  # noqa: E711
    assert list(np.char.replace(back.truth["label"].astype(str), "nan", "")) == list(expected)
    event = back.truth["event"].astype(str)
    assert event[60] == "sudden-braking" and event[70] == "sudden-braking;lateral" and event[0] == "bump"
    assert event[81] in ("", "nan")
    export_csv(store, ride, tmp_path / "m2.csv", model="m2")
    assert set(read_csv(tmp_path / "m2.csv").truth["label"].astype(str)) == {"x"}


def test_gpx_export_reads_back(recorded, tmp_path):
    store, ride, samples, _ = recorded
    export_gpx(store, ride, tmp_path / "ride.gpx")
    back = read_gpx(tmp_path / "ride.gpx")
    fix = np.isfinite(samples["lat"])
    got = np.isfinite(back.channels["lat"])
    np.testing.assert_allclose(back.channels["lat"][got], samples["lat"][fix], atol=1e-9)
    np.testing.assert_allclose(back.channels["lon"][got], samples["lon"][fix], atol=1e-9)
    np.testing.assert_allclose(back.channels["speed"][got], samples["speed"][fix])
    assert back.meta["start_epoch"] == pytest.approx(STARTED + samples["time"][fix][0], abs=1e-3)


def test_geojson_follows_rfc_7946(recorded, tmp_path):
    store, ride, samples, _ = recorded
    export_ride(store, ride, tmp_path / "ride.geojson")
    document = json.loads((tmp_path / "ride.geojson").read_text(encoding="utf-8"))
    assert document == json.loads(json.dumps(ride_geojson(store, ride)))
    assert document["type"] == "FeatureCollection" and "crs" not in document
    track, *events = document["features"]
    assert all(f["type"] == "Feature" and set(f) == {"type", "geometry", "properties"} for f in document["features"])
    assert track["geometry"]["type"] == "LineString"
    fix = np.isfinite(samples["lat"])
    np.testing.assert_array_equal(np.array(track["geometry"]["coordinates"]),
                                  np.column_stack([samples["lon"][fix], samples["lat"][fix]]))
    assert track["properties"]["ride_id"] == ride and track["properties"]["started"].startswith("2025-10-09T")
    assert [e["properties"]["kind"] for e in events] == ["bump", "sudden-braking", "lateral"]
    braking = events[1]
    assert braking["geometry"] == {"type": "Point", "coordinates": track["geometry"]["coordinates"][3]}
    assert braking["properties"] == {"kind": "sudden-braking", "start": 3.0, "end": 4.0, "detail": "peak 5 m/s^2"}


def test_rides_without_gps_or_samples(tmp_path):
    with RideStore(tmp_path / "rides.db", synchronous="normal") as store:
        _, token = store.register_device()
        empty = store.start_ride(token, "segway", "rider")
        with pytest.raises(InputError, match="no samples recorded"):
            export_csv(store, empty, tmp_path / "empty.csv")
        assert ride_geojson(store, empty)["features"][0]["geometry"] is None
        indoor = store.start_ride(token, "segway", "rider")
        samples = {k: v for k, v in batch(0.0, 40).items() if k not in ("lat", "lon", "speed")}
        store.append_samples(token, indoor, samples)
        store.add_event(token, indoor, Event("sudden-braking", 1.0, 1.5))
        document = ride_geojson(store, indoor)
        assert [f["geometry"] for f in document["features"]] == [None, None]
        with pytest.raises(InputError, match="hold no fix|no fix"):
            export_gpx(store, indoor, tmp_path / "indoor.gpx")
        assert set(ride_recording(store, indoor).truth["label"]) == {""}
        with pytest.raises(InputError, match="no labels of model 'm9'"):
            export_csv(store, indoor, tmp_path / "indoor.csv", model="m9")
        with pytest.raises(InputError, match="unknown export format"):
            export_ride(store, indoor, tmp_path / "ride.kml")


def test_several_models_without_the_rides_own_need_a_choice(recorded, tmp_path):
    store, _, samples, _ = recorded
    _, token = store.register_device()
    ride = store.start_ride(token, "segway", "rider")
    store.append_samples(token, ride, batch(0.0, 5), labels={"a": ["p"] * 5, "b": ["q"] * 5})
    with pytest.raises(InputError, match="several models"):
        export_csv(store, ride, tmp_path / "x.csv")
    assert list(ride_recording(store, ride, model="b").truth["label"]) == ["q"] * 5
