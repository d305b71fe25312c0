"""The service's garbage collection: startup frozen, no automatic full collection, a full one on a timer."""

from __future__ import annotations

import gc
import threading

import pytest

from spotfree.ride import collector


@pytest.fixture
def restored_gc():
    threshold = gc.get_threshold()
    yield
    gc.set_threshold(*threshold)
    gc.unfreeze()


def test_settle_freezes_startup_stops_automatic_full_collections_and_collects_on_a_timer(restored_gc):
    full = threading.Event()

    def watch(phase, info):
        if phase == "stop" and info["generation"] == 2:
            full.set()

    thread = collector.settle(every=0.05)
    assert gc.get_freeze_count() > 0
    assert gc.get_threshold()[2] == collector.NEVER
    assert thread.daemon and thread.is_alive()
    gc.callbacks.append(watch)
    try:
        assert full.wait(10), "no full collection from the timer thread"
    finally:
        gc.callbacks.remove(watch)
        thread.stop()
    assert not thread.is_alive()
