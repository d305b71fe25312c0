"""Class sets from a table: which classes occur in each training recording, or in a time span of one.

A sets file declares the training recordings of ``spotfree train --sets`` in bulk, as the weak labels of sound event
detection do (one row per clip, its labels without times). It is a CSV (comma, tab or semicolon separated, UTF-8),
one row per training recording, with the columns

``recording``
    the log, ``PATH`` or ``PATH@K`` (experiment ``K`` of the file); a relative ``PATH`` is taken from the sets
    file's folder;
``classes``
    the classes that occur somewhere in it, separated by commas or semicolons (quote a cell that holds the file's
    separator);
``start``, ``end`` (optional)
    the span ``start <= t < end`` of the log, in seconds on its time axis (its ``time`` column, as ``spotfree
    classify`` writes it); an empty cell or a missing column: from the log's beginning, to its end.

A span cuts one long log into training recordings without writing files: a trip whose stretches each declare what
occurs in them. The log is read once however many rows name it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from spotfree.errors import InputError
from spotfree.io.checks import detect_dialect, numbers, read_table, read_text
from spotfree.io.recording import Recording

COLUMNS = ("recording", "classes", "start", "end")
"""The columns of a sets file (``start`` and ``end`` optional)."""


@dataclass(frozen=True)
class Declared:
    """One training recording and the classes declared for it: the log ``recording`` (``PATH`` or ``PATH@K``),
    or its span ``start <= t < end`` (seconds on its time axis; None: its beginning, its end)."""

    recording: str
    classes: tuple[str, ...]
    start: float | None = None
    end: float | None = None

    @property
    def name(self) -> str:
        """How summaries name it: the log, and its span when it has one, e.g. ``trip.csv[600-660 s]``."""
        if self.start is None and self.end is None:
            return self.recording
        start = "" if self.start is None else f"{self.start:g}"
        end = "" if self.end is None else f"{self.end:g}"
        return f"{self.recording}[{start}-{end} s]"

    def take(self, rec: Recording) -> Recording:
        """The span of ``rec`` (the log, or its features on the same time axis) named ``name``; the whole of
        ``rec`` without a span. An empty span or a span of a log that holds several experiments is an InputError."""
        if self.start is None and self.end is None:
            return rec
        if rec.experiment is not None and len(np.unique(rec.experiment)) > 1:
            raise InputError(f"{self.name}: {self.recording} holds {len(np.unique(rec.experiment))} experiments, so "
                             "a time span is ambiguous; name one as PATH@K")
        lo = -np.inf if self.start is None else self.start
        hi = np.inf if self.end is None else self.end
        rows = slice(int(np.searchsorted(rec.time, lo, side="left")), int(np.searchsorted(rec.time, hi, "left")))
        if rows.stop <= rows.start:
            raise InputError(f"{self.name}: no sample in this span; the log runs from {rec.time[0]:g} s to "
                             f"{rec.time[-1]:g} s")
        return replace(rec.take(rows), source=self.name)


def class_names(text: str, separators: str = ",;") -> tuple[str, ...]:
    """The class names of a class list (a sets file's ``classes`` cell; ``--experiment``'s after ``=``, separated by
    commas alone): split at any of ``separators``, stripped, each once, in order."""
    return tuple(dict.fromkeys(c.strip() for c in re.split(f"[{re.escape(separators)}]", text) if c.strip()))


def read_class_sets(path: str | Path) -> list[Declared]:
    """The rows of the sets file ``path`` (module docstring), in order; a missing column, an empty class set, a
    start or end that is not a number, or a span that ends before it starts is an InputError naming the line."""
    path = Path(path)
    source = str(path)
    text = read_text(path)
    if not text.strip():
        raise InputError(f"{source}: the file is empty; give a header line (recording,classes[,start,end]) and one row "
                         "per training recording")
    sep, decimal = detect_dialect(text)
    table = read_table(text, source, sep)
    table.columns = [str(c).strip().lower() for c in table.columns]
    missing = [c for c in COLUMNS[:2] if c not in table.columns]
    if missing:
        raise InputError(f"{source}: no column {', '.join(missing)}; a sets file has the columns recording, classes "
                         "and optionally start, end (seconds)")
    if table.empty:
        raise InputError(f"{source}: no row; give one row per training recording")
    bounds = {c: numbers(table, c, source, decimal) if c in table.columns else np.full(len(table), np.nan)
              for c in COLUMNS[2:]}
    rows = []
    for k, (recording, classes) in enumerate(zip(table["recording"], table["classes"])):
        line = k + 2
        recording = str(recording).strip()
        names = class_names(str(classes))
        if not recording:
            raise InputError(f"{source}: line {line}: no recording; give its PATH or PATH@K")
        if not names:
            raise InputError(f"{source}: line {line}: no class declared for {recording}; name the classes that occur "
                             "in it")
        start, end = (None if np.isnan(bounds[c][k]) else float(bounds[c][k]) for c in COLUMNS[2:])
        if start is not None and end is not None and end <= start:
            raise InputError(f"{source}: line {line}: the span ends at {end:g} s, not after its start {start:g} s; "
                             "give start < end")
        spec = recording if Path(recording).is_absolute() else str(path.parent / recording)
        rows.append(Declared(spec, names, start, end))
    return rows


__all__ = ["COLUMNS", "Declared", "class_names", "read_class_sets"]
