"""Tilt of real phone exports: spotfree's reading against the phone's own gravity sensor.

    python benchmarks/export_tilt.py EXPORT [EXPORT ...] [--orientation default]

For each Sensor Logger export (folder or zip) that holds Gravity.csv, reads the export as ``spotfree`` does
(:func:`spotfree.io.read_recording`), runs the attitude filter on the device-frame accelerometer and gyroscope, and
compares its vertical with the one of the phone's gravity sensor (Gravity.csv, in Android's sign convention: iOS
exports without "Standardise Units & Frames" are negated, as the reader does), both on the reader's grid. Prints
one markdown row per export: format, duration, median and 95th-percentile angle (degrees) over the samples after
the first 10 s, or why the export was refused (the one-line message a user would see), and writes the table to
``benchmarks/results/export_tilt.md`` (command, machine, date). No data are stored here: the exports are the user's.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from machine import results_file
from spotfree.errors import SpotfreeError
from spotfree.io import checks, describe, read_recording
from spotfree.io.recording import ACC_CHANNELS, GYRO_CHANNELS
from spotfree.signal.frame import gravity_direction
from spotfree.signal.orientation import estimate_attitude

SKIP = 10.0
"""Seconds left out at the start (the filters' start-up)."""


def phone_gravity(path: Path, rec) -> np.ndarray | None:
    """The phone's gravity direction ``(n, 3)`` (unit, device frame, up) on ``rec``'s grid, or None."""
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("exports", nargs="+", type=Path)
    parser.add_argument("--orientation", default="default")
    args = parser.parse_args()
    with results_file("export_tilt", "Tilt of real phone exports against the phone's gravity sensor"):
        tilt_table(args.exports, args.orientation)


def tilt_table(exports: list[Path], orientation: str) -> None:
    """Print one row per export (module docstring)."""
    print("| export | read as | median (deg) | p95 (deg) |")
    print("|---|---|---:|---:|")
    for path in exports:
        try:
            rec = read_recording(path)
            rec.require_imu("the tilt")
        except SpotfreeError as exc:
            print(f"| {path.name} | refused: {exc} | | |")
            continue
        truth = phone_gravity(path, rec) if rec.meta.get("format", "").startswith("Sensor Logger") else None
        if truth is None:
            print(f"| {path.name} | {describe(rec)} | no gravity sensor to compare | |")
            continue
        angles = []
        for start, stop in rec.segments():
            rp = estimate_attitude(rec.array(ACC_CHANNELS)[start:stop], rec.array(GYRO_CHANNELS)[start:stop],
                                   rec.rate, orientation)
            up = gravity_direction(rp[:, 0], rp[:, 1])
            cos = np.sum(up * truth[start:stop], axis=1)
            keep = (rec.time[start:stop] - rec.time[start] >= SKIP) & np.isfinite(cos)
            angles.append(np.degrees(np.arccos(np.clip(cos[keep], -1.0, 1.0))))
        angle = np.concatenate(angles) if angles else np.array([])
        if not len(angle):
            print(f"| {path.name} | {describe(rec)} | too short | |")
            continue
        print(f"| {path.name} | {describe(rec)} | {np.median(angle):.2f} | {np.percentile(angle, 95):.2f} |")


if __name__ == "__main__":
    main()
