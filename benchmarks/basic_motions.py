"""Spotting-free learning on a second real data set: the smartwatch recordings of BasicMotions.

Data: BasicMotions of the UEA multivariate time-series classification archive (A. Bagnall, H. A. Dau, J. Lines,
M. Flynn, J. Large, A. Bostrom, P. Southam and E. Keogh, "The UEA multivariate time series classification archive,
2018", arXiv:1811.00075; data from a UEA student project, J. Clements,
https://www.timeseriesclassification.com/description.php?Dataset=BasicMotions), as shipped with ``aeon`` (the
``eval`` extra) and read with :func:`aeon.datasets.load_basic_motions`. Four students wore a smartwatch (3-axis
accelerometer and gyroscope, 10 Hz) for four activities (standing, walking, running, badminton), five sessions of
10 s each; the archive splits the 80 cases into 40 for training and 40 for the test.

Protocol (issue 31, the protocol of ``real_har.py`` on other recordings): the cases of each split are joined, in a
random order seeded by ``--order``, into recordings of :data:`CASES` cases (80 s), and put on the 20 Hz grid with their
body channels as ``real_har.py`` reads its data (:func:`real_har.on_grid`). The training recordings are cut into clips
of ``--clip`` seconds (each length a run of its own), each declared only with the set of classes in it; the whole test
recordings are the test. Scores and methods are those of ``real_har.py`` (:func:`real_har.compare`): balanced accuracy
away from changes (0.5 s) and strict; the learner once per seed of ``--seeds``, the paper's recipe, and the supervised
sliding 1-NN and MiniRocket peers given every sample's label of the same clips.

    python benchmarks/basic_motions.py [--clip 3 6 20] [--seeds 0 1 2] [--order 0] [--accelerometer] [--quick]

``--accelerometer``: every method on the acceleration's body channels alone, as ``real_har.py --accelerometer``.
Writes ``benchmarks/results/basic_motions.md`` (command, machine, date, tables), ``basic_motions_acc.md`` with
``--accelerometer``.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from machine import results_file
from real_har import clips, compare, on_grid, table
from spotfree.io.recording import Recording
from spotfree.signal.body import ACC_BODY_CHANNELS

CASES = 8
"""Cases of 10 s joined into one recording (80 s; each split's 40 cases make five)."""
SOURCE_RATE = 10.0
"""Sampling rate of the archive's cases, Hz."""
SPLITS = ("train", "test")


def recordings(split: str, order: int) -> list[Recording]:
    """The cases of ``split`` (``"train"`` or ``"test"``) in a random order seeded by ``order`` (and the split), joined
    :data:`CASES` at a time into recordings on the 20 Hz grid, each sample labelled with its case's class."""
    from aeon.datasets import load_basic_motions

    X, y = load_basic_motions(split=split.upper())  # (cases, 6 channels: accelerometer then gyroscope, samples)
    permuted = np.random.default_rng([order, SPLITS.index(split)]).permutation(len(y))
    out = []
    for k in range(0, len(permuted), CASES):
        part = permuted[k:k + CASES]
        values = np.concatenate([X[i].T for i in part])
        labels = np.repeat(np.asarray(y)[part], X.shape[2])
        t = np.arange(len(values)) / SOURCE_RATE
        out.append(on_grid(t, values, labels, f"BasicMotions {split} {k // CASES}"))
    return out


def run(clip: float, seeds: list[int], order: int, quick: bool, channels: tuple[str, ...] | None = None) -> list[dict]:
    tests = recordings("test", order)
    if quick:
        tests = tests[:2]
    train = [c for r in recordings("train", order) for c in clips(r, clip)]
    return compare(train, tests, seeds, channels, order=order, clip=clip)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--clip", type=float, nargs="+", default=[3.0, 6.0, 20.0], help="clip lengths, s")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the learner (the paper's "
                        "recipe: the first)")
    parser.add_argument("--order", type=int, nargs="+", default=[0], help="seeds of the order in which the cases "
                        "are joined into recordings")
    parser.add_argument("--quick", action="store_true", help="two test recordings (for a smoke run)")
    parser.add_argument("--accelerometer", action="store_true", help="every method on the acceleration's body "
                        "channels alone (writes basic_motions_acc.md)")
    args = parser.parse_args()
    if min(args.clip) <= 0:
        parser.exit(2, f"error: --clip must be positive seconds, got {min(args.clip):g}\n")
    if max(args.clip) > CASES * 10:
        parser.exit(2, f"error: --clip must be at most the recordings' {CASES * 10:g} s, got {max(args.clip):g}\n")
    try:
        import aeon.datasets  # noqa: F401
    except ImportError:
        parser.exit(2, "error: BasicMotions ships with aeon: pip install '.[eval]'\n")
    channels = ACC_BODY_CHANNELS if args.accelerometer else None
    with results_file("basic_motions" + "_acc" * args.accelerometer,
                      "Spotting-free learning on real recordings (BasicMotions)"
                      + ", acceleration alone" * args.accelerometer,
                      packages=("numpy", "scipy", "scikit-learn", "aeon")):
        rows = [r for o in args.order for c in args.clip for r in run(c, args.seeds, o, args.quick, channels)]
        print(f"- training: the archive's training cases joined {CASES} at a time, in the order of each seed of "
              f"--order, into recordings of {CASES * 10:g} s and cut into clips, each declared with its set of "
              f"classes; test: {rows[0]['test_recordings']} whole recordings of the test cases joined the same way")
        if channels:
            print(f"- channels: {', '.join(channels)} (every method)")
        print("- balanced accuracy = mean of per-class recalls; away = leaving out samples within 0.5 s of a true "
              "change; centred labels (offline), and live: causal labels (each window labels its last sample; a "
              "peer trained on that alignment, its fit time included); training windows named right = the learner's "
              "final names of its training windows against the true label at each window's centre")
        print()
        print("\n".join(table(rows, "order", prefix="order ")))

if __name__ == "__main__":
    main()
