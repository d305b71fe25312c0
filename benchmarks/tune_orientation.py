"""Grid search of the default orientation filter's gains on the four BROAD trials at ~20 Hz.

    python benchmarks/tune_orientation.py [--top 10] [--peers]

Runs :class:`spotfree.signal.orientation.GravityPI` on every trial block-averaged by 14 (20.41 Hz) for each point
of a small grid over ``kp, ki, acc_scale, rate_scale, max_error, acc_tau, motion_tau`` (the rest-detection
constants stay at their physical defaults) and prints the best points by mean inclination RMSE (degrees, movement
phase) as a markdown table. The defaults are chosen by ``orientation_leave_trials_out.py``, which scores this
selection on held-out trials. ``ki`` is searched from 0.001 up, not from 0: BROAD trials start with 30-45 s of rest, which hands the
rest-phase estimator the bias, whereas a ride may start moving; the integral term must stay on.
With ``--peers`` it sweeps the fixed gain of each peer of ``broad_orientation.py`` instead (ahrs Complementary,
Mahony, Madgwick; imufusion) and prints each peer's best gain by mean RMSE, the "best" rows of that benchmark.
Deterministic: no randomness, same output every run. Writes ``benchmarks/results/tune_orientation.md``
(``tune_orientation_peers.md`` with ``--peers``): command, machine, date, table.
"""

from __future__ import annotations

import argparse
import itertools

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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--top", type=int, default=10, help="rows to print")
    parser.add_argument("--peers", action="store_true", help="sweep the peers' fixed gains instead")
    args = parser.parse_args()
    trials = [broad.block_average(broad.load_trial(name)) for name in broad.TRIALS]
    if args.peers:
        with results_file("tune_orientation_peers", "Peer gains: fixed-gain sweep on BROAD at 20.4 Hz",
                          peers.PACKAGES):
            sweep_peers(trials)
        return
    with results_file("tune_orientation", "Default orientation gains: grid search on BROAD at 20.4 Hz",
                      peers.PACKAGES):
        grid_search(trials, args.top)


def grid_search(trials: list[broad.Trial], top: int) -> None:
    """Print the ``top`` points of :data:`GRID` by mean inclination RMSE over ``trials``."""
    rows = []
    for values in itertools.product(*GRID.values()):
        params = dict(zip(GRID, values))
        rows.append((params, score(trials, **params)))
    rows.sort(key=lambda row: row[1].mean())
    names = [name[:2] for name in broad.TRIALS]
    print("| " + " | ".join(GRID) + " | " + " | ".join(names) + " | mean |")
    print("|" + "---|" * (len(GRID) + len(names) + 1))
    for params, rmse in rows[:top]:
        cells = [f"{v:g}" for v in params.values()] + [f"{r:.2f}" for r in rmse] + [f"{rmse.mean():.2f}"]
        print("| " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
