"""Fleet scale: a simulated fleet, rides into the ride store, distributed processing, statistics by group.

Needs the ``fleet`` extra (``pip install 'spotfree[fleet]'``): Dask, Parquet through PyArrow, DuckDB.
"""

from spotfree.fleet.engine import ProcessReport, process_fleet
from spotfree.fleet.generator import Fleet, generate_fleet
from spotfree.fleet.ingest import IngestReport, LogEntry, ingest_logs, ingest_store, read_manifest

__all__ = ["Fleet", "IngestReport", "LogEntry", "ProcessReport", "generate_fleet", "ingest_logs", "ingest_store",
           "process_fleet", "read_manifest"]
