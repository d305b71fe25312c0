"""The same numbers on every x86-64 machine, for the files spotfree ships (its default model, the README's outputs).

numpy computes ``exp``, ``log`` and the trigonometric functions of float64 arrays with kernels of its own on a
processor with AVX-512 (Intel's SVML on ``AVX512_SKX``: numpy pull request 19478) and with the C library's or its AVX2
ones elsewhere, and the two round the last bit differently (numpy issue 22904: ``np.log`` differs on Intel servers
from Skylake on). The learner keeps its names in single precision, so that its names and columns do not depend on
those kernels (:mod:`spotfree.learner`), and kernel CRC_RLS groups the atoms in single precision to place its
landmarks (:mod:`spotfree.classify.kcrc`); the dictionary's values, features computed with those kernels, still
differ in their last bit, and so do the residuals computed from them, which can change the label of a window near a
tie.
``NPY_DISABLE_CPU_FEATURES`` (read by numpy when it is imported) switches those kernels off, so a process started with
:func:`pinned_environment` computes what a machine without AVX-512 does.
"""

from __future__ import annotations

import os
import sys

VARIABLE = "NPY_DISABLE_CPU_FEATURES"
AVX512 = ("AVX512F", "AVX512CD", "AVX512_KNL", "AVX512_KNM", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL", "AVX512_ICL",
          "AVX512_SPR", "X86_V4")
"""numpy's names of the AVX-512 feature groups it dispatches to: those of numpy 2.3 and before, and ``X86_V4`` (the
x86-64-v4 level, AVX-512), which numpy 2.4 dispatches to in their place beside ``AVX512_ICL`` and ``AVX512_SPR`` (a
name the processor or the numpy version lacks is ignored)."""
SETTING = " ".join(AVX512)
"""The value of :data:`VARIABLE` that switches them all off."""


def pinned_environment(env: dict[str, str] | None = None) -> dict[str, str]:
    """``env`` (default: this process's environment) with numpy's AVX-512 kernels switched off."""
    out = dict(os.environ if env is None else env)
    out[VARIABLE] = SETTING
    return out


def rerun_pinned() -> None:
    """Start this script again in place (``os.execve``, same interpreter and arguments) in
    :func:`pinned_environment`, unless it already runs in it; call it before any work, where the script runs as
    ``__main__`` (a module that imports the script must not restart)."""
    if os.environ.get(VARIABLE) != SETTING:
        os.execve(sys.executable, [sys.executable, *sys.argv], pinned_environment())
