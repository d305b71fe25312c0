"""Readers and writers of sensor logs; every reader returns a :class:`~spotfree.io.recording.Recording`.

:func:`read_recording` is the single entry point: it accepts ``PATH`` or ``PATH@K`` (experiment ``K`` of the file)
and picks the reader from the path and, where the extension does not settle it, from the content:

* a ``.gpx`` file (or XML text) -> :func:`~spotfree.io.gpx.read_gpx`;
* a ``.json`` file (or text starting with ``[``) -> :func:`~spotfree.io.sensorlogger.read_sensorlogger`;
* a folder or zip -> Sensor Logger when it holds ``Metadata.csv`` or a CSV with a ``seconds_elapsed`` column,
  phyphox when it holds ``meta/`` or a CSV whose first column is ``"Time (s)"``;
* any other file is CSV text: phyphox when its first column is ``"Time (s)"``, the generic CSV otherwise.

A gzip-compressed file (``log.csv.gz``, ``track.gpx.gz``) is read as the file it holds.

A raw motion channel (``ax`` ... ``gz``) that holds one value throughout the recording (a sensor that did not
record, or an export that wrote zeros for it) is warned about in ``meta['warnings']``: a real sensor is never that
quiet, and a channel that never changes tells no class apart.
"""

from pathlib import Path

import numpy as np

from spotfree.errors import InputError
from spotfree.io.checks import Archive, base_suffix, read_bytes
from spotfree.io.csvlog import read_csv, write_csv
from spotfree.io.gpx import read_gpx, write_gpx
from spotfree.io.phyphox import is_phyphox_table, read_phyphox
from spotfree.io.recording import IMU_CHANNELS, Gap, Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.io.sensorlogger import is_sensorlogger_table, read_sensorlogger

__all__ = [
    "Gap", "Recording", "Stream", "describe", "detect_format", "merge_streams", "read_csv", "read_gpx", "read_phyphox",
    "read_recording", "read_sensorlogger", "split_spec", "write_csv", "write_gpx",
]

_SNIFF_BYTES = 4096


def read_recording(spec: str | Path, rate: float = 20.0, max_gap: float = 0.5) -> Recording:
    """The log named by ``spec`` (``PATH`` or ``PATH@K``) as a Recording; ``rate`` Hz is the grid for logs
    that are not uniform and ``max_gap`` (s) the longest hole that resampling bridges."""
    path, experiment = split_spec(spec)
    kind = detect_format(path)
    if kind == "gpx":
        rec = read_gpx(path, rate=rate)
    else:
        reader = {"csv": read_csv, "sensorlogger": read_sensorlogger, "phyphox": read_phyphox}[kind]
        rec = reader(path, rate=rate, max_gap=max_gap)
    rec = rec if experiment is None else rec.select_experiment(experiment)
    rec.meta.setdefault("warnings", []).extend(_constant_channels(rec))
    return rec


def _constant_channels(rec: Recording) -> list[str]:
    """A warning per raw motion channel of ``rec`` whose finite samples (at least two) all hold one value, up to
    the rounding that resampling adds (``1e-9`` of its size)."""
    warnings = []
    for name in (c for c in IMU_CHANNELS if c in rec.channels):
        values = rec.channels[name][np.isfinite(rec.channels[name])]
        if len(values) > 1 and np.ptp(values) <= 1e-9 * max(1.0, float(np.abs(values).max())):
            warnings.append(f"{rec.source}: {name} holds {np.median(values):g} throughout; check that its sensor "
                            "recorded (a channel that never changes tells no class apart)")
    return warnings


_SENSOR_CHANNELS = (("accelerometer", "ax"), ("gyroscope", "gx"), ("GPS", "lat"), ("GPS speed", "speed"))


def describe(rec: Recording) -> str:
    """One line on what was read: the format, the sensors, each sensor's native rate (Hz), the duration (s) and
    the gaps (count and total seconds)."""
    sensors = rec.meta.get("sensors") or [name for name, channel in _SENSOR_CHANNELS if channel in rec.channels]
    rates = {k: r for k, r in rec.meta.get("native_rates", {}).items() if np.isfinite(r)}
    native = (", ".join(f"{k} {r:.3g} Hz" for k, r in rates.items()) if rates else f"{rec.rate:g} Hz")
    gaps = f"{len(rec.gaps)} gap(s), {sum(g.duration for g in rec.gaps):.1f} s in all" if rec.gaps else "no gaps"
    return (f"{rec.source}: {rec.meta.get('format', 'CSV log')}; sensors: {', '.join(sensors) or 'none'}; "
            f"native rate: {native}; {rec.duration:.1f} s on a {rec.rate:g} Hz grid; {gaps}")


def detect_format(path: str | Path) -> str:
    """``'csv'``, ``'sensorlogger'``, ``'phyphox'`` or ``'gpx'`` for the file or folder at ``path``."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: file not found; check the path")
    if path.is_dir() or path.suffix.lower() == ".zip":
        return _archive_format(path)
    suffix = base_suffix(path)
    if suffix in (".gpx", ".json"):
        return "gpx" if suffix == ".gpx" else "sensorlogger"
    head = read_bytes(path, _SNIFF_BYTES)
    if head.startswith(b"PK\x03\x04"):
        return _archive_format(path)
    text = head.decode("utf-8-sig", errors="replace").lstrip()
    if text.startswith("<"):
        return "gpx"
    if text.startswith("["):
        return "sensorlogger"
    if is_phyphox_table(text):
        return "phyphox"
    if is_sensorlogger_table(text):
        raise InputError(
            f"{path}: one sensor file of a Sensor Logger export; give the whole export (its folder or zip)"
        )
    return "csv"


def split_spec(spec: str | Path) -> tuple[Path, int | None]:
    """``PATH@K`` -> ``(PATH, K)``; a path that exists as written is never split."""
    text = str(spec)
    if Path(text).exists() or "@" not in text:
        return Path(text), None
    head, tail = text.rsplit("@", 1)
    if not tail.strip().isdigit():
        raise InputError(f"{text}: '@{tail}' must be an experiment number, as in ride.csv@2")
    return Path(head), int(tail)


def _archive_format(path: Path) -> str:
    """Sensor Logger or phyphox, from the files in a folder or zip."""
    with Archive(path) as archive:
        if archive.find("Metadata.csv") is not None:
            return "sensorlogger"
        if any(m.lower().startswith("meta/") or "/meta/" in m.lower() for m in archive.members):
            return "phyphox"
        for member in (m for m in archive.members if m.lower().endswith(".csv")):
            head = archive.head(member, _SNIFF_BYTES)
            if is_sensorlogger_table(head):
                return "sensorlogger"
            if is_phyphox_table(head):
                return "phyphox"
    raise InputError(
        f"{path}: holds neither a Sensor Logger export (Metadata.csv, Gyroscope.csv, ...) nor a phyphox export "
        f"(Accelerometer.csv with \"Time (s)\", meta/); give the export as the app wrote it"
    )
