"""Per-sample latency of streaming ride classification (``RideClassifier.update``), beside its parts and peers.

Model: trained by the ``braking`` preset (channels acc_long, pitch_rate; hankel windows of 20
samples, so d = 40) on the first 25 s of a simulated normal-braking ride (seed 0) and of a sudden-braking ride
(seed 1), read from CSV like ``spotfree train`` does. Test data: two simulated sudden-braking rides (seed 7), raw
device-frame IMU at 20 Hz with GPS speed on the fixes.

Every row times single calls with ``time.perf_counter_ns`` after one warm-up pass (compiled kernels loaded):

* ``RideClassifier.update <method>``: one raw sample in, one label out (features, ring-buffer window, scaling,
  affine row, classifier). The default method (kernel CRC_RLS) runs over the rides ``--passes`` times, CRC_RLS over
  them once, the others over their first ``--sparse`` samples (SRC and B_SRC solve an optimisation per window;
  their convergence warnings are counted).
* ``FeatureStream.update``: the ride features alone (attitude filter, low-pass, lean, speed-aided acc_long), the
  floor under the end-to-end figure.
* ``crc`` / ``kcrc predict_one``, ``crc predict (one-row matrix)``: the classifiers alone on the windows of the rides,
  their single-window path and the generic scikit-learn path that the stream would otherwise take (first
  ``--short`` windows).
* ``classify_recording (batch), per sample``: the batch path on the same rides (features, windows, classifier),
  wall time over samples, with the stream's fitted classifier (fitting is outside every row).

The stream's labels are checked against the batch path's (causal) on the same rides.

Run: ``python benchmarks/stream_speed.py`` (about half a minute, most of it training).
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numba
import numpy as np
from threadpoolctl import threadpool_info

from machine import results_file
from spotfree.classify import DEFAULT_METHOD, METHODS
from spotfree.classify.batch import classify_recording, dictionary_classifier, model_affine, model_features
from spotfree.classify.stream import RideClassifier
from spotfree.io.csvlog import write_csv
from spotfree.pipeline import feature_recording
from spotfree.signal.features import FeatureStream
from spotfree.sim.scenarios import simulate_scenario
from spotfree.presets import preset_learner
from spotfree.windows import ChannelScaling, recording_windows, with_affine_row

GOAL_US = 50.0
"""Median per raw sample, end to end (issue 4)."""


def trained_model():
    """The model of the module docstring."""
    recordings, sets = [], []
    with tempfile.TemporaryDirectory() as folder:
        for scenario, seed, classes in (("normal-braking", 0, ["cruising", "normal-braking"]),
                                        ("sudden-braking", 1, ["cruising", "normal-braking", "sudden-braking"])):
            path = Path(folder) / f"{scenario}.csv"
            write_csv(simulate_scenario(scenario, repeats=1, seed=seed).take(slice(0, 500)), path)
            recordings.append(feature_recording(str(path)))
            sets.append(classes)
    return preset_learner("braking", seed=0).fit(recordings, sets).model_


def samples(rec):
    """``(acc, gyr, time, speed)`` rows of a raw Recording."""
    return list(zip(rec.array(["ax", "ay", "az"]), rec.array(["gx", "gy", "gz"]), rec.time, rec.channels["speed"]))


def timed(call, rows, reset=None, passes=1) -> tuple[np.ndarray, list]:
    """Nanoseconds of every ``call(*row)`` over ``passes`` passes (``reset()`` before each), and the last pass's
    results."""
    ns, out = [], []
    for _ in range(passes):
        if reset is not None:
            reset()
        out = []
        for row in rows:
            start = time.perf_counter_ns()
            result = call(*row)
            ns.append(time.perf_counter_ns() - start)
            out.append(result)
    return np.array(ns, dtype=float), out


def machine() -> str:
    model = next((line.split(":", 1)[1].strip() for line in subprocess.run(
        ["lscpu"], capture_output=True, text=True).stdout.splitlines() if line.startswith("Model name")),
        platform.processor())
    blas = ", ".join(f"{i['internal_api']} {i.get('version')} ({i.get('architecture')}, {i['num_threads']} threads)"
                     for i in threadpool_info() if i["user_api"] == "blas")
    return (f"{model}, {os.cpu_count()} cores, shared; Python {platform.python_version()}, numpy {np.__version__}, "
            f"numba {numba.__version__}; BLAS {blas}; OPENBLAS_CORETYPE "
            f"{os.environ.get('OPENBLAS_CORETYPE', 'not set')}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--passes", type=int, default=3, help="passes over the rides for the CRC rows")
    parser.add_argument("--short", type=int, default=300, help="windows for the one-row-matrix CRC row")
    parser.add_argument("--sparse", type=int, default=60, help="samples for the SRC and B_SRC rows")
    args = parser.parse_args()
    with results_file("stream_speed", "Per-sample latency of streaming classification", preformatted=True):
        _run(args)


def _run(args) -> None:
    """The latency table of :func:`main`."""
    started = time.perf_counter()
    model = trained_model()
    rides = simulate_scenario("sudden-braking", repeats=2, seed=7)
    rows = samples(rides)
    print(f"# stream_speed, {datetime.date.today()}: {machine()}; load average {os.getloadavg()[0]:.1f}")
    print(f"model: {model.dictionary.shape[1]} columns of {model.dictionary.shape[0]} (+1 affine) rows, classes "
          f"{', '.join(model.classes)}; rides: {len(rides)} samples at {rides.rate:g} Hz; training took "
          f"{time.perf_counter() - started:.1f} s")

    stream = RideClassifier(model)
    features = FeatureStream(model.rate, model.orientation, derived=True)
    feature_rows = [(a, g, v) for a, g, _, v in rows]
    timed(stream.update, rows, stream.reset)  # warm-up: compiled kernels
    timed(features.update, feature_rows, features.reset)
    ns_stream, ns_features = [], []
    for _ in range(args.passes):  # interleaved, so that both see the same load
        ns, labels = timed(stream.update, rows, stream.reset)
        ns_stream.append(ns)
        ns_features.append(timed(features.update, feature_rows, features.reset)[0])
    ns_features = np.concatenate(ns_features)
    table = [(f"RideClassifier.update {DEFAULT_METHOD} (default; end to end)", "raw sample",
              np.concatenate(ns_stream)),
             ("FeatureStream.update (features alone)", "raw sample", ns_features)]
    batch_start = time.perf_counter_ns()
    batch = classify_recording(model, rides, classifier=stream.classifier_)
    batch_ns = (time.perf_counter_ns() - batch_start) / len(rides)
    differ = int(np.sum(np.array([x or "" for x in labels], dtype=object) != batch.label))

    feats = model_features(model, rides)
    windows = recording_windows(feats, tuple(model.channels), model.window, 1,
                                ChannelScaling(tuple(model.channels), model.scale), model.normalisation)
    windows = with_affine_row(windows.matrix, model_affine(model)).T.copy()
    for method in ("crc", "kcrc"):
        clf = dictionary_classifier(model, method)
        table.append((f"{method} predict_one (classifier alone)", "window",
                      timed(clf.predict_one, [(y,) for y in windows], passes=args.passes)[0]))
    crc = dictionary_classifier(model, "crc")
    table.append(("crc predict, one-row matrix (classifier alone)", "window",
                  timed(lambda y: crc.predict(y[None, :]), [(y,) for y in windows[:args.short]])[0]))
    unconverged = 0
    for method in sorted(set(METHODS) - {DEFAULT_METHOD}):
        other = RideClassifier(model, method=method)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            timed(other.update, rows[:model.window + 5], other.reset)
            ns_other = timed(other.update, rows if method == "crc" else rows[:args.sparse], other.reset)[0]
        unconverged += len(caught)
        table.append((f"RideClassifier.update {method} (end to end)", "raw sample", ns_other))

    floor = np.median(ns_features)
    print()
    print("| path | per | calls | median (us) | p90 (us) | p99 (us) | median / FeatureStream |")
    print("|---|---|---:|---:|---:|---:|---:|")
    for name, per, values in table:
        print(f"| {name} | {per} | {len(values)} | {np.median(values) / 1e3:.1f} | "
              f"{np.percentile(values, 90) / 1e3:.1f} | {np.percentile(values, 99) / 1e3:.1f} | "
              f"{np.median(values) / floor:.2f} |")
    print(f"| classify_recording {DEFAULT_METHOD} (batch), wall time / samples | raw sample | {len(rides)} | "
          f"{batch_ns / 1e3:.1f} "
          f"| | | {batch_ns / floor:.2f} |")
    print()
    end_to_end = np.median(table[0][2]) / 1e3
    print(f"- end to end median {end_to_end:.1f} us per raw sample: "
          f"{'within' if end_to_end <= GOAL_US else 'above'} the {GOAL_US:g} us goal; "
          f"classification and windowing add {end_to_end - floor / 1e3:.1f} us to the features")
    print(f"- SRC / B_SRC warnings (windows not converged) while timed: {unconverged}")
    print(f"- stream labels differing from the batch (causal) labels on the same rides: {differ} of {len(rides)}")


if __name__ == "__main__":
    sys.exit(main())
