"""The README's shown outputs are what its commands print now (``scripts/readme_outputs.py --check`` runs every
marked block of commands in a temporary folder and compares)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_the_readme_shows_what_its_commands_print():
    run = subprocess.run([sys.executable, str(ROOT / "scripts" / "readme_outputs.py"), "--check"],
                         capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "current" in run.stdout
