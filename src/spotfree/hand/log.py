"""Hand-tracking logs: JSON lines of the tracking service's frames, read into a Recording on a uniform grid.

A log holds one JSON object per line, exactly as the service sends it (:mod:`spotfree.hand.frames`); the live
client (:mod:`spotfree.hand.live`) and the simulator write such files. Reading rules (every repair is listed in
``meta['repairs']``, every doubt in ``meta['warnings']``):

* a line that is not JSON is an error naming its line number, except an unfinished last line (a log cut while
  being written), which is dropped; blank lines, the version header and events are skipped;
* frames are grouped by ``session`` (one experiment each, contiguous in the file);
* a few frames out of timestamp order (at most 1 %) are sorted, frames repeating a timestamp are dropped (the
  first is kept); more of either is an error naming the first offending line;
* the hand of a frame is the one of the requested ``side`` (``"any"``: either) with the highest ``confidence``;
  a frame without one, or whose hand holds NaN or lacks a finger, is a missing sample;
* each session is put on a grid of ``rate`` Hz by :func:`~spotfree.io.resample.merge_streams`: an anti-aliasing
  low-pass (the service runs at about 110 frames per second), linear interpolation across holes of at most
  ``max_gap`` s, and longer holes left NaN and reported in ``Recording.gaps``. Extended flags become the fraction
  of the interpolation interval that the finger was extended;
* ground truth (``truth`` of simulated frames) goes to ``Recording.truth`` columns ``state``, ``label``,
  ``person`` and ``pace`` (empty where a frame lacks it), taken from the nearest frame.

Default grid: :data:`HAND_RATE` = 20 Hz, the framework's rate. Its anti-aliasing cut-off, 0.4 x 20 = 8 Hz, keeps
99.96 % of the velocity energy of a minimum-jerk movement as short as 0.3 s (the fastest posture change of the
simulator) and removes most physiological tremor (8-12 Hz), which carries no intent; docs/hand.md has the numbers.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from spotfree.errors import InputError
from spotfree.hand.frames import HAND_CHANNELS, Hand, HandFrame, frame_message, is_frame, parse_frame
from spotfree.io import checks
from spotfree.io.csvlog import _concatenate
from spotfree.io.recording import Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.limits import MAX_RIDE_SECONDS

HAND_RATE = 20.0
"""Hz: the default grid of a hand-tracking Recording."""

HAND_MAX_GAP = 0.1
"""s: longest stretch without a hand that is bridged by interpolation (two grid samples at 20 Hz); a posture
change takes 0.3 s or more, so no posture or gesture can hide in a bridged hole."""

SIDES = ("any", "left", "right")
TRUTH_KEYS = ("state", "label", "person", "pace")
"""Ground-truth columns of a simulated log."""


def read_hand_log(
    path: str | Path, rate: float = HAND_RATE, max_gap: float = HAND_MAX_GAP, side: str = "any"
) -> Recording:
    """A hand-tracking log (JSON lines) as a Recording of :data:`~spotfree.hand.frames.HAND_CHANNELS` (rules in
    the module docstring); ``rate`` Hz is the grid, ``max_gap`` s the longest hole bridged, ``side`` the hand."""
    source = str(path)
    frames, lines, repairs = parse_log(checks.read_text(Path(path)), source)
    return frames_to_recording(frames, rate, max_gap, side, source, lines=lines, repairs=repairs)


def parse_log(text: str, source: str) -> tuple[list[HandFrame], list[int], list[str]]:
    """The frames of a log's text, the line number of each (from 1), and the repairs made."""
    frames: list[HandFrame] = []
    lines: list[int] = []
    repairs: list[str] = []
    rows = text.split("\n")
    for number, line in enumerate(rows, 1):
        if not line.strip():
            continue
        try:
            message = json.loads(line)
        except (ValueError, RecursionError) as exc:  # also an integer of thousands of digits, deep nesting
            if not isinstance(exc, json.JSONDecodeError):
                reason = "nested too deeply" if isinstance(exc, RecursionError) else "a number too long"
                raise InputError(f"{source}, line {number}: not a frame of the tracking service ({reason})") from None
            if number == len(rows) and frames:
                repairs.append(f"{source}: dropped the unfinished last line {number} (the log was cut while written)")
                break
            raise InputError(
                f"{source}, line {number}: not valid JSON ({exc.msg}, column {exc.colno}); "
                f"each line must hold one frame of the tracking service as a JSON object"
            ) from None
        if isinstance(message, dict) and not is_frame(message):
            continue
        frames.append(parse_frame(message, f"{source}, line {number}"))
        lines.append(number)
    if not frames:
        raise InputError(f"{source}: no frames; a hand log holds one JSON frame of the tracking service per line")
    return frames, lines, repairs


def write_hand_log(frames: Iterable[HandFrame], path: str | Path) -> None:
    """Write frames as JSON lines (the service's schema, :func:`~spotfree.hand.frames.frame_message`); the file is
    replaced only once it is completely written."""
    text = "".join(json.dumps(frame_message(f), separators=(",", ":")) + "\n" for f in frames)
    checks.write_text(Path(path), text)


def frames_to_recording(
    frames: Sequence[HandFrame], rate: float = HAND_RATE, max_gap: float = HAND_MAX_GAP, side: str = "any",
    source: str = "<memory>", lines: Sequence[int] | None = None, repairs: list[str] | None = None,
) -> Recording:
    """Frames (e.g. from the live client) as a Recording: one experiment per session, each on its own grid.

    ``lines`` are the frames' line numbers for messages (default: their positions from 1); ``repairs`` collects
    the repairs made (it becomes ``meta['repairs']``).
    """
    if side not in SIDES:
        raise InputError(f"side {side!r}: use one of {', '.join(SIDES)}")
    if not frames:
        raise InputError(f"{source}: no frames")
    repairs = [] if repairs is None else repairs
    warnings: list[str] = []
    lines = np.arange(1, len(frames) + 1) if lines is None else np.asarray(lines)
    truth = any(f.truth is not None for f in frames)
    sessions = np.array([f.session for f in frames])
    numbered = set(sessions.tolist()) != {1}
    counts = {"frames": 0, "with_hand": 0}
    parts = []
    for number, rows in _sessions(sessions, lines, source):
        where = f"{source} (session {number})" if numbered else source
        part = _session([frames[i] for i in rows], lines[rows], rate, max_gap, side, truth, where, repairs,
                        warnings, counts)
        if numbered:
            part.experiment = np.full(len(part), number)
        parts.append(part)
    rec = _concatenate(parts, source)
    rec.meta = {
        "repairs": repairs, "warnings": warnings, "side": side,
        "native_rates": {p.source: p.meta["native_rates"]["hand"] for p in parts}, **counts,
    }
    return rec


def _sessions(sessions: np.ndarray, lines: np.ndarray, source: str) -> list[tuple[int, np.ndarray]]:
    """``(number, frame indices)`` of each session; a session's frames must be contiguous."""
    starts = np.r_[0, np.flatnonzero(np.diff(sessions) != 0) + 1]
    stops = np.r_[starts[1:], len(sessions)]
    seen: set[int] = set()
    for start in starts:
        if int(sessions[start]) in seen:
            raise InputError(
                f"{source}, line {lines[start]}: session {sessions[start]} starts again; keep the frames of each "
                f"session together"
            )
        seen.add(int(sessions[start]))
    return [(int(sessions[a]), np.arange(a, b)) for a, b in zip(starts, stops)]


def _session(
    frames: list[HandFrame], lines: np.ndarray, rate: float, max_gap: float, side: str, truth: bool, where: str,
    repairs: list[str], warnings: list[str], counts: dict[str, int],
) -> Recording:
    """One session's frames on a ``rate`` Hz grid, with ground truth from the nearest frame."""
    t = np.array([f.timestamp for f in frames], dtype=float) * 1e-6
    keep = _order(t, lines, where, repairs)
    frames, t = [frames[i] for i in keep], t[keep]
    values = np.full((len(frames), len(HAND_CHANNELS)), np.nan)
    present = 0
    for i, frame in enumerate(frames):
        hand = _select(frame.hands, side)
        if hand is not None:
            values[i] = hand.vector()
            present += 1
    usable = np.all(np.isfinite(values), axis=1)
    if present > usable.sum():
        repairs.append(
            f"{where}: {present - int(usable.sum())} frame(s) whose hand lacks a finger or holds NaN treated as "
            f"frames without a hand"
        )
    if usable.sum() < 2:
        raise InputError(
            f"{where}: {int(usable.sum())} frame(s) with a usable {'' if side == 'any' else side + ' '}hand; a "
            f"recording needs at least two (was a hand over the sensor?)"
        )
    first, last = t[usable][[0, -1]]
    if t[-1] - t[0] > MAX_RIDE_SECONDS:
        raise InputError(f"{where}: its frames span {t[-1] - t[0]:.4g} s, more than {MAX_RIDE_SECONDS:g} s; check "
                         "the timestamps (microseconds) or split the log")
    if first - t[0] > max_gap or t[-1] - last > max_gap:
        warnings.append(
            f"{where}: no hand in the first {first - t[0]:.2f} s and the last {t[-1] - last:.2f} s; the recording "
            f"spans the frames with a hand"
        )
    rec = merge_streams({"hand": Stream(t, values, HAND_CHANNELS)}, rate=rate, max_gap=max_gap, source=where)
    if truth:
        nearest = np.clip(np.rint(np.interp(rec.time, t, np.arange(len(t)))).astype(int), 0, len(t) - 1)
        rec.truth = {k: np.array([str((frames[i].truth or {}).get(k, "")) for i in nearest]) for k in TRUTH_KEYS}
    counts["frames"] += len(frames)
    counts["with_hand"] += int(usable.sum())
    return rec


def _order(t: np.ndarray, lines: np.ndarray, where: str, repairs: list[str]) -> np.ndarray:
    """Indices of the frames to keep, in time order: at most 1 % out of order are sorted and at most 1 % repeating
    a timestamp are dropped (the first is kept); more raises an InputError naming the first offending line."""
    limit = max(1, len(t) // 100)
    late = np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1]) + 1
    if len(late) > limit:
        row = late[0]
        raise InputError(
            f"{where}, line {lines[row]}: timestamp {t[row] * 1e6:.0f} us comes after {t[row - 1] * 1e6:.0f} us, "
            f"{len(late)} frames out of order; keep the frames in the order the service sent them (separate "
            f"recordings need separate 'session' numbers)"
        )
    order = np.argsort(t, kind="stable")
    if len(late):
        repairs.append(f"{where}: sorted {len(late)} frame(s) that were out of timestamp order")
    ts = t[order]
    repeat = np.r_[False, ts[1:] == ts[:-1]]
    if repeat.sum() > limit:
        row = order[np.flatnonzero(repeat)[0]]
        raise InputError(
            f"{where}, line {lines[row]}: timestamp {t[row] * 1e6:.0f} us repeats, and so do {int(repeat.sum()) - 1} "
            f"more frames; each frame needs its own timestamp"
        )
    if repeat.any():
        repairs.append(f"{where}: dropped {int(repeat.sum())} frame(s) repeating an earlier timestamp (kept the first)")
    return order[~repeat]


def _select(hands: tuple[Hand, ...], side: str) -> Hand | None:
    """The hand of ``side`` (any side for ``"any"``) with the highest confidence, or None."""
    candidates = [h for h in hands if side == "any" or h.side == side]
    return max(candidates, key=lambda h: h.confidence) if candidates else None
