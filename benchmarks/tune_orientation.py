"""Grid search of the default orientation filter's gains on the four BROAD trials at ~20 Hz.

    python benchmarks/tune_orientation.py [--top 10]

Runs :class:`spotfree.signal.orientation.GravityPI` on every trial block-averaged by 14 (20.41 Hz) for each point
of a small grid over ``kp, ki, acc_scale, rate_scale, max_error`` (the rest-detection constants stay at their
physical defaults) and prints the best points by mean inclination RMSE (degrees, movement phase) as a markdown
table. ``ki`` is searched from 0.001 up, not from 0: BROAD trials start with 30-45 s of rest, which hands the
rest-phase estimator the bias, whereas a ride may start moving; the integral term must stay on.
Deterministic: no randomness, same output every run.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

import broad
from spotfree.signal.frame import gravity_direction
from spotfree.signal.orientation import GravityPI

GRID = {
    "kp": (0.2, 0.3, 0.5),
    "ki": (0.001, 0.002, 0.005),
    "acc_scale": (2.0, 5.0, 10.0),
    "rate_scale": (4.0, 8.0, 16.0),
    "max_error": (0.1, 0.15, 0.2),
}


def score(trials: list[broad.Trial], **params: float) -> np.ndarray:
    """Inclination RMSE (deg) of GravityPI with ``params`` on each trial."""
    out = []
    for t in trials:
        rp = GravityPI(t.rate, **params).run(t.acc, t.gyr)
        out.append(broad.inclination_rmse(gravity_direction(rp[:, 0], rp[:, 1]), t))
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=10, help="rows to print")
    args = parser.parse_args()
    trials = [broad.block_average(broad.load_trial(name)) for name in broad.TRIALS]
    rows = []
    for values in itertools.product(*GRID.values()):
        params = dict(zip(GRID, values))
        rows.append((params, score(trials, **params)))
    rows.sort(key=lambda row: row[1].mean())
    names = [name[:2] for name in broad.TRIALS]
    print("| " + " | ".join(GRID) + " | " + " | ".join(names) + " | mean |")
    print("|" + "---|" * (len(GRID) + len(names) + 1))
    for params, rmse in rows[: args.top]:
        cells = [f"{v:g}" for v in params.values()] + [f"{r:.2f}" for r in rmse] + [f"{rmse.mean():.2f}"]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
