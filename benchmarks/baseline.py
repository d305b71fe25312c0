"""Run a benchmark script against spotfree as it was at another git revision, so that a change is measured against
its predecessor in the same run (same machine, same minute, same data).

The revision's ``src/`` is exported with ``git archive`` into a temporary folder that leads ``PYTHONPATH`` of a child
process running the script; the script must only use what both versions have, and print its figures as JSON on its
last line of output.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def run_at_revision(revision: str, script: str | Path, args: list[str]) -> dict:
    """The JSON that ``script`` prints last when run with ``args`` on spotfree at ``revision``."""
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", f"{revision}^{{commit}}"],
                            capture_output=True, text=True)
    if commit.returncode != 0:
        raise SystemExit(f"--baseline {revision}: not a commit of {ROOT}; give a revision such as HEAD~2 or a hash")
    with tempfile.TemporaryDirectory() as folder:
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit.stdout.strip(), "src"],
                                 capture_output=True, check=True).stdout
        tar_path = Path(folder) / "src.tar"
        tar_path.write_bytes(archive)
        with tarfile.open(tar_path) as tar:
            tar.extractall(folder, filter="data")
        path = os.pathsep.join([str(Path(folder) / "src"), os.environ.get("PYTHONPATH", "")])
        env = dict(os.environ, PYTHONPATH=path)
        child = subprocess.run([sys.executable, str(script), *args], capture_output=True, text=True, env=env)
    if child.returncode != 0:
        raise SystemExit(f"the benchmark at {revision} failed:\n{child.stderr[-2000:]}")
    return json.loads(child.stdout.strip().splitlines()[-1])
