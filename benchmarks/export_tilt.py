"""Real phone exports read as a user would, and the tilt against the phone's own gravity sensor.

    python benchmarks/export_tilt.py EXPORT [EXPORT ...] [--sources SOURCES.tsv] [--orientation default,vqf]
                                     [--skip 10]

For every export (folder, zip or file) it reads the export as ``spotfree`` does (:func:`spotfree.io.read_recording`)
and prints one markdown row: what was read (the ``read:`` line's format, sensors, native rates and duration) or
the one-line message a user would see when the ride features refuse it. For a Sensor Logger export that holds
Gravity.csv it also runs each attitude filter on the device-frame accelerometer and gyroscope and compares its
vertical with the one of the phone's gravity sensor (Gravity.csv, in Android's sign convention: iOS exports
without "Standardise Units & Frames" are negated, as the reader does), both on the reader's grid: median and
95th-percentile angle (degrees) over the samples from ``--skip`` seconds on (the filters' start-up is left out;
with exports shorter than that, the whole export is scored and the row says so).

``--sources`` names where each export comes from: a tab-separated file with the columns ``export`` (the folder or
file name given), ``source`` (e.g. a repository and path) and ``note`` (e.g. how it was cut); the table cites it.
The table is written to ``benchmarks/results/export_tilt.md`` (command, machine, date). No data are stored here:
the exports are other people's.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from machine import results_file
from spotfree.errors import SpotfreeError
from spotfree.io import checks, describe, read_recording
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS
from spotfree.signal.frame import gravity_direction
from spotfree.signal.orientation import estimate_attitude

SKIP = 10.0
"""Seconds left out at the start by default (the filters' start-up)."""


def phone_gravity(path: Path, rec) -> np.ndarray | None:
    """The phone's gravity direction ``(n, 3)`` (unit, device frame, up) on ``rec``'s grid, or None."""
    if not rec.meta.get("format", "").startswith("Sensor Logger") or "start_epoch" not in rec.meta:
        return None
    with checks.Archive(path) as archive:
        member = archive.find("Gravity.csv")
        if member is None:
            return None
        table = checks.read_table(archive.read_text(member), archive.label(member))
    t = checks.numbers(table, "time", member) * 1e-9 - rec.meta["start_epoch"]
    values = np.column_stack([checks.numbers(table, axis, member) for axis in "xyz"])
    if rec.meta.get("ios_native"):  # CoreMotion's sign, as the reader converts Accelerometer + Gravity
        values = -values
    order = np.argsort(t)
    grid = np.column_stack([np.interp(rec.time, t[order], v[order], left=np.nan, right=np.nan) for v in values.T])
    return grid / np.linalg.norm(grid, axis=1, keepdims=True)


def tilt_angles(rec, truth: np.ndarray, orientation: str, skip: float) -> tuple[np.ndarray, bool]:
    """Angles (degrees) between the filter's vertical and ``truth`` over the gap-free segments, from ``skip`` s on
    in each; when no segment is that long, over every sample (second value True)."""
    angles, whole = [], []
    for start, stop in rec.segments():
        rp = estimate_attitude(rec.array(ACC_CHANNELS)[start:stop], rec.array(GYRO_CHANNELS)[start:stop],
                               rec.rate, orientation)
        up = gravity_direction(rp[:, 0], rp[:, 1])
        cos = np.sum(up * truth[start:stop], axis=1)
        angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
        late = rec.time[start:stop] - rec.time[start] >= skip
        angles.append(angle[late & np.isfinite(cos)])
        whole.append(angle[np.isfinite(cos)])
    scored = np.concatenate(angles) if angles else np.array([])
    if len(scored):
        return scored, False
    return (np.concatenate(whole) if whole else np.array([])), True


def read_sources(path: Path | None) -> dict[str, tuple[str, str]]:
    """``{export name: (source, note)}`` from a tab-separated file with columns export, source, note."""
    if path is None:
        return {}
    with open(path, newline="", encoding="utf-8") as stream:
        return {row["export"]: (row["source"], row.get("note") or "") for row in csv.DictReader(stream, delimiter="\t")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("exports", nargs="+", type=Path)
    parser.add_argument("--sources", type=Path, default=None)
    parser.add_argument("--orientation", default="default", help="comma-separated attitude filters to score")
    parser.add_argument("--skip", type=float, default=SKIP, help="seconds left out at the start of each segment")
    args = parser.parse_args()
    with results_file("export_tilt", "Real phone exports: read or refused, and the tilt against the phone's "
                                     "gravity sensor"):
        tilt_table(args.exports, args.orientation.split(","), args.skip, read_sources(args.sources))


def tilt_table(exports: list[Path], orientations: list[str], skip: float,
               sources: dict[str, tuple[str, str]]) -> None:
    """Print one row per export (module docstring)."""
    print(f"Tilt: angle between the filter's vertical and Gravity.csv's, degrees, median / 95th percentile, from "
          f"{skip:g} s into each gap-free segment (* = export shorter than that: every sample scored).\n")
    print("| export | source | read | " + " | ".join(f"tilt {o} (deg)" for o in orientations) + " |")
    print("|---|---|---|" + "---:|" * len(orientations))
    for path in exports:
        source, note = sources.get(path.name, ("", ""))
        cite = source + (f" ({note})" if note else "")
        rec = None
        try:
            rec = read_recording(path)
            rec.require_imu("the tilt")
        except SpotfreeError as exc:
            said = f"refused: {str(exc).split(': ', 1)[-1]}"
            status = said if rec is None else f"read: {_read_line(rec)}; {said}"
            print(f"| {path.name} | {cite} | {status} |" + " |" * len(orientations))
            continue
        truth = phone_gravity(path, rec)
        if truth is None:
            print(f"| {path.name} | {cite} | read: {_read_line(rec)}; no gravity sensor to compare |"
                  + " |" * len(orientations))
            continue
        cells = []
        for orientation in orientations:
            angle, whole = tilt_angles(rec, truth, orientation, skip)
            cells.append(f"{np.median(angle):.2f} / {np.percentile(angle, 95):.2f}{' *' if whole else ''}"
                         if len(angle) else "no overlap")
        print(f"| {path.name} | {cite} | read: {_read_line(rec)} | " + " | ".join(cells) + " |")


def _read_line(rec) -> str:
    """The ``read:`` line without the path."""
    return describe(rec).split(": ", 1)[1]

if __name__ == "__main__":
    main()
