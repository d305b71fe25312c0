"""The default classifier, kernel CRC_RLS, beside CRC_RLS: batch windows per second, live microseconds per window and
three ride models per raw sample, all in one run (issue 35, part 4).

Models: braking, lateral and road of ``multi_model_speed.py`` (trained on development seed 100, or loaded from
``--models DIR``); braking is learnt by the ``braking`` preset, as the default model is. Windows: every model's
classifier inputs (a window at every sample, represented, with the affine row) of two simulated rides (seed 7):
sudden-braking rides for braking, lateral rides for lateral and road. Classifiers are fitted on the causal columns,
as a stream uses them.

Rows, per model and method (``kcrc``, the default, and ``crc``):

* batch: ``predict`` on the windows tiled to ``--windows`` rows, windows per second, best of ``--repeats`` after one
  untimed call, with one thread and with one per core (``n_jobs``; input validation included); and, on one thread,
  windows per CPU-second of the process (``time.process_time``), the rate of a core that is not shared;
* live: ``predict_one`` on every window of the rides, one call timed at a time (median and 99th percentile, us), in
  the pass of least median of ``--passes`` passes that take every model and method in turn;
* per raw sample: ``MultiModelStream.update`` with the three models (one feature pass, three windows), median and
  99th percentile over ``--passes`` passes over the raw rides, the two methods interleaved;
* yardstick: the machine's float64 matrix product (``2000 x 2000``, 1 and 2 threads), measured in the same run.

Checks: the kernel CRC_RLS labels of ``predict`` equal those of ``predict_one`` on every window; the stream's labels
equal the batch table (``spotfree.evaluation.ride_models.stream_cost``). Goals: at least 1,000,000 windows per second
in batch and under 10 us median per window live for kernel CRC_RLS, and under 50 us median per raw sample for the
three models together. ``--baseline REV`` first runs the batch and live rows on spotfree as it was at git revision
``REV`` (:mod:`baseline`), for the speed-up, on the same model files or on those of ``--baseline-models DIR`` (models
trained by that revision, when it trained them differently). The machine is shared: the load average is printed at
the start.

Writes ``benchmarks/results/crc_speed.md`` (command, machine, date, output).

Run: ``python benchmarks/crc_speed.py [--windows 200000] [--repeats 5] [--passes 3] [--models DIR] [--baseline REV]
[--baseline-models DIR]``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits

from classifier_timing import best_seconds
from machine import describe
from multi_model_speed import load_or_train, timed
from spotfree.classify.batch import dictionary_classifier, model_features
from spotfree.classify.multi import MultiModelStream
from spotfree.evaluation.ride_models import raw_samples, stream_cost
from spotfree.sim.scenarios import simulate_scenario
from spotfree.windows import ChannelScaling, recording_windows

RESULTS = Path(__file__).resolve().parent / "results" / "crc_speed.md"
METHODS = ("kcrc", "crc")
BATCH_GOAL = 1_000_000
"""Windows per second in batch (issue 35)."""
LIVE_GOAL_US = 10.0
"""Median microseconds per window, live (issue 35)."""
SAMPLE_GOAL_US = 50.0
"""Median microseconds per raw sample, three models on one stream (issue 35)."""


def model_windows(models: dict) -> dict[str, np.ndarray]:
    """Each model's classifier inputs ``(n, d)`` at every sample of its rides (module docstring)."""
    rides = {"braking": simulate_scenario("sudden-braking", repeats=2, seed=7),
             "lateral": simulate_scenario("lateral", repeats=2, seed=7)}
    out = {}
    for name, model in models.items():
        feats = model_features(model, rides["braking" if name == "braking" else "lateral"])
        windows = recording_windows(feats, tuple(model.channels), model.window, 1,
                                    ChannelScaling(tuple(model.channels), model.scale), model.normalisation)
        out[name] = model.inputs(windows.matrix)
    return out


def best_rate(call, rows: int, repeats: int) -> float:
    """Rows per second of ``call()``, best of ``repeats`` after one untimed call."""
    call()
    return rows / best_seconds(call, repeats)[0]


def cpu_rate(call, rows: int, repeats: int) -> float:
    """Rows per CPU-second of this process (every thread) of ``call()``, best of ``repeats``: what the call would do
    on free cores, less what sharing them costs beyond waiting (caches, clock)."""
    seconds = np.inf
    for _ in range(repeats):
        start = time.process_time()
        call()
        seconds = min(seconds, time.process_time() - start)
    return rows / seconds


def live_latencies_us(classifiers: dict, windows: dict, passes: int) -> dict:
    """``{(model, method): us}``: microseconds of each ``predict_one`` call (:func:`multi_model_speed.timed`) on
    every window of the model, in the pass of least median; the ``passes`` passes go over every model and method in
    turn, after one untimed pass over the first windows, so that a slow spell of the shared machine falls on all of
    them (it only adds time, as for the batch rows' best of repeats)."""
    rows = {name: [(x,) for x in windows[name]] for name, _ in classifiers}
    for (name, _), clf in classifiers.items():
        timed(clf.predict_one, rows[name][:50])
    passes_us: dict = {key: [] for key in classifiers}
    for _ in range(passes):
        for (name, method), clf in classifiers.items():
            passes_us[name, method].append(timed(clf.predict_one, rows[name]))
    return {key: min(us, key=np.median) for key, us in passes_us.items()}


def classifier_rows(models: dict, windows: dict, n_windows: int, repeats: int, passes: int) -> dict:
    """``{model: {method: figures}}``: batch windows/s per thread count, live median and p99 us
    (:func:`live_latencies_us`), and for kernel CRC_RLS the windows whose ``predict`` and ``predict_one`` labels
    differ."""
    out: dict = {name: {} for name in models}
    classifiers = {}
    for name, model in models.items():
        tiled = np.tile(windows[name], (n_windows // len(windows[name]) + 1, 1))[:n_windows]
        for method in METHODS:
            clf = classifiers[name, method] = dictionary_classifier(model, method, causal=True)
            figures = out[name][method] = {"d": tiled.shape[1]}
            for threads in (1, -1):
                if "n_jobs" in clf.get_params():  # an older kernel CRC_RLS (--baseline) has no n_jobs
                    clf.set_params(n_jobs=threads)
                elif threads == 1:
                    continue
                figures[f"batch {threads}"] = best_rate(lambda: clf.predict(tiled), len(tiled), repeats)
                if threads == 1:
                    figures["cpu"] = cpu_rate(lambda: clf.predict(tiled), len(tiled), repeats)
            if method == "kcrc":
                one = np.array([str(clf.predict_one(y)) for y in windows[name]])
                figures["differ"] = int(np.sum(one != clf.predict(windows[name]).astype(str)))
    for (name, method), us in live_latencies_us(classifiers, windows, passes).items():
        out[name][method]["live"] = [float(np.median(us)), float(np.percentile(us, 99))]
    return out


def multiply_adds(clf, windows: np.ndarray) -> float:
    """Multiply-adds per window of ``clf.predict`` on ``windows``: ``C d^2`` for CRC_RLS; for kernel CRC_RLS the kernel
    row ``m (d + 2)``, the bounds ``C h m`` and ``(f - h) m`` per completed class, counted on these windows (the
    classes its ranking leaves finite)."""
    if not hasattr(clf, "head_"):
        return len(clf.classes_) * windows.shape[1] ** 2
    m, f, h = len(clf.landmarks_), len(clf.normalisation_), clf.head_
    completed = np.isfinite(clf._ranked(windows, False)[0]).sum(axis=1).mean()
    return m * (windows.shape[1] + 2) + len(clf.classes_) * h * m + completed * (f - h) * m


def per_sample_rows(models: dict, samples: list, passes: int) -> dict[str, np.ndarray]:
    """Microseconds per ``MultiModelStream.update`` for each method, ``passes`` interleaved passes after one untimed
    pass."""
    streams = {method: MultiModelStream(models, method=method) for method in METHODS}
    times: dict[str, list] = {method: [] for method in METHODS}
    for k in range(passes + 1):  # the first pass warms up
        for method, stream in streams.items():
            stream.reset()
            us = timed(stream.update, samples)
            if k:
                times[method].append(us)
    return {method: np.concatenate(parts) for method, parts in times.items()}


def gemm_rates(repeats: int) -> dict[int, float]:
    """GFLOP/s of a float64 ``2000 x 2000`` matrix product per thread count."""
    a = np.random.default_rng(0).random((2000, 2000))
    rates = {}
    for threads in (1, 2):
        with threadpool_limits(threads, user_api="blas"):
            rates[threads] = 2 * 2000 ** 3 * best_rate(lambda: a @ a, 1, repeats) / 1e9
    return rates


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--windows", type=int, default=200_000, help="rows of the batch rows")
    parser.add_argument("--repeats", type=int, default=5, help="batch calls timed per row (the best is kept)")
    parser.add_argument("--passes", type=int, default=3, help="passes over the rides for the live and per-sample rows")
    parser.add_argument("--models", type=Path, help="folder of braking.npz, lateral.npz, road.npz (written if missing)")
    parser.add_argument("--baseline", help="git revision whose spotfree runs the batch and live rows first")
    parser.add_argument("--baseline-models", type=Path,
                        help="folder of the models the --baseline run loads (default: those of --models), e.g. "
                             "models trained by that revision")
    parser.add_argument("--json", action="store_true", help="print only the batch and live figures, as JSON")
    args = parser.parse_args()
    if args.windows < 1 or args.repeats < 1 or args.passes < 1:
        parser.error("--windows, --repeats and --passes take numbers >= 1")
    with tempfile.TemporaryDirectory() as scratch:
        folder = args.models or Path(scratch)
        models = load_or_train(folder)
        windows = model_windows(models)
        if args.json:
            print(json.dumps(classifier_rows(models, windows, args.windows, args.repeats, args.passes)))
            return
        old = None
        if args.baseline:
            from baseline import run_at_revision

            old = run_at_revision(args.baseline, __file__, ["--json", "--windows", str(args.windows), "--repeats",
                                                            str(args.repeats), "--passes", str(args.passes),
                                                            "--models", str(args.baseline_models or folder)])
        lines = [f"machine: {describe(('numpy', 'scipy', 'scikit-learn', 'numba'))}",
                 "BLAS: " + ", ".join(f"{i['internal_api']} {i.get('version')} ({i.get('architecture')})"
                                      for i in threadpool_info() if i["user_api"] == "blas")
                 + f"; OPENBLAS_CORETYPE {os.environ.get('OPENBLAS_CORETYPE', 'not set')}"]
        rates = gemm_rates(args.repeats)
        lines += [f"GEMM float64 2000^3: {rates[1]:.0f} GFLOP/s on 1 thread, {rates[2]:.0f} on 2"]
        rows = classifier_rows(models, windows, args.windows, args.repeats, args.passes)
        rides = simulate_scenario("lateral", repeats=2, seed=7)
        per_sample = per_sample_rows(models, raw_samples(rides), args.passes)
        differ = stream_cost(models, rides).differing
        lines += report(models, windows, rows, rates[1], per_sample, differ, len(rides), old, args.baseline)
    text = "\n".join(lines)
    print(text)
    command = " ".join(["python", "benchmarks/crc_speed.py", *sys.argv[1:]])
    RESULTS.write_text(f"# Kernel CRC_RLS (the default) beside CRC_RLS: batch, live, three models per raw sample\n\n"
                       f"- command: `{command}`\n"
                       f"- date: {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC\n\n{text}\n")


def report(models: dict, windows: dict, rows: dict, gemm: float, per_sample: dict, differ: int, n_samples: int,
           old: dict | None, revision: str | None) -> list[str]:
    """The tables and the goals, as lines of Markdown; ``gemm``: the machine's GFLOP/s on one thread."""
    lines, ceilings = [], []
    for name, model in models.items():
        clf = dictionary_classifier(model, "kcrc", causal=True)
        work = {method: multiply_adds(dictionary_classifier(model, method, causal=True), windows[name])
                for method in METHODS}
        lines.append(f"model {name}: {model.representation} windows of {model.window} samples, d = "
                     f"{rows[name]['kcrc']['d']}, {model.dictionary.shape[1]} columns, {len(model.classes)} classes; "
                     f"kernel CRC_RLS: {len(clf.landmarks_)} landmarks, {len(clf.normalisation_)} features, "
                     f"{work['kcrc']:,.0f} multiply-adds per window in predict; CRC_RLS {work['crc']:,.0f}")
        ceilings.append(f"{name} kcrc {gemm * 1e9 / 2 / work['kcrc']:,.0f}, crc {gemm * 1e9 / 2 / work['crc']:,.0f}")
    head = "| " + " | ".join(["model", "method", "batch windows/s, 1 thread", "batch windows/s, 2 threads",
                              "batch windows per CPU-second, 1 thread", "live median us/window",
                              "live p99 us/window"]) + " |"
    rule = "|---|---|---:|---:|---:|---:|---:|"
    if old is not None:
        head += f" batch 2 threads at {revision} | live median at {revision} | batch speed-up | live speed-up |"
        rule += "---:|---:|---:|---:|"
    lines += ["", head, rule]
    for name, methods in rows.items():
        for method, f in methods.items():
            line = (f"| {name} | {method} | {f.get('batch 1', np.nan):,.0f} | {f['batch -1']:,.0f} | "
                    f"{f.get('cpu', np.nan):,.0f} | {f['live'][0]:.2f} | {f['live'][1]:.2f} |")
            if old is not None:
                before = old[name][method]
                line += (f" {before['batch -1']:,.0f} | {before['live'][0]:.2f} | "
                         f"{f['batch -1'] / before['batch -1']:.1f}x | {before['live'][0] / f['live'][0]:.1f}x |")
            lines.append(line)
    lines += ["", "| three models on one stream | calls | median us per raw sample | p99 us |", "|---|---:|---:|---:|"]
    for method, us in per_sample.items():
        lines.append(f"| MultiModelStream.update, {method} | {len(us)} | {np.median(us):.1f} | "
                     f"{np.percentile(us, 99):.1f} |")
    kcrc = {name: methods["kcrc"] for name, methods in rows.items()}
    default = kcrc["braking"]
    batch = max(default.get("batch 1", 0.0), default["batch -1"])
    slowest = max(f["live"][0] for f in kcrc.values())
    sample = float(np.median(per_sample["kcrc"]))

    def met(ok: bool) -> str:
        return "met" if ok else "NOT met"

    lines += ["",
              f"- goal batch >= {BATCH_GOAL:,} windows/s (kcrc, the default braking model, best thread count): "
              f"{batch:,.0f}, {met(batch >= BATCH_GOAL)} ({default['cpu']:,.0f} per CPU-second on one thread); "
              "other models: "
              + ", ".join(f"{n} {max(f.get('batch 1', 0.0), f['batch -1']):,.0f}" for n, f in kcrc.items()
                          if n != "braking")
              + f"; CRC_RLS on the default model in the same run: "
                f"{max(rows['braking']['crc'].get('batch 1', 0.0), rows['braking']['crc']['batch -1']):,.0f}",
              f"- goal live < {LIVE_GOAL_US:g} us median per window (kcrc, every model): slowest {slowest:.2f} us, "
              f"{met(slowest < LIVE_GOAL_US)}",
              f"- goal three models < {SAMPLE_GOAL_US:g} us median per raw sample (kcrc): {sample:.1f} us, "
              f"{met(sample < SAMPLE_GOAL_US)} (crc: {np.median(per_sample['crc']):.1f} us)",
              f"- ceiling of one core at this run's one-thread GEMM rate ({gemm:.0f} GFLOP/s) for the multiply-adds "
              f"above, windows/s: {'; '.join(ceilings)}",
              "- kcrc predict vs predict_one, windows with differing labels: "
              + ", ".join(f"{n} {f['differ']}" for n, f in kcrc.items()),
              f"- stream labels differing from the batch table (3 models x {n_samples} samples): {differ}"]
    return lines


if __name__ == "__main__":
    main()
