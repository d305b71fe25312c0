"""The light core: reading, features, training, classification, the simulator and the evaluation need none of the
server's or the cluster's libraries; ``serve`` and ``fleet`` without their extra exit 2 with one line naming it."""

import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import spotfree

SERVER_AND_CLUSTER = ("fastapi", "starlette", "uvicorn", "websockets", "cryptography", "orjson", "dask",
                      "distributed", "pyarrow", "duckdb")

# Runs its arguments as ``spotfree ARGS`` (or, with ``--import``, imports the named modules) in a Python where the
# server's and the cluster's libraries cannot be imported, as after ``pip install spotfree``.
WITHOUT_EXTRAS = textwrap.dedent(f"""
    import importlib
    import sys

    class Missing:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in {SERVER_AND_CLUSTER!r}:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
            return None

    sys.meta_path.insert(0, Missing())
    if sys.argv[1] == "--import":
        for name in sys.argv[2:]:
            importlib.import_module(name)
    else:
        from spotfree.cli import app
        app(sys.argv[1:], prog_name="spotfree")
""")

# What needs an extra: the live service and the store (serve), the fleet (fleet), the hand-tracking live client.
NEEDS_AN_EXTRA = ("spotfree.ride", "spotfree.fleet", "spotfree.hand.live")


def _spotfree(*argv: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", WITHOUT_EXTRAS, *argv], capture_output=True, text=True, cwd=cwd,
                          timeout=600)


def test_the_blocker_does_block(tmp_path):
    proc = _spotfree("--import", "fastapi", cwd=tmp_path)
    assert proc.returncode == 1 and "No module named 'fastapi'" in proc.stderr


def test_every_core_module_imports_without_the_extras(tmp_path):
    core = [m.name for m in pkgutil.walk_packages(spotfree.__path__, "spotfree.")
            if not m.name.startswith(NEEDS_AN_EXTRA)]
    assert "spotfree.classify.batch" in core and "spotfree.sim.scenarios" in core
    proc = _spotfree("--import", *core, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr


@pytest.mark.slow
def test_simulate_features_train_classify_run_without_the_extras(tmp_path):
    steps = [["simulate", "sudden-braking", "-o", "ride.csv", "--repeats", "1"],
             ["features", "ride.csv", "-o", "features.csv"],
             ["train", "-o", "m.npz", "--experiment", "ride.csv=cruising,normal-braking,sudden-braking"],
             ["classify", "m.npz", "ride.csv", "-o", "labels.csv"]]
    for argv in steps:
        proc = _spotfree(*argv, cwd=tmp_path)
        assert proc.returncode == 0, f"{argv}: {proc.stderr}"
    assert (tmp_path / "labels.csv").stat().st_size > 0


@pytest.mark.parametrize("argv, line", [
    (["serve"], "spotfree serve needs the server extra: pip install 'spotfree[serve]'"),
    (["fleet", "stats", "results", "-o", "stats"], "spotfree fleet needs the fleet extra: pip install 'spotfree[fleet]'"),
])
def test_serve_and_fleet_without_their_extra_exit_2_with_one_line(tmp_path, argv, line):
    proc = _spotfree(*argv, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"error: {line}"]
    assert list(tmp_path.iterdir()) == []
