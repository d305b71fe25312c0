"""Speed and quality of Ordered Subspace Clustering on block-Hankel windows, side by side with peers.

Data: a synthetic 3-channel signal at 20 Hz that switches between ``REGIMES`` regimes in contiguous segments of
5-15 s. In each regime the channels are a fixed mixture of two sinusoids (regime frequencies 0.3-4 Hz, random
phase per segment, regime amplitude 0.5-2) plus white noise; windows of 20 samples (1 s) with step 1 form the
block-Hankel matrix (``spotfree.windows.block_hankel``, d = 60 rows). The true label of a window is the regime of
its middle sample, so windows that straddle a switch count as errors for every method.

Methods (each case runs in its own process; time = the clustering call, after imports and, for spotfree, after one
tiny warm-up fit that loads the compiled kernels; memory = the process's peak resident set size):

* ``osc``: ``spotfree.cluster.OrderedSubspaceClustering`` with its defaults (float32, tol 1e-2).
* ``ssc``: ``spotfree.cluster.SparseSubspaceClustering``, the same solver without the ordering term.
* ``reference``: a straightforward ADMM written from the published algorithm (Tierney, Gao & Guo 2014, the
  Sylvester-equation variant, as in their code): dense ``X^T X`` and ``R``, a dense Sylvester solve for the
  coefficient step at every iteration (``O(n^3)``), penalty multiplied by 1.1 per iteration; same objective
  (eq. 10's square ``R``, zero diagonal), same weights and initial penalty, same affinity and normalized cuts as
  ``osc``. Stops when the constraint residuals and the change of ``S`` are below 1e-2 relative, at most 300
  iterations.
* ``sklearn-rbf`` / ``sklearn-knn``: ``sklearn.cluster.SpectralClustering`` on the raw windows (RBF kernel with
  the median heuristic for gamma; 10-nearest-neighbour graph), k-means labels with a fixed seed.

Run: ``python benchmarks/osc_speed.py`` (all cases; about 20 minutes on 2 cores; writes
``benchmarks/results/osc_speed.md``: command, machine, date, table) or ``python benchmarks/osc_speed.py --case osc
--n 1300`` (one case, JSON on stdout).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np

from machine import results_file

REGIMES = 4
WINDOW = 20
RATE = 20.0
SIZES = (1300, 10000)
REFERENCE_SIZES = (400, 800, 1300)
CASES = ("osc", "ssc", "reference", "sklearn-rbf", "sklearn-knn")


def switching_signal(n_samples: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``(n_samples, 3)`` signal and the regime of every sample (see the module docstring)."""
    rng = np.random.default_rng(seed)
    regimes = [
        (rng.uniform(0.3, 4.0, 2), rng.standard_normal((3, 2)), rng.uniform(0.5, 2.0)) for _ in range(REGIMES)
    ]
    t = np.arange(n_samples) / RATE
    signal = np.empty((n_samples, 3))
    labels = np.empty(n_samples, dtype=int)
    start, previous = 0, -1
    while start < n_samples:
        length = int(rng.integers(5 * RATE, 15 * RATE))
        regime = int(rng.choice([r for r in range(REGIMES) if r != previous]))
        freqs, mixing, amplitude = regimes[regime]
        stop = min(start + length, n_samples)
        phases = rng.uniform(0, 2 * np.pi, 2)
        sources = np.sin(2 * np.pi * freqs[None, :] * t[start:stop, None] + phases[None, :])
        signal[start:stop] = amplitude * sources @ mixing.T
        labels[start:stop] = regime
        start, previous = stop, regime
    signal += 0.05 * rng.standard_normal(signal.shape)
    return signal, labels


def windows(n_windows: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Block-Hankel windows, one per row (``n_windows x 60``), and their true regimes."""
    from spotfree.windows import block_hankel

    signal, labels = switching_signal(n_windows + WINDOW - 1, seed)
    X = block_hankel(signal, WINDOW).T
    return X, labels[np.arange(n_windows) + WINDOW // 2]


def reference_osc(X: np.ndarray, lambda1: float, lambda2: float, rho: float, tol: float = 1e-2, max_iter: int = 300):
    """The published OSC ADMM, written plainly (reference for the benchmark; paper's layout, ``Xp = X^T``).

    min 1/2 ||Xp - Xp S||^2 + l1 ||Z||_1 + l2 ||U||_{1,2}  s.t.  Z = S, U = S R,  diag(Z) = 0.
    Steps: Z = soft(S - G/g1, l1/g1) with zero diagonal; (Xp^T Xp + g1 I) S + g2 S R R^T = Xp^T Xp + g1 Z + G +
    (g2 U + F) R^T (Sylvester); U = column shrink(S R - F/g2, l2/g2); G += g1 (Z - S); F += g2 (U - S R);
    g1, g2 *= 1.1. Both Sylvester operators are symmetric, so the equation is solved densely in their
    eigenbases (computed once; four ``n^3`` products per iteration): ``scipy.linalg.solve_sylvester`` solves the
    same equation but took 35 s per call at n = 1300 on the benchmark machine.
    """
    n = X.shape[0]
    XtX = X @ X.T  # Xp^T Xp
    R = -np.eye(n) + np.eye(n, k=-1)
    gram_values, Q = np.linalg.eigh(XtX)
    diff_values, V = np.linalg.eigh(R @ R.T)
    S = np.zeros((n, n))
    U = np.zeros((n, n))
    G = np.zeros((n, n))
    F = np.zeros((n, n))
    g1 = g2 = rho
    for iteration in range(1, max_iter + 1):
        W = S - G / g1
        Z = W - np.clip(W, -lambda1 / g1, lambda1 / g1)
        np.fill_diagonal(Z, 0.0)
        S_previous = S
        rhs = XtX + g1 * Z + G + (g2 * U + F) @ R.T
        S = Q @ ((Q.T @ rhs @ V) / (gram_values[:, None] + g1 + g2 * diff_values[None, :])) @ V.T
        SR = S @ R
        W = SR - F / g2
        norms = np.linalg.norm(W, axis=0)
        U = W * np.maximum(0.0, 1.0 - (lambda2 / g2) / np.maximum(norms, 1e-300))
        G += g1 * (Z - S)
        F += g2 * (U - SR)
        g1 *= 1.1
        g2 *= 1.1
        scale = max(np.linalg.norm(S), 1e-300)
        residual = max(np.linalg.norm(Z - S), np.linalg.norm(U - SR)) / scale
        if residual < tol and np.linalg.norm(S - S_previous) / scale < tol:
            break
    return Z, iteration


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def fit_spotfree(case: str, X: np.ndarray) -> dict:
    from spotfree.cluster import OrderedSubspaceClustering, SparseSubspaceClustering, osc_objective

    estimator = (SparseSubspaceClustering if case == "ssc" else OrderedSubspaceClustering)(REGIMES, random_state=0)
    start = time.perf_counter()
    estimator.set_params(max_iter=3).fit(X[:60])  # loads the compiled kernels
    warm_up, rss_before = time.perf_counter() - start, peak_rss_mb()
    start = time.perf_counter()
    estimator.set_params(max_iter=300).fit(X)
    elapsed = time.perf_counter() - start
    return {
        "labels": estimator.labels_,
        "time_s": elapsed,
        "peak_rss_mb": peak_rss_mb(),
        "warm_up_s": warm_up,
        "rss_before_fit_mb": rss_before,
        "iterations": estimator.n_iter_,
        "objective": osc_objective(X, estimator.coef_, estimator.lambda1_, estimator.lambda2_),
    }


def fit_reference(X: np.ndarray) -> dict:
    from spotfree.cluster import OrderedSubspaceClustering, affinity, normalized_cuts, osc_objective, penalty_scale
    from spotfree.cluster.osc import DEFAULT_RHO_PER_LAMBDA

    defaults, mu = OrderedSubspaceClustering(), penalty_scale(X)
    lam1, lam2 = defaults.lambda1 * mu, defaults.lambda2 * mu
    start = time.perf_counter()
    Z, iterations = reference_osc(X, lam1, lam2, DEFAULT_RHO_PER_LAMBDA * max(lam1, lam2))
    labels = normalized_cuts(affinity(Z), REGIMES, random_state=0)
    elapsed = time.perf_counter() - start
    return {
        "labels": labels,
        "time_s": elapsed,
        "peak_rss_mb": peak_rss_mb(),
        "iterations": iterations,
        "objective": osc_objective(X, Z, lam1, lam2),
    }


def fit_sklearn(case: str, X: np.ndarray) -> dict:
    from sklearn.cluster import SpectralClustering

    if case == "sklearn-rbf":
        sample = X[np.random.default_rng(0).choice(len(X), min(len(X), 2000), replace=False)]
        d2 = ((sample[:, None, :] - sample[None, :, :]) ** 2).sum(-1)
        params = {"affinity": "rbf", "gamma": 1.0 / np.median(d2[d2 > 0])}
    else:
        params = {"affinity": "nearest_neighbors", "n_neighbors": 10}
    start = time.perf_counter()
    labels = SpectralClustering(REGIMES, random_state=0, assign_labels="kmeans", **params).fit_predict(X)
    return {"labels": labels, "time_s": time.perf_counter() - start, "peak_rss_mb": peak_rss_mb()}


def run_case(case: str, n: int, seed: int) -> dict:
    """One measurement in this process."""
    from sklearn.metrics import adjusted_rand_score

    X, truth = windows(n, seed)
    rss_before = peak_rss_mb()
    if case in ("osc", "ssc"):
        result = fit_spotfree(case, X)
    elif case == "reference":
        result = fit_reference(X)
    else:
        result = fit_sklearn(case, X)
    labels = result.pop("labels")
    if "iterations" in result:
        result["time_per_iteration_s"] = result["time_s"] / result["iterations"]
    return {
        "case": case,
        "n": n,
        "seed": seed,
        "rss_before_fit_mb": rss_before,  # after loading the data (and, for spotfree, the compiled kernels)
        **result,
        "ari": adjusted_rand_score(truth, labels),
    }


def measure(case: str, n: int, seed: int) -> dict:
    """Run one case in a fresh process (so that peak memory belongs to that case alone)."""
    command = [sys.executable, __file__, "--case", case, "--n", str(n), "--seed", str(seed)]
    completed = subprocess.run(command, capture_output=True, text=True, check=True)
    return json.loads(completed.stdout.strip().splitlines()[-1])


def main() -> None:
    seed = 0
    with results_file("osc_speed", "Ordered Subspace Clustering: speed against the published ADMM and scikit-learn",
                      ("numpy", "scipy", "scikit-learn", "numba")):
        rows = []
        for n in SIZES:
            for case in ("osc", "ssc", "sklearn-knn", "sklearn-rbf"):
                rows.append(measure(case, n, seed))
                print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
        for n in REFERENCE_SIZES:
            rows.append(measure("reference", n, seed))
            print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
        print(f"Load average after the runs: {os.getloadavg()[0]:.1f}.\n")
        print(table(rows))
        print()
        print(reference_summary(rows))


def table(rows: list[dict]) -> str:
    lines = [
        "| n | method | time (s) | iterations | s / iteration | ARI | objective | peak RSS (MB) "
        "| RSS before fit (MB) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        per_iteration = f"{r['time_per_iteration_s']:.3f}" if "iterations" in r else ""
        objective = f"{r['objective']:.6g}" if "objective" in r else ""
        lines.append(
            f"| {r['n']} | {r['case']} | {r['time_s']:.2f} | {r.get('iterations', '')} | {per_iteration} | "
            f"{r['ari']:.3f} | {objective} | {r['peak_rss_mb']:.0f} | {r['rss_before_fit_mb']:.0f} |"
        )
    return "\n".join(lines)


def reference_summary(rows: list[dict]) -> str:
    """Ratios to osc at the largest common n, and the reference at the largest n extrapolated."""
    reference = [r for r in rows if r["case"] == "reference"]
    osc = {r["n"]: r for r in rows if r["case"] == "osc"}
    sizes = np.array([r["n"] for r in reference], dtype=float)
    exponent = np.polyfit(np.log(sizes), np.log([r["time_per_iteration_s"] for r in reference]), 1)[0]
    last, target = reference[-1], max(osc)
    fitted = last["time_per_iteration_s"] * (target / last["n"]) ** exponent
    cubic = last["time_per_iteration_s"] * (target / last["n"]) ** 3
    arrays = (last["peak_rss_mb"] - last["rss_before_fit_mb"]) * 1e6 / (8 * last["n"] ** 2)
    ours = osc[target]["time_per_iteration_s"]
    return "\n".join([
        f"- reference at n = {last['n']}: {last['time_per_iteration_s'] / osc[last['n']]['time_per_iteration_s']:.0f}x"
        f" the time per iteration of osc, {last['time_s'] / osc[last['n']]['time_s']:.0f}x its total time.",
        f"- reference time per iteration grew as n^{exponent:.2f} over n = {tuple(int(v) for v in sizes)}"
        " (its dense products cost n^3 flops).",
        f"- reference at n = {target}, not run: {fitted:.0f} s per iteration by that power, {cubic:.0f} s by n^3,"
        f" i.e. {fitted / ours:.0f}x to {cubic / ours:.0f}x osc's measured {ours:.2f} s; its peak memory at"
        f" n = {last['n']} was {arrays:.0f} dense n x n float64 arrays, {arrays * 8 * target**2 / 1e9:.0f} GB at"
        f" n = {target}.",
    ])


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", choices=CASES)
    parser.add_argument("--n", type=int, default=1300)
    parser.add_argument("--seed", type=int, default=0)
    arguments = parser.parse_args()
    if arguments.case:
        print(json.dumps(run_case(arguments.case, arguments.n, arguments.seed)))
    else:
        main()
