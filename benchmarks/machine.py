"""What machine a benchmark ran on, and its results file.

:func:`describe` gives one line: processor, cores, load at the start (these machines are shared), Python and the
versions of the packages that matter to the benchmark. :func:`results_file` copies what a benchmark prints into
``benchmarks/results/<name>.md`` under a header of the command, the machine and the date."""

from __future__ import annotations

import contextlib
import io
import os
import platform
import shlex
import sys
from datetime import datetime, timezone
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"
"""Folder of the current results files, one per benchmark (``BENCHMARKS.md`` indexes them)."""
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_CORETYPE")
"""Environment variables that change how many threads the numeric libraries use, or which kernels; named in the
machine line when set."""


def describe(packages: tuple[str, ...] = ("numpy", "scipy", "scikit-learn")) -> str:
    """One line: processor, cores, load average now, Python, the versions of ``packages`` and the
    :data:`THREAD_VARIABLES` that are set."""
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.machine())
    found = []
    for p in packages:
        try:
            found.append(f"{p} {version(p)}")
        except PackageNotFoundError:
            found.append(f"{p} (not installed)")
    threads = [f"{name}={os.environ[name]}" for name in THREAD_VARIABLES if name in os.environ]
    return (f"{cpu}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start (shared machine); "
            f"Python {platform.python_version()}, {', '.join(found)}" + (f"; {', '.join(threads)}" if threads else ""))


class _Tee(io.TextIOBase):
    """A text stream that writes to every one of ``streams``."""

    def __init__(self, *streams):
        self.streams = streams

    def write(self, text: str) -> int:
        for s in self.streams:
            s.write(text)
        return len(text)

    def flush(self) -> None:
        for s in self.streams:
            s.flush()


@contextlib.contextmanager
def results_file(name: str, title: str, packages: tuple[str, ...] = ("numpy", "scipy", "scikit-learn"),
                 preformatted: bool = False):
    """Print as usual inside the block, and write ``benchmarks/results/<name>.md``: ``# title``, the command (as run,
    from the repository root), the machine (:func:`describe` of ``packages``, taken at the start), the date, then
    everything printed (in a code block when ``preformatted``: output that is not Markdown). The file is written only
    when the block ends without an exception, so a failed run leaves the last results in place."""
    started = datetime.now(timezone.utc)
    machine = describe(packages)
    printed = io.StringIO()
    with contextlib.redirect_stdout(_Tee(sys.stdout, printed)):
        yield
    body = printed.getvalue().strip("\n")
    if preformatted:
        body = f"```\n{body}\n```"
    command = shlex.join(["python", f"benchmarks/{Path(sys.argv[0]).name}", *sys.argv[1:]])
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{name}.md").write_text(f"# {title}\n\n- command: `{command}`\n- machine: {machine}\n"
                                        f"- date: {started:%Y-%m-%d %H:%M} UTC\n\n{body}\n")
