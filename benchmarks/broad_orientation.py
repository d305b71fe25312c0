"""Inclination error of every spotfree orientation option and its peers on four BROAD trials, in one run.

    python benchmarks/broad_orientation.py [--rates native,20]

For each trial (``../shared/data/broad``, see ``broad.py``) at the native 285.7 Hz and block-averaged by 14 to
20.4 Hz, runs

* spotfree: ``paper`` (eq. 3, Kp 7.5924, Ki 20.7015), ``default`` (GravityPI), ``vqf`` (the backend);
* ahrs 0.4: Complementary, Mahony, Madgwick (m/s^2 and rad/s), each at its default gain and at the fixed gain
  that is best at 20 Hz over the four trials (mean RMSE; ``python benchmarks/tune_orientation.py``);
* imufusion 1.3 (``Ahrs.update_no_magnetometer``; g and deg/s, NWU), default settings and best gain;
* vqf 2.1: ``VQF`` (online, default parameters) and ``offlineVQF`` (non-causal, for reference);

and prints one markdown table: inclination RMSE (deg, movement phase, valid reference) per trial, their mean,
and samples per second (all trials' samples over all trials' wall time; noisy on a shared machine, compare
ratios). A summary says on which trials the default beats each fixed-gain peer at 20 Hz, and the gap to vqf.
Writes ``benchmarks/results/broad_orientation.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import time
from typing import Callable

import ahrs
import imufusion
import numpy as np
import vqf

import broad
from machine import results_file
from spotfree.signal.frame import gravity_direction
from spotfree.signal.orientation import estimate_attitude
from spotfree.units import GRAVITY

PACKAGES = ("numpy", "scipy", "numba", "ahrs", "imufusion", "vqf")
"""The packages whose versions the results file names."""

Runner = Callable[[broad.Trial], np.ndarray]
"""A method: trial -> estimated unit vertical ``(n, 3)`` in the body frame."""

PEER_BEST_GAINS = {"Complementary": 0.8, "Mahony": (0.3, 1e-9), "Madgwick": 0.05, "imufusion": 0.2}
"""Best fixed gain of each peer at 20.4 Hz over the four trials (mean RMSE); Mahony as (k_P, k_I), k_I > 0
because ahrs rejects 0. Found by ``tune_orientation.py``."""


def spotfree(orientation: str) -> Runner:
    def run(t: broad.Trial) -> np.ndarray:
        rp = estimate_attitude(t.acc, t.gyr, t.rate, orientation)
        return gravity_direction(rp[:, 0], rp[:, 1])

    return run


def ahrs_complementary(gain: float = 0.9) -> Runner:
    def run(t: broad.Trial) -> np.ndarray:
        angles = ahrs.filters.Complementary(gyr=t.gyr, acc=t.acc, frequency=t.rate, gain=gain).W
        return gravity_direction(angles[:, 0], angles[:, 1])

    return run


def ahrs_mahony(k_p: float = 1.0, k_i: float = 0.3) -> Runner:
    def run(t: broad.Trial) -> np.ndarray:
        return broad.up_from_quaternion(ahrs.filters.Mahony(gyr=t.gyr, acc=t.acc, frequency=t.rate, k_P=k_p, k_I=k_i).Q)

    return run


def ahrs_madgwick(gain: float = 0.033) -> Runner:
    def run(t: broad.Trial) -> np.ndarray:
        return broad.up_from_quaternion(ahrs.filters.Madgwick(gyr=t.gyr, acc=t.acc, frequency=t.rate, gain=gain).Q)

    return run


def fusion(gain: float | None = None) -> Runner:
    def run(t: broad.Trial) -> np.ndarray:
        settings = imufusion.AhrsSettings(sample_rate=t.rate, convention=imufusion.CONVENTION_NWU)
        if gain is not None:
            settings.gain = gain
        filt = imufusion.Ahrs()
        filt.set_settings(settings)
        gyr_deg, acc_g = np.degrees(t.gyr), t.acc / GRAVITY
        out = np.empty_like(t.acc)
        for k in range(len(acc_g)):
            filt.update_no_magnetometer(gyr_deg[k], acc_g[k])
            out[k] = filt.get_gravity()
        return out

    return run


def vqf_online(t: broad.Trial) -> np.ndarray:
    out = vqf.VQF(1.0 / t.rate).updateBatch(np.ascontiguousarray(t.gyr), np.ascontiguousarray(t.acc))
    return broad.up_from_quaternion(out["quat6D"])


def vqf_offline(t: broad.Trial) -> np.ndarray:
    out = vqf.offlineVQF(np.ascontiguousarray(t.gyr), np.ascontiguousarray(t.acc), None, 1.0 / t.rate)
    return broad.up_from_quaternion(out["quat6D"])


def methods() -> dict[str, tuple[Runner, bool]]:
    """Name -> (runner, fixed gain). Fixed-gain peers are the ones the default must beat at 20 Hz."""
    best = PEER_BEST_GAINS
    return {
        "spotfree paper": (spotfree("paper"), False),
        "spotfree default": (spotfree("default"), False),
        "spotfree vqf": (spotfree("vqf"), False),
        "ahrs Complementary (gain 0.9, default)": (ahrs_complementary(), True),
        f"ahrs Complementary (gain {best['Complementary']}, best)": (ahrs_complementary(best["Complementary"]), True),
        "ahrs Mahony (k_P 1, k_I 0.3, default)": (ahrs_mahony(), True),
        f"ahrs Mahony (k_P {best['Mahony'][0]}, k_I {best['Mahony'][1]:g}, best)": (ahrs_mahony(*best["Mahony"]), True),
        "ahrs Madgwick (gain 0.033, default)": (ahrs_madgwick(), True),
        f"ahrs Madgwick (gain {best['Madgwick']}, best)": (ahrs_madgwick(best["Madgwick"]), True),
        "imufusion (gain 0.5, default)": (fusion(), False),
        f"imufusion (gain {best['imufusion']}, best)": (fusion(best["imufusion"]), False),
        "vqf VQF (online)": (vqf_online, False),
        "vqf offlineVQF (non-causal)": (vqf_offline, False),
    }


def evaluate(trials: list[broad.Trial], runner: Runner) -> tuple[np.ndarray, float]:
    """Inclination RMSE (deg) per trial and samples per second over all trials."""
    rmse, seconds, samples = [], 0.0, 0
    for t in trials:
        start = time.perf_counter()
        up = runner(t)
        seconds += time.perf_counter() - start
        samples += len(t.acc)
        rmse.append(broad.inclination_rmse(up, t))
    return np.array(rmse), samples / seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rates", default="native,20", help="comma list of: native, 20")
    args = parser.parse_args()
    with results_file("broad_orientation", "BROAD orientation: every option and its peers", PACKAGES):
        _table(args)


def _table(args: argparse.Namespace) -> None:
    """Print the table and the summary for ``args.rates``."""
    native = [broad.load_trial(name) for name in broad.TRIALS]
    sets = {"native": native, "20": [broad.block_average(t) for t in native]}
    names = [name[:2] for name in broad.TRIALS]
    print("| rate (Hz) | method | " + " | ".join(names) + " | mean | samples/s |")
    print("|---|---|" + "---:|" * (len(names) + 2))
    results = {}
    for key in args.rates.split(","):
        trials = sets[key]
        for label, (runner, _) in methods().items():
            rmse, speed = evaluate(trials, runner)
            results[key, label] = rmse
            cells = [f"{r:.2f}" for r in rmse] + [f"{rmse.mean():.2f}", f"{speed:,.0f}"]
            print(f"| {trials[0].rate:.1f} | {label} | " + " | ".join(cells) + " |", flush=True)
    if "20" in args.rates.split(","):
        default = results["20", "spotfree default"]
        print()
        for label, (_, fixed) in methods().items():
            if fixed or label.startswith("imufusion"):
                wins = [n for n, d, p in zip(names, default, results["20", label]) if d < p]
                print(f"- 20 Hz, default vs {label}: lower RMSE on {len(wins)}/4 trials ({', '.join(wins) or 'none'})")
        gap = default - results["20", "vqf VQF (online)"]
        print("- 20 Hz, default minus vqf VQF (deg): " + ", ".join(f"{n}: {g:+.2f}" for n, g in zip(names, gap)))


if __name__ == "__main__":
    main()
