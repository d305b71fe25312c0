"""CRC_RLS alone: batch windows per second, single-window latency, and the machine's matrix-multiply rate.

Problem (issue 4's goal): 60-dimensional windows, a dictionary of 300 columns in 3 classes of 100 (atoms near
three random 5-dimensional subspaces), windows near the same subspaces. Rows:

* ``GEMM`` float32 / float64: square ``2000 x 2000`` matrix products, the machine's yardstick, measured here.
* batch ``plain einsum``: the residuals as ``||E_i y||`` by ``einsum`` over the ``(C, d, d)`` operators then
  ``norm`` (the formula, no chunking), float64.
* batch ``decision_function``: :class:`~spotfree.classify.crc.CRCClassifier`'s chunked path (one GEMM per chunk
  against the stacked operators, then the block norms), float64 and float32, with 1 and 2 threads (``n_jobs``;
  chunks shared out to threads that each run a single-threaded BLAS); includes input validation. ``GFLOP/s`` counts the GEMM's ``2 C d^2`` flops per window; ``% GEMM`` compares with the
  square GEMM of the same precision and threads.
* stream ``predict_one``: one window, one compiled call, per-call median and 99th percentile; beside it the
  generic path (``predict`` on a one-row matrix).
* ``RideClassifier.update`` (when ``spotfree.classify.stream`` exists): one raw IMU sample in, one label out,
  with the ride dictionary of ``classifier_timing.py`` (d = 41, 300 columns) on a simulated sudden-braking ride.

Batch figures are the best of ``--repeats`` runs over ``--windows`` windows; ``OPENBLAS_CORETYPE`` and the load
average are printed, since both move the figures (other jobs share the 2 cores).

    python benchmarks/crc_speed.py [--windows 200000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import time
from datetime import date

import numpy as np
from threadpoolctl import threadpool_limits

from classifier_timing import best_seconds, machine
from spotfree.classify import CRCClassifier

D, CLASSES, PER_CLASS, RANK = 60, 3, 100, 5
FLOPS_PER_WINDOW = 2 * CLASSES * D * D


def problem(seed: int, n_windows: int):
    rng = np.random.default_rng(seed)
    bases = [np.linalg.qr(rng.normal(size=(D, RANK)))[0] for _ in range(CLASSES)]
    atoms = np.vstack([(b @ rng.normal(size=(RANK, PER_CLASS))).T for b in bases])
    atoms += 0.05 * rng.normal(size=atoms.shape)
    windows = np.vstack([(b @ rng.normal(size=(RANK, n_windows // CLASSES + 1))).T for b in bases])[:n_windows]
    windows += 0.05 * rng.normal(size=windows.shape)
    return atoms, np.repeat(np.arange(CLASSES), PER_CLASS), rng.permutation(windows)


def latencies_us(call, windows) -> np.ndarray:
    call(windows[0])
    ns = np.empty(len(windows))
    for k, y in enumerate(windows):
        start = time.perf_counter_ns()
        call(y)
        ns[k] = time.perf_counter_ns() - start
    return ns / 1e3


def gemm_rates(repeats: int) -> dict:
    """GFLOP/s of a square 2000 x 2000 product per (dtype, threads)."""
    rates = {}
    for dtype in ("float32", "float64"):
        a = np.random.default_rng(0).random((2000, 2000)).astype(dtype)
        for threads in (1, 2):
            with threadpool_limits(threads, user_api="blas"):
                rates[dtype, threads] = 2 * 2000 ** 3 / best_seconds(lambda: a @ a, repeats)[0] / 1e9
    return rates


def stream_rows(print_row) -> None:
    try:
        from spotfree.classify.stream import RideClassifier
    except ImportError:
        print("RideClassifier.update: skipped (no spotfree.classify.stream)")
        return
    from classifier_timing import AFFINE, CHANNELS, WINDOW, ride_data
    from spotfree.model import DictionaryModel
    from spotfree.sim.scenarios import simulate_scenario

    atoms, labels, _, _, _, scaling = ride_data(0, PER_CLASS, 10)
    classes = sorted(set(labels))
    model = DictionaryModel(classes=classes, channels=list(CHANNELS), rate=20.0, window=WINDOW, step=1,
                            normalisation="scale", scale=scaling.scale, dictionary=atoms[:, :-1].T,
                            column_class=np.searchsorted(classes, labels), parameters={"affine": AFFINE})
    ride = simulate_scenario("sudden-braking", repeats=1, seed=7)
    rows = list(zip(ride.array(["ax", "ay", "az"]), ride.array(["gx", "gy", "gz"]), ride.time,
                    ride.channels["speed"]))
    stream = RideClassifier(model)
    for row in rows:  # warm-up: compiled kernels
        stream.update(*row)
    stream.reset()
    us = latencies_us(lambda row: stream.update(*row), rows)
    print_row(f"RideClassifier.update, raw sample ({len(rows)} samples, d={atoms.shape[1]})", us)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=200_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    print(f"# crc_speed  {date.today()}  {machine()}")
    atoms, labels, windows = problem(args.seed, args.windows)
    print(f"d={D}, dictionary {len(atoms)} columns in {CLASSES} classes, {len(windows)} windows; "
          f"GEMM flops per window {FLOPS_PER_WINDOW}")
    gemm = gemm_rates(args.repeats)
    for (dtype, threads), rate in gemm.items():
        print(f"GEMM 2000^3 {dtype}, {threads} thread(s): {rate:.1f} GFLOP/s")

    print(f"{'batch path':<44} {'threads':>7} {'windows/s':>12} {'GFLOP/s':>8} {'% GEMM':>7}")

    def print_rate(name, call, dtype, threads):
        call()  # warm-up
        rate = len(windows) / best_seconds(call, args.repeats)[0]
        flops = rate * FLOPS_PER_WINDOW / 1e9
        print(f"{name:<44} {threads:>7} {rate:>12,.0f} {flops:>8.1f} {100 * flops / gemm[dtype, threads]:>6.0f}%")

    clf64, clf32 = (CRCClassifier(dtype=dtype).fit(atoms, labels) for dtype in ("float64", "float32"))
    operators = clf64.residual_operators_

    def plain():
        return np.linalg.norm(np.einsum("cij,nj->nci", operators, windows), axis=2)

    print_rate("plain einsum, float64", plain, "float64", 1)
    for threads in (1, 2):
        for clf in (clf64, clf32):
            clf.set_params(n_jobs=threads)
            print_rate(f"decision_function, {clf.dtype}", lambda: clf.decision_function(windows), clf.dtype, threads)
        print_rate("predict (labels), float64", lambda: clf64.predict(windows), "float64", threads)
    exact = plain()
    for clf in (clf64, clf32):
        error = np.abs(clf.decision_function(windows) - exact)
        print(f"{clf.dtype}: max |r - r_plain| / r_plain = {np.max(error / exact):.1e}, "
              f"/ ||y|| = {np.max(error / np.linalg.norm(windows, axis=1)[:, None]):.1e}")

    print(f"{'single window':<58} {'median us':>10} {'p99 us':>8}")

    def print_row(name, us):
        print(f"{name:<58} {np.median(us):>10.2f} {np.percentile(us, 99):>8.2f}")

    print_row("CRC predict_one (compiled, float64)", latencies_us(clf64.predict_one, windows[:20000]))
    print_row("CRC predict on a one-row matrix (generic path)",
              latencies_us(lambda y: clf64.predict(y[np.newaxis]), windows[:2000]))
    stream_rows(print_row)


if __name__ == "__main__":
    main()
