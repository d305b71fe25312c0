"""One line saying what machine a benchmark ran on, for the results files: processor, cores, load at the start
(these machines are shared), Python and the versions of the packages that matter to the benchmark."""

from __future__ import annotations

import os
import platform
from importlib.metadata import PackageNotFoundError, version


def describe(packages: tuple[str, ...] = ("numpy", "scipy", "scikit-learn")) -> str:
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.machine())
    found = []
    for p in packages:
        try:
            found.append(f"{p} {version(p)}")
        except PackageNotFoundError:
            found.append(f"{p} (not installed)")
    return (f"{cpu}, {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f} at the start (shared machine); "
            f"Python {platform.python_version()}, {', '.join(found)}")
