"""Run the commands shown in README.md and rewrite the outputs shown under them, so that none can go stale.

    python scripts/readme_outputs.py           rewrite README.md in place
    python scripts/readme_outputs.py --check   exit 1 (and name the blocks) when README.md is not current

A block of commands is marked in README.md by a comment line before its ```` ```bash ```` fence:

* ``<!-- run -->``: the commands are run and the ```` ```text ```` block that follows, closed by ``<!-- end -->``,
  is replaced by what they print (standard output and error, in order);
* ``<!-- check -->``: the commands are run, nothing is shown; they must succeed.

All blocks run in document order in one temporary folder (a block may use the files of the blocks before it), with
``spotfree`` being this checkout's command-line interface (``python -m spotfree.cli`` on ``src/``) and a terminal
width of :data:`COLUMNS`. Before the first block, :func:`phone_exports` writes the stand-in phone logs that the
README's own-log quickstart names (the blocks cannot ship a rider's recordings): Sensor Logger exports of simulated
rides. A command that fails stops the script with its output and exit status 2. The script and its commands run with
numpy's AVX-512 kernels off (:mod:`spotfree.reproducible`), so that the outputs are the same on every machine.
"""

from __future__ import annotations

import argparse
import os
import re
import stat
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "src"))

from spotfree.reproducible import rerun_pinned  # noqa: E402

README = ROOT / "README.md"
COLUMNS = 100
"""Terminal width the commands see (tables printed by the CLI wrap to it)."""

BLOCK = re.compile(r"<!-- (?P<kind>run|check) -->\n```bash\n(?P<commands>.*?)```\n"
                   r"(?:<!-- output -->\n```text\n(?P<output>.*?)```\n<!-- end -->\n)?", re.S)
"""A marked block: its kind, its commands and, for ``run``, the output shown under it."""

PHONE_LOGS = {"normal-stops.zip": ("normal-braking", 1), "sudden-stops.zip": ("sudden-braking", 2),
              "commute.zip": ("sudden-braking", 3)}
"""Stand-in phone logs of the own-log quickstart: file -> (simulator scenario, seed); each is the scenario's first
ride."""


def phone_exports(folder: Path) -> None:
    """Write :data:`PHONE_LOGS` into ``folder`` as Android Sensor Logger zips (``TotalAcceleration.csv`` and
    ``Gyroscope.csv`` with ``time`` in epoch ns, ``seconds_elapsed`` and the axes z, y, x; ``Location.csv`` at the
    GPS fixes), as the app exports a recording."""
    import numpy as np
    import pandas as pd

    from spotfree.sim.scenarios import simulate_scenario

    epoch_ns = 1_767_225_600 * 10**9
    for name, (scenario, seed) in PHONE_LOGS.items():
        ride = simulate_scenario(scenario, repeats=1, seed=seed)
        elapsed = ride.time - ride.time[0]
        stamps = epoch_ns + np.round(elapsed * 1e9).astype(np.int64)
        tables = {sensor: pd.DataFrame({"time": stamps, "seconds_elapsed": elapsed,
                                        **{axis: ride.channels[prefix + axis] for axis in "zyx"}})
                  for sensor, prefix in (("TotalAcceleration", "a"), ("Gyroscope", "g"))}
        fixes = np.isfinite(ride.channels["lat"])
        tables["Location"] = pd.DataFrame({"time": stamps[fixes], "seconds_elapsed": elapsed[fixes],
                                           **{column: ride.channels[channel][fixes] for column, channel in
                                              (("latitude", "lat"), ("longitude", "lon"), ("speed", "speed"))}})
        with zipfile.ZipFile(folder / name, "w") as archive:
            for sensor, table in tables.items():
                archive.writestr(f"{sensor}.csv", table.to_csv(index=False))


def shim(folder: Path) -> Path:
    """A ``bin`` folder in ``folder`` whose ``spotfree`` runs this checkout's command-line interface."""
    bin_dir = folder / "bin"
    bin_dir.mkdir()
    command = bin_dir / "spotfree"
    command.write_text(f'#!/bin/sh\nexec "{sys.executable}" -m spotfree.cli "$@"\n')
    command.chmod(command.stat().st_mode | stat.S_IXUSR)
    return bin_dir


def run_block(commands: str, folder: Path, env: dict) -> str:
    """What ``commands`` print (each line without trailing blanks), run by ``bash -e`` in ``folder``; exits with
    status 2 when one fails."""
    done = subprocess.run(["bash", "-e", "-c", commands], cwd=folder, env=env, stdout=subprocess.PIPE,
                          stderr=subprocess.STDOUT, text=True)
    if done.returncode != 0:
        print(f"README block failed (exit {done.returncode}):\n{commands}\n{done.stdout}", file=sys.stderr)
        sys.exit(2)
    return "".join(line.rstrip() + "\n" for line in done.stdout.splitlines())


def regenerate(text: str) -> tuple[str, list[str]]:
    """README ``text`` with every ``run`` block's output rewritten, and the first lines of the blocks that changed."""
    changed, pieces, last = [], [], 0
    with tempfile.TemporaryDirectory(prefix="readme-") as tmp:
        folder = Path(tmp) / "work"
        folder.mkdir()
        env = {**os.environ, "PATH": f"{shim(Path(tmp))}{os.pathsep}{os.environ['PATH']}",
               "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT / "src"), os.environ.get("PYTHONPATH")])),
               "COLUMNS": str(COLUMNS), "TERM": "dumb", "NO_COLOR": "1", "PYTHONUNBUFFERED": "1"}
        phone_exports(folder)
        for block in BLOCK.finditer(text):
            output = run_block(block["commands"], folder, env)
            if block["kind"] == "check":
                continue
            if block["output"] != output:
                changed.append(block["commands"].splitlines()[0])
            start, end = block.span("output") if block["output"] is not None else (block.end(), block.end())
            shown = output if block["output"] is not None else f"<!-- output -->\n```text\n{output}```\n<!-- end -->\n"
            pieces += [text[last:start], shown]
            last = end
    pieces.append(text[last:])
    return "".join(pieces), changed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", action="store_true", help="only say whether README.md is current")
    args = parser.parse_args()
    text = README.read_text()
    if not BLOCK.search(text):
        print(f"{README} has no <!-- run --> or <!-- check --> block", file=sys.stderr)
        sys.exit(2)
    new, changed = regenerate(text)
    if args.check:
        if changed:
            print("README.md outputs are stale under: " + "; ".join(changed) +
                  "\nrun: python scripts/readme_outputs.py", file=sys.stderr)
            sys.exit(1)
        print("README.md outputs are current")
        return
    README.write_text(new)
    print(f"README.md: {len(changed)} output block(s) rewritten" + (f" ({'; '.join(changed)})" if changed else ""))


if __name__ == "__main__":
    rerun_pinned()  # the same outputs on every machine (spotfree.reproducible)
    main()
