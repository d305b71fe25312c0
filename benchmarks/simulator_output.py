"""What the ride simulator produces: manoeuvre shares, braking magnitudes and the tablet's vibration per surface.

For one seed, every scenario's ``--repeats`` experiments (:func:`spotfree.sim.scenarios.simulate_ride`, which also
returns the kinematic truth):

* manoeuvre share per experiment (fraction of samples in the scenario's declared manoeuvre classes,
  :func:`~spotfree.sim.scenarios.manoeuvre_share`), the experiments' durations, and the processor time to simulate
  the scenario (``time.process_time``);
* braking, from the braking scenarios' truth: the rider's lean deceleration ``-lean_accel`` (m/s^2, the quantity the
  labels threshold) and the handlebar pitch (deg, the truth's ``pitch``) per label, median and 90th percentile of the
  deceleration, median and 10th percentile of the pitch;
* vibration, ``road`` scenario: device accelerometer and gyroscope on the nominal vehicle axes
  (:func:`~spotfree.signal.frame.device_to_vehicle_axes`), high-passed at 2 Hz (second-order Butterworth,
  zero-phase), RMS per surface label over the samples riding faster than 3 m/s outside kerb strikes, and at a
  standstill (truth speed below 0.05 m/s); per kerb strike, the peak of the vertical acceleration's departure from
  its ride median and the length of its ``kerb`` label.

    python benchmarks/simulator_output.py [--seed 0] [--repeats 7]

Writes ``benchmarks/results/simulator_output.md`` (command, machine, date, tables).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.signal import butter, sosfiltfilt

from machine import results_file
from spotfree.io.checks import true_runs
from spotfree.signal.frame import device_to_vehicle_axes
from spotfree.sim.scenarios import SCENARIOS, manoeuvre_share, simulate_ride

HIGH_PASS = 2.0
"""Cut-off (Hz) of the vibration's high-pass."""
RIDING = 3.0
"""Speed (m/s) above which a sample counts as riding for the vibration table."""


def shares(seed: int, repeats: int) -> dict:
    """Per scenario: its rides (with truth) and the processor time they took."""
    rides = {}
    for scenario in SCENARIOS:
        start = time.process_time()
        rides[scenario] = [simulate_ride(scenario, k, repeats=repeats, seed=seed) for k in range(1, repeats + 1)]
        rides[scenario] = (rides[scenario], time.process_time() - start)
    print("## Manoeuvre share per experiment\n")
    print("| scenario | " + " | ".join(str(k) for k in range(1, repeats + 1)) + " | durations (s) | CPU time (s) |")
    print("|---|" + "---:|" * repeats + "---|---:|")
    for scenario, (experiments, cpu) in rides.items():
        cells = [f"{manoeuvre_share(r.label, scenario):.2f}" for r in experiments]
        durations = [r.time[-1] - r.time[0] for r in experiments]
        print(f"| {scenario} | {' | '.join(cells)} | {min(durations):.0f}-{max(durations):.0f} | {cpu:.2f} |")
    return rides


def braking(rides: dict) -> None:
    """Print the lean deceleration and handlebar pitch per braking label of the braking scenarios."""
    print("\n## Braking\n")
    print("| scenario | label | samples | deceleration median (p90), m/s^2 | pitch median (p10), deg |")
    print("|---|---|---:|---|---|")
    for scenario in ("normal-braking", "sudden-braking"):
        experiments, _ = rides[scenario]
        label = np.concatenate([r.label for r in experiments])
        decel = -np.concatenate([r.truth["lean_accel"] for r in experiments])
        pitch = np.degrees(np.concatenate([r.truth["pitch"] for r in experiments]))
        for name in ("normal-braking", "sudden-braking"):
            keep = label == name
            if keep.any():
                print(f"| {scenario} | {name} | {keep.sum()} | {np.median(decel[keep]):.1f} "
                      f"({np.percentile(decel[keep], 90):.1f}) | {np.median(pitch[keep]):.1f} "
                      f"({np.percentile(pitch[keep], 10):.1f}) |")


def vibration(rides: dict) -> None:
    """Print the tablet's vibration RMS per surface and the kerb strikes of the road scenario."""
    experiments, _ = rides["road"]
    sums, kerbs = {}, []
    for r in experiments:
        rate = 1.0 / np.median(np.diff(r.time))
        sos = butter(2, HIGH_PASS, "high", fs=rate, output="sos")
        acc = device_to_vehicle_axes(np.column_stack([r.channels[c] for c in ("ax", "ay", "az")]))
        gyr = device_to_vehicle_axes(np.column_stack([r.channels[c] for c in ("gx", "gy", "gz")]))
        high = np.column_stack([sosfiltfilt(sos, acc, axis=0), np.degrees(sosfiltfilt(sos, gyr[:, :2], axis=0))])
        speed = r.truth["speed"]
        kerb = r.label == "kerb"
        groups = {name: (r.label == name) & (speed > RIDING) & ~kerb for name in np.unique(r.label) if name != "kerb"}
        groups["standing"] = speed < 0.05
        for name, keep in groups.items():
            total = sums.setdefault(name, [np.zeros(5), 0])
            total[0] += np.sum(high[keep] ** 2, axis=0)
            total[1] += int(keep.sum())
        vertical = acc[:, 2] - np.median(acc[:, 2])
        kerbs += [(np.max(np.abs(vertical[i0:i1])), (i1 - i0) / rate) for i0, i1 in true_runs(kerb)]
    print(f"\n## Vibration on the road scenario\n\nHigh-passed at {HIGH_PASS:g} Hz; riding faster than {RIDING:g} m/s, "
          "kerb strikes left out; standing: truth speed below 0.05 m/s.\n")
    print("| surface | samples | accel RMS x, y, z (m/s^2) | gyro RMS x, y (deg/s) |")
    print("|---|---:|---|---|")
    for name, (square, n) in sums.items():
        if n:
            rms = np.sqrt(square / n)
            print(f"| {name} | {n} | {rms[0]:.2f}, {rms[1]:.2f}, {rms[2]:.2f} | {rms[3]:.1f}, {rms[4]:.1f} |")
    if kerbs:
        peak, length = np.array(kerbs).T
        print(f"\nKerb strikes: {len(kerbs)}; peak vertical acceleration {peak.min():.0f}-{peak.max():.0f} m/s^2 "
              f"(median {np.median(peak):.0f}); labelled `kerb` for {length.min():.2f}-{length.max():.2f} s.")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    with results_file("simulator_output", "What the ride simulator produces", ("numpy", "scipy")):
        print(f"Seed {args.seed}, {args.repeats} experiments per scenario.\n")
        rides = shares(args.seed, args.repeats)
        braking(rides)
        vibration(rides)


if __name__ == "__main__":
    main()
