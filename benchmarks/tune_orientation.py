"""Fixed-gain sweep of the orientation peers on the four BROAD trials at ~20 Hz, and the default filter's grid.

    python benchmarks/tune_orientation.py

Sweeps the fixed gain of each peer of ``broad_orientation.py`` (ahrs Complementary, Mahony, Madgwick; imufusion:
:data:`PEER_GRID`) on every trial block-averaged by 14 (20.41 Hz) and prints every gain's inclination RMSE (degrees,
movement phase) per trial, best mean first within each peer: the "best" rows of ``broad_orientation.py``. Writes
``benchmarks/results/tune_orientation.md`` (command, machine, date, table). Deterministic.

:data:`GRID` is the grid of :class:`spotfree.signal.orientation.GravityPI`'s gains over ``kp, ki, acc_scale,
rate_scale, max_error, acc_tau, motion_tau`` (the rest-detection constants stay at their physical defaults) from
which ``orientation_leave_trials_out.py`` chooses the default on tuning trials and scores it on held-out ones.
``ki`` is searched from 0.001 up, not from 0: BROAD trials start with 30-45 s of rest, which hands the rest-phase
estimator the bias, whereas a ride may start moving; the integral term must stay on.
"""

from __future__ import annotations

import argparse

import numpy as np

import broad
import broad_orientation as peers
from machine import results_file
from spotfree.signal.frame import gravity_direction
from spotfree.signal.orientation import GravityPI

GRID = {
    "kp": (0.2, 0.3, 0.5),
    "ki": (0.001, 0.003, 0.01),
    "acc_scale": (1.5, 2.0, 3.0),
    "rate_scale": (2.0, 4.0, 8.0),
    "max_error": (0.1, 0.2, 0.4),
    "acc_tau": (0.0, 0.5, 1.0, 2.0),
    "motion_tau": (2.0, 4.0),
}

PREVIOUS_DEFAULT = {"kp": 0.3, "ki": 0.001, "acc_scale": 10.0, "rate_scale": 8.0, "max_error": 0.1, "acc_tau": 0.0,
                    "motion_tau": 0.0}
"""The default before the accelerometer low-pass (tuned on all four trials, none held out): the reference of the
ride-like guard in ``orientation_leave_trials_out.py``."""


def score(trials: list[broad.Trial], **params: float) -> np.ndarray:
    """Inclination RMSE (deg) of GravityPI with ``params`` on each trial."""
    out = []
    for t in trials:
        rp = GravityPI(t.rate, **params).run(t.acc, t.gyr)
        out.append(broad.inclination_rmse(gravity_direction(rp[:, 0], rp[:, 1]), t))
    return np.array(out)


PEER_GRID = {
    "Complementary": (peers.ahrs_complementary, (0.5, 0.8, 0.9, 0.95, 0.98, 0.99, 0.995, 0.999)),
    "Mahony": (peers.ahrs_mahony, [(kp, ki) for kp in (0.1, 0.3, 1.0, 3.0) for ki in (1e-9, 0.01, 0.1, 0.3)]),
    "Madgwick": (peers.ahrs_madgwick, (0.005, 0.01, 0.02, 0.033, 0.05, 0.1, 0.2, 0.4)),
    "imufusion": (peers.fusion, (0.1, 0.2, 0.5, 1.0, 2.0)),
}


def sweep_peers(trials: list[broad.Trial]) -> None:
    """Print every peer gain's RMSE per trial, best (lowest mean) first within each peer."""
    names = [name[:2] for name in broad.TRIALS]
    print("| peer | gain | " + " | ".join(names) + " | mean |")
    print("|---|---|" + "---:|" * (len(names) + 1))
    for peer, (make, gains) in PEER_GRID.items():
        rows = []
        for gain in gains:
            runner = make(*gain) if isinstance(gain, tuple) else make(gain)
            rmse, _ = peers.evaluate(trials, runner)
            rows.append((gain, rmse))
        for gain, rmse in sorted(rows, key=lambda row: row[1].mean()):
            cells = [f"{r:.2f}" for r in rmse] + [f"{rmse.mean():.2f}"]
            print(f"| {peer} | {gain} | " + " | ".join(cells) + " |", flush=True)


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    trials = [broad.block_average(broad.load_trial(name)) for name in broad.TRIALS]
    with results_file("tune_orientation", "Peer gains: fixed-gain sweep on BROAD at 20.4 Hz", peers.PACKAGES):
        sweep_peers(trials)


if __name__ == "__main__":
    main()
