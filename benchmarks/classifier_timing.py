"""The paper's timing table, measured: CRC_RLS vs SRC vs B_SRC classifying 1000 windows; accuracy and rejection.

Dictionary and test windows come from simulated rides (``spotfree.sim``): ``normal-braking`` and ``sudden-braking``
files (7 experiments each), ride features with the derived channels: the ride models' channels ``acc_long,
pitch_rate`` scaled by their training standard deviation, windows of 20 samples, 1 s at 20 Hz, and the constant row
6 appended, so ``d = 41``. Each window takes the
hidden ground-truth label of its centre sample (the benchmark's own labelling; training in spotfree never reads
it). Atoms: ``--atoms`` per class, evenly over time, from experiments 1-3 of both files; test: ``--windows``
windows drawn at random (seeded) from experiments 4-7, in the classes' natural proportions.

Rejection: windows that no class owns are the ``cobblestone`` stretches of a ``road`` ride (vibration the
dictionary has never seen) and, separately, windows of a fourth random subspace in synthetic union-of-subspaces
data. For each method, the area under the ROC curve of two scores telling those windows from the known test
windows: ``min_i r_i / ||y||`` (share of the window left unexplained) and ``min_i r_i / second-smallest r_i``
(ambiguity between the two best classes).

Times: ``decision_function`` on the test windows, one call (CRC: best of 5 after an untimed one), ``--threads``
threads.

    python benchmarks/classifier_timing.py [--windows 1000] [--atoms 100] [--threads 1] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import platform
import time
import warnings
from datetime import date

import numpy as np
from sklearn.metrics import roc_auc_score
from threadpoolctl import threadpool_info, threadpool_limits

from machine import results_file
from spotfree.classify import make_classifier
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import simulate_scenario
from spotfree.presets import PRESETS
from spotfree.windows import ChannelScaling, recording_windows, with_affine_row

CHANNELS, WINDOW, AFFINE = PRESETS["braking"]["channels"], PRESETS["braking"]["window"], 6.0
"""The ride models' channels, window (samples) and the paper's affine row (as the CRC / SRC / B_SRC comparison of
``spotfree evaluate`` stacks it)."""
CLASSES = ("cruising", "normal-braking", "sudden-braking")
PAPER_SECONDS = {"crc": 0.39, "bsrc": 112.0}
METHODS = {  # label in the table: (method, parameters)
    "CRC_RLS": ("crc", {}),  # n_jobs set from --threads
    "SRC (LARS)": ("src", {"algorithm": "lasso_lars"}),
    "SRC (CD)": ("src", {"algorithm": "lasso_cd"}),
    "B_SRC (group lasso)": ("bsrc", {}),
}


def labelled_windows(rec, scaling):
    """Windows ``(m, d)`` of ``rec``, the truth label of each window's centre sample, and its experiment."""
    w = recording_windows(rec, CHANNELS, WINDOW, scaling=scaling)
    centre = w.ends - WINDOW // 2
    return with_affine_row(w.matrix, AFFINE).T, rec.truth["label"][centre], w.experiment


def ride_data(seed: int, n_atoms: int, n_test: int):
    """Atoms, their labels, test windows, their labels, outside (cobblestone) windows, and the channel scaling."""
    recs = [ride_features(simulate_scenario(s, repeats=7, seed=seed + k), derived=True)
            for k, s in enumerate(("normal-braking", "sudden-braking"))]
    train_recs = [r.select_experiment(e) for r in recs for e in (1, 2, 3)]
    scaling = ChannelScaling(CHANNELS).fit(train_recs)
    parts = [labelled_windows(r, scaling) for r in recs]
    X = np.vstack([p[0] for p in parts])
    label = np.concatenate([p[1] for p in parts])
    experiment = np.concatenate([p[2] for p in parts])
    train = experiment <= 3
    atoms = []
    for c in CLASSES:
        index = np.flatnonzero(train & (label == c))
        atoms.append(index[np.linspace(0, len(index) - 1, n_atoms).round().astype(int)])
    atoms = np.concatenate(atoms)
    rng = np.random.default_rng(seed)
    test = rng.choice(np.flatnonzero(~train), size=n_test, replace=False)
    road = ride_features(simulate_scenario("road", repeats=7, seed=seed + 2), derived=True)
    Xr, label_r, _ = labelled_windows(road, scaling)
    outside = Xr[label_r == "cobblestone"]
    outside = outside[rng.choice(len(outside), size=min(n_test, len(outside)), replace=False)]
    return X[atoms], label[atoms], X[test], label[test], outside, scaling


def subspace_data(seed: int, d: int = 41, rank: int = 5, n_atoms: int = 100, n_test: int = 300, noise: float = 1.0):
    """Union of three random ``rank``-dimensional subspaces (unit-variance coordinates) plus isotropic noise of
    expected norm ``noise``; the out-of-class windows come from a fourth subspace."""
    rng = np.random.default_rng(seed)
    bases = [np.linalg.qr(rng.normal(size=(d, rank)))[0] for _ in range(4)]

    def draw(basis, n):
        return (basis @ rng.normal(size=(rank, n))).T + noise * rng.normal(size=(n, d)) / np.sqrt(d)

    X = np.vstack([draw(b, n_atoms) for b in bases[:3]])
    test = np.vstack([draw(b, n_test // 3) for b in bases[:3]])
    return X, np.repeat(CLASSES, n_atoms), test, np.repeat(CLASSES, n_test // 3), draw(bases[3], n_test)


def machine(threads: int | None = None) -> str:
    """CPU, cores, load average and numpy's BLAS, for the header line."""
    cpu = next((line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name")),
               platform.machine())
    blas = next(i for i in threadpool_info() if i["user_api"] == "blas" and "numpy" in i["filepath"])
    return (f"{cpu}, {os.cpu_count()} cores (shared), load average {os.getloadavg()[0]:.1f}; numpy {np.__version__}, "
            f"BLAS {blas['internal_api']} {blas['version']} ({blas['architecture']}), OPENBLAS_CORETYPE "
            f"{os.environ.get('OPENBLAS_CORETYPE', 'not set')}" + (f"; {threads} thread(s)" if threads else ""))


def best_seconds(call, repeats: int) -> tuple[float, object]:
    """Shortest wall time of ``repeats`` calls, and the last call's result."""
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    return min(times), result


def rejection_auc(residuals_known, residuals_outside, X_known, X_outside):
    """AUC of ``r_min / ||y||`` and of ``r_min / r_second`` for telling outside windows from known ones."""
    def scores(residuals, X):
        r = np.sort(residuals, axis=1)
        return r[:, 0] / np.linalg.norm(X, axis=1), r[:, 0] / r[:, 1]

    known, outside = scores(residuals_known, X_known), scores(residuals_outside, X_outside)
    truth = np.r_[np.zeros(len(X_known)), np.ones(len(X_outside))]
    return [roc_auc_score(truth, np.r_[k, o]) for k, o in zip(known, outside)]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=1000)
    parser.add_argument("--atoms", type=int, default=100)
    parser.add_argument("--threads", type=int, default=1, help="threads (BLAS, and CRC's n_jobs)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    with results_file("classifier_timing", "CRC_RLS, SRC and B_SRC on the same windows (the paper's timing table)",
                      preformatted=True):
        _run(args)


def _run(args) -> None:
    """The timing table of :func:`main`."""
    print(f"# classifier_timing  {date.today()}  {machine(args.threads)}")
    atoms, atom_label, X, truth, outside, _ = ride_data(args.seed, args.atoms, args.windows)
    print(f"channels {', '.join(CHANNELS)}, window {WINDOW}, affine row {AFFINE:g}; "
          f"dictionary {len(atoms)} atoms x d={atoms.shape[1]} ({args.atoms} per class); test {len(X)} windows: "
          + ", ".join(f"{c} {np.sum(truth == c)}" for c in CLASSES) + f"; outside (cobblestone) {len(outside)}")
    synth = subspace_data(args.seed)
    header = (f"{'method':<20} {'fit s':>7} {'predict s':>10} {'x CRC':>7} {'paper s':>8} {'accuracy':>9} "
              + " ".join(f"{c[:6]:>7}" for c in CLASSES)
              + f" {'AUC r/|y|':>10} {'AUC r1/r2':>10} {'syn r/|y|':>10} {'syn r1/r2':>10} {'unconv':>7}")
    print(header)
    crc_time = None
    with threadpool_limits(args.threads, user_api="blas"):
        for name, (method, params) in METHODS.items():
            start = time.perf_counter()
            params = params | ({"n_jobs": args.threads} if method == "crc" else {})
            clf = make_classifier(method, **params).fit(atoms, atom_label)
            fit_s = time.perf_counter() - start
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                if method == "crc":
                    clf.decision_function(X)  # first call: thread pool and compiled code loaded
                predict_s, residuals = best_seconds(lambda: clf.decision_function(X), 5 if method == "crc" else 1)
            unconverged = sum(int(str(w.message).split()[0]) for w in caught if "not converged" in str(w.message))
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                residuals_out = clf.decision_function(outside)
                syn = make_classifier(method, **params).fit(synth[0], synth[1])
                syn_auc = rejection_auc(syn.decision_function(synth[2]), syn.decision_function(synth[4]),
                                        synth[2], synth[4])
            crc_time = crc_time or predict_s
            labels = clf.classes_[np.argmin(residuals, axis=1)]
            recall = [np.mean(labels[truth == c] == c) for c in CLASSES]
            auc = rejection_auc(residuals, residuals_out, X, outside)
            paper = PAPER_SECONDS.get(method)
            print(f"{name:<20} {fit_s:>7.3f} {predict_s:>10.3f} {predict_s / crc_time:>7.0f} "
                  f"{paper if paper else '-':>8} {np.mean(labels == truth):>9.3f} "
                  + " ".join(f"{r:>7.3f}" for r in recall)
                  + f" {auc[0]:>10.3f} {auc[1]:>10.3f} {syn_auc[0]:>10.3f} {syn_auc[1]:>10.3f} {unconverged:>7}",
                  flush=True)


if __name__ == "__main__":
    main()
