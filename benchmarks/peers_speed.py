"""Peers on the paper's braking protocol: train / predict time and per-sample accuracy.

Protocol (section V): the simulator's normal-braking, sudden-braking and cruising files, seven rides each; every
peer trains on ride 1 of the three files (with the ground-truth labels) and labels every sample of rides 2-7.
Accuracy counts the samples a peer labels (``coverage`` says which fraction that is); ``balanced`` is the mean
per-class recall; ``sudden in NB`` counts sudden-braking labels inside the normal-braking tests, the figure the
paper quotes. "all cruising" is the majority-class reference. numba compiles aeon's kernels in a warm-up on
one training ride before anything is timed.

    python benchmarks/peers_speed.py [--seed 0] [--kernels 10000]

Writes ``benchmarks/results/peers_speed.md`` (command, machine, date, table).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import threadpoolctl
from sklearn.metrics import balanced_accuracy_score

from machine import results_file
from spotfree.peers import ClaspPeer, MiniRocketPeer, NearestNeighbourPeer
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario

SCENARIOS = ("normal-braking", "sudden-braking", "cruising")


def protocol(seed: int):
    files = {s: ride_features(simulate_scenario(s, repeats=7, seed=seed), derived=True) for s in SCENARIOS}
    train = [f.select_experiment(1) for f in files.values()]
    tests = [(s, f.select_experiment(k)) for s, f in files.items() for k in range(2, 8)]
    return train, tests


def warm_up(train, kernels):
    MiniRocketPeer(n_kernels=kernels).fit(train).predict(train[0])
    ClaspPeer().fit(train).predict(train[0])


def measure(name, peer, train, tests):
    """One row: fit once, predict every test ride, score the labelled samples."""
    peer.fit(train)
    predict_time, truth, labels, scenario, total = 0.0, [], [], [], 0
    for s, rec in tests:
        predicted = peer.predict(rec)
        predict_time += peer.predict_time_
        keep = predicted != ""
        truth.append(rec.truth["label"][keep])
        labels.append(predicted[keep])
        scenario.append(np.full(keep.sum(), s))
        total += len(rec)
    return row(name, peer.fit_time_, predict_time, np.concatenate(truth), np.concatenate(labels),
               np.concatenate(scenario), total)


def row(name, fit_time, predict_time, truth, labels, scenario, total):
    right = truth == labels
    per_file = [f"{right[scenario == s].mean():.4f}" for s in SCENARIOS]
    in_nb = scenario == "normal-braking"
    sudden = int(np.sum(labels[in_nb] == "sudden-braking"))
    return (f"| {name} | {fit_time:.2f} | {predict_time:.2f} | {len(labels) / total:.4f} | {right.mean():.4f} | "
            f"{balanced_accuracy_score(truth, labels):.4f} | {' | '.join(per_file)} | {sudden} of {in_nb.sum()} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--kernels", type=int, default=10_000, help="MiniRocket features")
    args = parser.parse_args()
    with results_file("peers_speed", "Peers on the braking protocol: MiniRocket, 1-NN, ClaSP",
                      ("numpy", "scikit-learn", "aeon")):
        peers_table(args.seed, args.kernels)


def peers_table(seed: int, kernels: int) -> None:
    """Print the protocol's sizes and one row per peer."""
    blas = [(i["internal_api"], i.get("architecture"), i["version"]) for i in threadpoolctl.threadpool_info()
            if i["user_api"] == "blas"]
    print(f"BLAS {blas} (one thread inside the peers), OPENBLAS_CORETYPE="
          f"{os.environ.get('OPENBLAS_CORETYPE', 'unset')}.\n")
    start = time.perf_counter()
    train, tests = protocol(seed)
    print(f"simulator seed {seed}: {sum(len(r) for r in train)} training samples, {len(tests)} test rides, "
          f"{sum(len(r) for _, r in tests)} test samples (simulation and features {time.perf_counter() - start:.1f} s)")
    warm_up(train, kernels)
    print()
    print("| peer | fit (s) | predict (s) | coverage | accuracy | balanced | normal-braking tests | "
          "sudden-braking tests | cruising tests | sudden in NB |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    truth = np.concatenate([r.truth["label"] for _, r in tests])
    scenario = np.concatenate([np.full(len(r), s) for s, r in tests])
    print(row("all cruising (majority reference)", 0.0, 0.0, truth, np.full(len(truth), "cruising"), scenario,
              len(truth)))
    peers = [
        ("1-NN, causal", NearestNeighbourPeer()),
        ("1-NN, centred", NearestNeighbourPeer(alignment="centred")),
        (f"MiniRocket {kernels} + ridge, causal", MiniRocketPeer(n_kernels=kernels)),
        (f"MiniRocket {kernels} + ridge, centred", MiniRocketPeer(n_kernels=kernels, alignment="centred")),
        ("ClaSP (min_score 0.7), centroid naming", ClaspPeer()),
        ("ClaSP (min_score 0.7), truth naming (upper bound)", ClaspPeer(naming="truth")),
        ("ClaSP (min_score 0.55), centroid naming", ClaspPeer(min_score=0.55)),
        ("ClaSP (min_score 0.55), truth naming (upper bound)", ClaspPeer(naming="truth", min_score=0.55)),
    ]
    for name, peer in peers:
        print(measure(name, peer, train, tests), flush=True)


if __name__ == "__main__":
    main()
