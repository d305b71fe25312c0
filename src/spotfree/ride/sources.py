"""Demo and test inputs of ``spotfree serve``: a recorded log replayed, or the simulator ridden live, at real time.

Either one becomes a device of its own that streams its samples to the service in batches of
:data:`BATCH` samples, as a phone would, paced so that sample ``t`` is sent ``t / speed`` s after the start
(in process, so the devices' rate limit does not apply to a replay faster than real time).
"""

from __future__ import annotations

import asyncio
import math

import numpy as np

from spotfree.io.recording import Recording
from spotfree.ride.records import SAMPLE_COLUMNS
from spotfree.ride.service import RideService

BATCH = 5
"""Samples per batch (0.25 s at 20 Hz)."""


def recording_rows(rec: Recording) -> np.ndarray:
    """``(n, len(SAMPLE_COLUMNS))`` rows of ``rec`` (its first experiment), time from 0; no GPS is NaN."""
    part = rec.experiments()[0][1] if rec.experiment is not None else rec
    n = len(part.time)
    columns = [part.time - part.time[0]]
    columns += [part.channels.get(name, np.full(n, np.nan)) for name in SAMPLE_COLUMNS[1:]]
    return np.column_stack(columns)


async def ride_live(service: RideService, rows: np.ndarray, vehicle: str, speed: float = 1.0,
                    loop_forever: bool = False) -> None:
    """Stream ``rows`` (see :func:`recording_rows`) to ``service`` as one device, paced at ``speed`` times real
    time; with ``loop_forever`` a new ride starts after each one ends."""
    _, token = await asyncio.to_thread(service.register_device, vehicle)
    rows = rows[np.isfinite(rows[:, 1:7]).all(axis=1)]
    while True:
        ride_id = await asyncio.to_thread(service.start_ride, token, vehicle, vehicle)
        start = asyncio.get_running_loop().time()
        for k in range(0, len(rows), BATCH):
            batch = rows[k:k + BATCH]
            due = start + batch[-1, 0] / speed
            await asyncio.sleep(max(0.0, due - asyncio.get_running_loop().time()))
            samples = {name: [None if math.isnan(v) else float(v) for v in batch[:, j]]
                       for j, name in enumerate(SAMPLE_COLUMNS)}
            await asyncio.to_thread(service.ingest, token, ride_id, samples, check_rate=False)
        await asyncio.to_thread(service.end_ride, token, ride_id)
        if not loop_forever:
            return
