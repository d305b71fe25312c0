"""Scripts that write shipped files run again in place with numpy's AVX-512 kernels off (spotfree.reproducible)."""

import os
import subprocess
import sys

from spotfree.reproducible import AVX512, SETTING, VARIABLE, pinned_environment

SCRIPT = """
import os
from spotfree.reproducible import rerun_pinned
print("started", flush=True)
rerun_pinned()
import numpy as np
umath = np._core._multiarray_umath
print(os.environ["{variable}"], [f for f in umath.__cpu_dispatch__ if f in {avx512!r} and umath.__cpu_features__[f]])
"""


def test_the_pinned_environment_switches_every_avx512_group_off_and_keeps_the_rest():
    env = pinned_environment({"PATH": "/bin", VARIABLE: "AVX2"})
    assert env["PATH"] == "/bin" and env[VARIABLE].split() == list(AVX512)


def test_a_script_started_without_the_pin_runs_again_with_it_and_numpy_uses_no_avx512_kernel(tmp_path):
    script = tmp_path / "script.py"
    script.write_text(SCRIPT.format(variable=VARIABLE, avx512=AVX512))
    env = {k: v for k, v in os.environ.items() if k != VARIABLE}
    proc = subprocess.run([sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert lines[:2] == ["started", "started"]  # the second start is the script again, in the pinned environment
    assert lines[2] == f"{SETTING} []"
