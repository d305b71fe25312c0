"""Shared input helpers for the readers: files and archives, CSV dialects, numeric cells, time columns, units.

Every check raises :class:`~spotfree.errors.InputError` with one line that names the file, the column and the
fix; every safe repair appends one line to the ``repairs`` list it is given (it ends up in
``Recording.meta['repairs']``).
"""

from __future__ import annotations

import contextlib
import csv
import difflib
import gzip
import io
import os
import re
import secrets
import stat
import zipfile
import zlib
from pathlib import Path, PurePosixPath
from typing import Iterator

import numpy as np
import pandas as pd

from spotfree.errors import InputError
from spotfree.units import GRAVITY

MAX_FILL_RUN = 2
"""Longest run of missing samples (in a uniform file) that is filled by linear interpolation."""

MIN_RATE, MAX_RATE = 0.1, 10_000.0
"""Plausible sampling rates (Hz) of a time column in seconds; outside them the unit is wrong."""

MIN_MOTION_RATE = 2.0
"""Lowest plausible rate (Hz) of a phone's accelerometer or gyroscope."""

GZIP_MAGIC = b"\x1f\x8b"
"""First bytes of a gzip-compressed file."""
MAX_UNPACKED = 2 << 30
"""Most bytes of one file read whole: a log, a gzip-compressed log once uncompressed, a member of a zip export (2
GiB, a day of 100 Hz motion and GPS as CSV; a few kilobytes of gzip or zip can inflate to gigabytes)."""

G_RANGE = (0.7, 1.3)
"""A median specific-force magnitude in this range means the numbers are in g (about 1), not m/s^2 (about 9.81)."""


# ---------------------------------------------------------------- files and archives


class Archive:
    """The files of a folder or a zip archive, addressed by their path inside it ('/'-separated)."""

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        if self.path.is_dir():
            self._zip = None
            self.members = sorted(
                p.relative_to(self.path).as_posix() for p in self.path.rglob("*") if p.is_file()
            )
        else:
            stream = open_regular(self.path)
            try:
                self._zip = zipfile.ZipFile(stream)
                self.members = sorted(n for n in self._zip.namelist() if not n.endswith("/"))
            except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
                stream.close()
                raise InputError(f"{self.path}: not a readable zip archive ({exc}); export it again") from None

    def __enter__(self) -> "Archive":
        return self

    def __exit__(self, *exc) -> None:
        if self._zip is not None:
            stream = self._zip.fp
            self._zip.close()
            if stream is not None:
                stream.close()

    def find(self, name: str) -> str | None:
        """The member whose file name (any folder, any case) is ``name``, or None; the shallowest one wins."""
        hits = [m for m in self.members if PurePosixPath(m).name.lower() == name.lower()]
        return min(hits, key=lambda m: m.count("/")) if hits else None

    def label(self, member: str) -> str:
        """How a member is named in messages: ``archive.zip:Gyroscope.csv`` or ``folder/Gyroscope.csv``."""
        return f"{self.path}/{member}" if self._zip is None else f"{self.path}:{member}"

    def read_text(self, member: str) -> str:
        """A member decoded as UTF-8 text."""
        return decode(self._read(member), self.label(member))

    def head(self, member: str, size: int) -> str:
        """The first ``size`` bytes of a member as text (undecodable bytes replaced), to recognise its format."""
        return self._read(member, size).decode("utf-8-sig", errors="replace")

    def _read(self, member: str, size: int = -1) -> bytes:
        """The first ``size`` bytes of a member (all for -1), at most :data:`MAX_UNPACKED` (refused beyond, by
        the size a zip declares before anything is read)."""
        wanted = MAX_UNPACKED + 1 if size < 0 else min(size, MAX_UNPACKED + 1)
        try:
            if self._zip is None:
                with open_regular(self.path / member) as stream:
                    raw = stream.read(wanted)
            else:
                declared = self._zip.getinfo(member).file_size
                if size < 0 and declared > MAX_UNPACKED:
                    raise InputError(f"{self.label(member)}: holds {declared} bytes once uncompressed, more than "
                                     f"{_size(MAX_UNPACKED)}; split the log")
                with self._zip.open(member) as stream:
                    raw = stream.read(wanted)
        except InputError:
            raise
        except (zipfile.BadZipFile, OSError, EOFError, ValueError, NotImplementedError, RuntimeError) as exc:
            raise InputError(f"{self.label(member)}: cannot be read ({exc}); export it again") from None
        if len(raw) > MAX_UNPACKED:
            raise InputError(f"{self.label(member)}: holds more than {_size(MAX_UNPACKED)}; split the log")
        return raw


def decode(raw: bytes, source: str) -> str:
    """Bytes as UTF-8 text (a byte-order mark is dropped)."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{source}: not UTF-8 text (byte {exc.start}); save the file as UTF-8 CSV") from None


def _size(n: int) -> str:
    """Bytes in GiB, as the limits are said: ``2 GiB``."""
    return f"{n / 2 ** 30:g} GiB"


def open_regular(path: Path):
    """A regular file opened for reading in binary; a folder, device, FIFO or socket is refused (InputError) without
    waiting for a FIFO's writer or reading a device."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
    except FileNotFoundError:
        raise InputError(f"{path}: file not found; check the path") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror}); check the file") from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        what = "a folder" if stat.S_ISDIR(mode) else "not a regular file (a device, a FIFO or a socket)"
        raise InputError(f"{path}: is {what}; give a log file saved on disk")
    os.set_blocking(fd, True)
    return os.fdopen(fd, "rb")


def read_bytes(path: Path, size: int = -1) -> bytes:
    """The first ``size`` bytes of a regular file (all of it for -1); a gzip-compressed file (``log.csv.gz``) is read
    as the file it holds. At most :data:`MAX_UNPACKED` bytes either way. A missing, unreadable, truncated or overlong
    file, or one that is not a regular file (:func:`open_regular`), is an InputError."""
    wanted = MAX_UNPACKED + 1 if size < 0 else min(size, MAX_UNPACKED + 1)
    try:
        with open_regular(path) as stream:
            compressed = stream.read(len(GZIP_MAGIC)) == GZIP_MAGIC
            stream.seek(0)
            if not compressed:
                if size < 0 and os.fstat(stream.fileno()).st_size > MAX_UNPACKED:
                    raise InputError(f"{path}: is over {_size(MAX_UNPACKED)}; split the log")
                raw = stream.read(wanted)
            else:
                with gzip.GzipFile(fileobj=stream) as unpacked:
                    raw = unpacked.read(wanted)
        if len(raw) > MAX_UNPACKED:
            raise InputError(f"{path}: holds more than {_size(MAX_UNPACKED)} once uncompressed; split the log")
        return raw
    except FileNotFoundError:
        raise InputError(f"{path}: file not found; check the path") from None
    except (OSError, EOFError, zlib.error) as exc:
        raise InputError(f"{path}: cannot be read ({getattr(exc, 'strerror', None) or exc}); check the file") from None


def read_text(path: Path) -> str:
    """A file (:func:`read_bytes`) decoded as UTF-8 text."""
    return decode(read_bytes(path), str(path))


def base_suffix(path: Path) -> str:
    """The lower-case suffix that says a file's format, ``.gz`` looked through: ``.gpx`` for ``track.gpx.gz``."""
    path = Path(path)
    suffix = path.suffix.lower()
    return Path(path.stem).suffix.lower() if suffix == ".gz" else suffix


@contextlib.contextmanager
def replacing(path: str | Path, suffix: str = ".tmp") -> Iterator[Path]:
    """The path to write ``path`` through in the ``with`` block.

    For a regular file (new or existing): a new empty file beside it (its name ends in ``suffix``), which then
    replaces it at once, so ``path`` is never half written, or is removed when the block fails; it is created as any
    file the user writes, with mode ``0o666`` less the user's umask. A symbolic link is followed: the file it names
    is the one replaced (the link stays). A character device or a FIFO (``/dev/null``, ``/dev/stdout``, a named pipe
    read by another program) is written in place: ``path`` itself is yielded. A folder, a block device or a socket is
    refused (InputError, one line); an operating-system error while writing is an OSError naming ``path``."""
    path = Path(path)
    try:
        kind = os.stat(path).st_mode
    except FileNotFoundError:  # a new file, or a link to one
        kind = None
    except OSError as exc:
        raise InputError(f"{path}: cannot be written ({exc.strerror}); give another file name") from None
    if kind is not None and stat.S_ISDIR(kind):
        raise InputError(f"{path}: is a folder; give the name of a file to write in it")
    if kind is not None and not stat.S_ISREG(kind):
        if not (stat.S_ISCHR(kind) or stat.S_ISFIFO(kind)):
            raise InputError(f"{path}: is a block device or a socket, not a file; give the name of a file")
        with _one_line_errors(path):
            yield path
        return
    target = Path(os.path.realpath(path)) if path.is_symlink() else path
    folder = target.parent
    if not folder.is_dir():
        raise InputError(f"{path}: folder '{folder}' does not exist; create it first")
    while True:
        temporary = folder / f".{target.name}.{secrets.token_hex(6)}{suffix}"
        try:
            os.close(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            break
        except FileExistsError:
            continue
        except OSError as exc:
            raise InputError(f"{path}: cannot be written in '{folder}' ({exc.strerror}); give another folder") \
                from None
    try:
        with _one_line_errors(path):
            yield temporary
            os.replace(temporary, target)
    finally:
        temporary.unlink(missing_ok=True)


@contextlib.contextmanager
def _one_line_errors(path: Path) -> Iterator[None]:
    """An operating-system error in the block (a full disk, a closed pipe) raised again as an OSError of the same
    errno naming ``path``, not the temporary file, so that the command line says ``path: reason`` in one line."""
    try:
        yield
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None


def write_text(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` as UTF-8 through :func:`replacing`, so ``path`` is never half written."""
    with replacing(path) as temporary:
        temporary.write_text(text, encoding="utf-8", newline="")


# ---------------------------------------------------------------- CSV dialects and tables

_SEPARATORS = (",", "\t", ";")
_DECIMAL_COMMA = re.compile(r"(?:^|[\t;])\s*[-+]?\d+,\d")


def detect_dialect(text: str) -> tuple[str, str]:
    """``(separator, decimal mark)`` of CSV ``text``: comma, tab or semicolon; decimal point or comma.

    The separator is the candidate found most often in the header line (quoted header names are skipped, so a
    comma inside ``"Acceleration x (m/s^2)"`` does not count). A comma separator implies a decimal point;
    otherwise a comma between digits in the first data lines means a decimal comma (phyphox's tab/decimal comma
    and semicolon/decimal comma dialects).
    """
    lines = text.splitlines()
    header = lines[0] if lines else ""
    unquoted = re.sub(r'"[^"]*"', "", header)
    counts = {sep: unquoted.count(sep) for sep in _SEPARATORS}
    sep = max(_SEPARATORS, key=lambda s: counts[s])
    if counts[sep] == 0:
        sep = ","
    if sep == ",":
        return sep, "."
    body = "\n".join(lines[1:20])
    return sep, "," if any(_DECIMAL_COMMA.search(line) for line in body.splitlines()) else "."


def read_table(text: str, source: str, sep: str = ",", unique: bool = True) -> pd.DataFrame:
    """CSV ``text`` as a table of strings (empty cells are ''); with ``unique``, a repeated column name is refused.

    (Without ``unique``, pandas numbers repeats: ``Time (s)``, ``Time (s).1``, ...)
    """
    if not text.strip():
        raise InputError(f"{source}: the file is empty; export the recording again")
    try:
        header = next(csv.reader([text.lstrip().splitlines()[0]], delimiter=sep))
    except csv.Error as exc:
        raise InputError(f"{source}: unreadable header line ({exc}); the first line must name the columns") from None
    repeated = [name for i, name in enumerate(header) if name in header[:i]]
    if unique and repeated:
        raise InputError(f"{source}: column {repeated[0]!r} appears twice; rename or drop one of them")
    try:
        table = pd.read_csv(
            io.StringIO(text), sep=sep, dtype=str, keep_default_na=False, na_filter=False,
            skip_blank_lines=True, engine="c",
        )
    except (pd.errors.ParserError, pd.errors.EmptyDataError, ValueError) as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{source}: not a readable CSV table ({first}); check the separator and quoting") from None
    if table.shape[1] == 0:
        raise InputError(f"{source}: no columns; the first line must name the columns")
    if any("\n" in str(c) or "\r" in str(c) for c in table.columns):
        raise InputError(f"{source}: a quote in the header line is never closed; fix the first line")
    return table


def numbers(table: pd.DataFrame, column: str, source: str, decimal: str = ".") -> np.ndarray:
    """Column ``column`` of a string table as floats; '' and NaN are missing values, anything else must parse.

    A cell that is not a finite number raises an InputError naming its line in the file (header on line 1).
    """
    cells = table[column].astype(str).str.strip()
    if decimal == ",":
        cells = cells.str.replace(",", ".", regex=False)
    filled = cells.where(cells != "", "nan")
    try:  # exact parsing: pandas 3's to_numeric may round the last bit of a double
        values = filled.to_numpy(dtype=float)
    except ValueError:  # a cell is not a number: find it below
        values = pd.to_numeric(filled, errors="coerce").to_numpy(dtype=float)
    bad = np.isinf(values) | (np.isnan(values) & ~cells.str.lower().isin(["", "nan"]).to_numpy())
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise InputError(
            f"{source}: column {column!r}, line {row + 2}: {table[column].iloc[row]!r} is not a finite number; "
            f"fix the cell or delete the line"
        )
    return values


def suggest(name: str, known: list[str] | tuple[str, ...], cutoff: float = 0.75) -> str | None:
    """The known column name closest to ``name`` (difflib ratio at least ``cutoff``), or None."""
    hits = difflib.get_close_matches(name.strip().lower(), list(known), n=1, cutoff=cutoff)
    return hits[0] if hits else None


# ---------------------------------------------------------------- time columns


def check_time(t: np.ndarray, source: str, column: str, first_line: int = 2, min_rate: float = MIN_RATE) -> None:
    """Every time cell is a finite number and the median step is a plausible sampling period in seconds.

    A median step outside ``1/MAX_RATE .. 1/min_rate`` s means the column is in ms, us or ns, or is not a
    time (``min_rate`` is :data:`MIN_MOTION_RATE` for accelerometer and gyroscope times).
    """
    missing = ~np.isfinite(t)
    if missing.any():
        row = int(np.flatnonzero(missing)[0])
        raise InputError(f"{source}: column {column!r}, line {row + first_line}: empty time cell; fill or delete it")
    if len(t) < 2:
        raise InputError(f"{source}: only {len(t)} sample(s); a recording needs at least two rows")
    steps = np.abs(np.diff(t))
    step = float(np.median(steps[steps > 0])) if (steps > 0).any() else 0.0
    if step == 0.0:
        raise InputError(f"{source}: column {column!r} never changes; it must hold the sample times in seconds")
    rate = 1.0 / step
    if rate < min_rate or rate > MAX_RATE:
        unit = {1e-3: "milliseconds", 1e-6: "microseconds", 1e-9: "nanoseconds"}
        guess = next((u for f, u in unit.items() if min_rate <= rate / f <= MAX_RATE), None)
        hint = f"it looks like {guess}; convert it to seconds" if guess else "it must be in seconds"
        raise InputError(
            f"{source}: column {column!r} has a median step of {step:g}, i.e. {rate:g} Hz; {hint}"
        )


def order_and_deduplicate(
    t: np.ndarray, values: np.ndarray, source: str, column: str, repairs: list[str], first_line: int = 2
) -> np.ndarray:
    """Indices of the rows to keep, in time order, when only a few rows are out of order or repeat a time.

    ``t`` (n,) are the sample times and ``values`` (n, k) the numbers of each row. A row is out of order when it
    is earlier than some row above it; at most ``max(1, n // 100)`` such rows are sorted (stable) and as many
    rows repeating an earlier timestamp with other values are dropped (the first is kept; exact duplicates are
    always dropped). More than that raises an InputError naming the first offending line.
    """
    n = len(t)
    limit = max(1, n // 100)
    order = np.arange(n)
    late = np.flatnonzero(t[1:] < np.maximum.accumulate(t)[:-1]) + 1  # rows earlier than a row above them
    if len(late):
        if len(late) > limit:
            row = int(late[0])
            raise InputError(
                f"{source}: column {column!r} goes back in time at line {row + first_line} "
                f"({t[row]:g} after {t[row - 1]:g}), {len(late)} rows out of order; the times must increase "
                f"(several rides in one file need an 'experiment' column)"
            )
        order = np.argsort(t, kind="stable")
        repairs.append(f"{source}: sorted {len(late)} out-of-order row(s) by {column!r}")
    ts, vs = t[order], values[order]
    repeat = np.r_[False, ts[1:] == ts[:-1]]
    if repeat.any():
        equal = (vs[1:] == vs[:-1]) | (np.isnan(vs[1:]) & np.isnan(vs[:-1]))
        same = repeat & np.r_[False, np.all(equal, axis=1)]
        differing = int(repeat.sum() - same.sum())
        if differing > limit:
            row = int(order[np.flatnonzero(repeat & ~same)[0]])
            raise InputError(
                f"{source}: column {column!r} repeats the time {t[row]:g} with different values at line "
                f"{row + first_line} and {differing - 1} more; each row needs its own time"
            )
        kinds = [f"{int(same.sum())} duplicated row(s)"] if same.any() else []
        kinds += [f"{differing} row(s) repeating an earlier time with other values"] if differing else []
        repairs.append(f"{source}: dropped {' and '.join(kinds)} in {column!r} (kept the first)")
        order = order[~repeat]
    return order


# ---------------------------------------------------------------- missing samples and units


def true_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` index ranges of the True runs of a boolean vector."""
    edges = np.diff(np.r_[0, np.asarray(mask).astype(np.int8), 0])
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def fill_short_runs(values: np.ndarray, name: str, source: str, repairs: list[str]) -> np.ndarray:
    """A uniformly sampled channel with interior NaN runs of at most :data:`MAX_FILL_RUN` samples filled linearly.

    Longer runs and runs touching either end stay NaN (they are gaps, reported by the caller).
    """
    values = np.array(values, dtype=float)
    missing = np.isnan(values)
    short = [(a, b) for a, b in true_runs(missing) if b - a <= MAX_FILL_RUN and a > 0 and b < len(values)]
    if short:
        index = np.arange(len(values))
        fill = np.concatenate([index[a:b] for a, b in short])
        values[fill] = np.interp(fill, index[~missing], values[~missing])
        repairs.append(
            f"{source}: interpolated {len(fill)} missing sample(s) of {name!r} in {len(short)} run(s) "
            f"of at most {MAX_FILL_RUN}"
        )
    return values


def check_acceleration_units(acc: np.ndarray, source: str, columns: str) -> None:
    """Specific force ``(n, 3)`` (device frame, gravity included) must be in m/s^2, not g.

    The median norm of a phone's specific force is close to g = 9.81 m/s^2; a median in
    :data:`G_RANGE` means the numbers are in g. When their mean points out of the screen's back or the bottom edge
    (a phone screen down or upside down), they are most likely minus the specific force, as iOS reports its
    acceleration, and the factor said is -9.81.
    """
    norm = np.linalg.norm(acc, axis=1)
    norm = norm[np.isfinite(norm)]
    if len(norm) and G_RANGE[0] <= float(np.median(norm)) <= G_RANGE[1]:
        mean = np.nanmean(acc, axis=0) / np.linalg.norm(np.nanmean(acc, axis=0))
        flipped = max(-mean[1], -mean[2]) > 0.7  # "up" out of the screen's back or the bottom edge
        raise InputError(
            f"{source}: columns {columns} have a median magnitude of {float(np.median(norm)):.3f}, i.e. they are "
            f"in g; " + (f"multiply them by {-GRAVITY} to get m/s^2 (they read minus the specific force, as iOS's "
                         f"acceleration does; by {GRAVITY} if the phone lay screen down or top edge down)"
                         if flipped else f"multiply them by {GRAVITY} to get m/s^2")
        )
