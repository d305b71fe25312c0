"""Garbage collection in a long-running ride service: no full collection in the middle of the traffic.

CPython's cyclic collector stops the interpreter for a full (generation-2) collection in proportion to the
objects alive; under many phones such pauses, every few seconds, set the tail of the batch-to-acknowledgement
latency (``benchmarks/serve_load.py`` measures it). So, once the service is built:

* everything alive is collected once and frozen (:func:`gc.freeze`: modules, the model, compiled kernels are
  never scanned again);
* automatic full collections are switched off (the young generations are still collected as usual, which frees
  the per-batch garbage);
* a daemon thread runs a full collection every :data:`FULL_COLLECTION_SECONDS`, so that reference cycles which
  outlived the young generations (an ended ride's objects, say) are still freed: one pause every
  :data:`FULL_COLLECTION_SECONDS` instead of every few seconds.
"""

from __future__ import annotations

import gc
import threading

FULL_COLLECTION_SECONDS = 600.0
"""Seconds between the full collections of :func:`settle`'s thread."""
NEVER = 2**31 - 1
"""A generation-2 threshold that the collector never reaches."""


def settle(every: float = FULL_COLLECTION_SECONDS) -> "FullCollections":
    """Collect and freeze what is alive, stop automatic full collections and start the thread that runs one every
    ``every`` s (returned, started; a daemon, it ends with the process unless stopped)."""
    gc.collect()
    gc.freeze()
    young, middle, _ = gc.get_threshold()
    gc.set_threshold(young, middle, NEVER)
    thread = FullCollections(every)
    thread.start()
    return thread


class FullCollections(threading.Thread):
    """A daemon thread that runs a full collection every ``every`` s until :meth:`stop`."""

    def __init__(self, every: float):
        super().__init__(name="spotfree-gc", daemon=True)
        self.every = every
        self._stopping = threading.Event()

    def run(self) -> None:
        while not self._stopping.wait(self.every):
            gc.collect()

    def stop(self) -> None:
        self._stopping.set()
        self.join()
