"""Per-sample cost of running the braking, lateral and road models together on one stream (MultiModelStream).

Models: trained spotting-free on development seed 100: braking (the ``braking`` preset, experiment
1 of a normal-braking and of a sudden-braking ride), lateral and road
(:data:`spotfree.evaluation.lateral_road.MODELS`, each under its training protocol,
:func:`~spotfree.evaluation.lateral_road.spec_split`); or
loaded from ``--models DIR`` (``braking.npz``, ``lateral.npz``, ``road.npz``, written there when missing).
Data: two simulated lateral rides (seed 7), raw device-frame IMU at 20 Hz with GPS speed on the fixes.

Rows (single calls timed with ``time.perf_counter_ns`` after a warm-up pass; the passes are interleaved so that all
rows see the same machine load):

* ``MultiModelStream.update``: one raw sample in, three labels out (one feature pass, the windows of three models);
* ``RideClassifier.update`` per model: each model alone, end to end (its own feature pass);
* ``FeatureStream.update``: the ride features alone (16 channels), the floor under every row;
* where the code has them, the two compiled calls inside ``MultiModelStream.update``: ``FeatureStream.step`` (the
  features into a preallocated vector) and ``ModelRing.push`` (three windows and CRCs on precomputed features).

The three models' stream labels are checked against :func:`spotfree.classify.multi.classify_models`.
``--baseline REV`` runs the same rows on the same models and rides with spotfree as it was at git revision ``REV``
(:mod:`baseline`), just before this run's own rows, and prints the ratios. ``--profile`` adds the functions that
take the most time inside ``MultiModelStream.update`` (cProfile, one pass; the profiler's own cost inflates every
figure, the shares are what it is for).

Run: ``python benchmarks/multi_model_speed.py [--passes 3] [--models DIR] [--baseline REV] [--profile]``.
"""

from __future__ import annotations

import argparse
import cProfile
import datetime
import io
import json
import os
import platform
import pstats
import tempfile
import time
from pathlib import Path

import numpy as np

from machine import results_file
from spotfree.classify import DEFAULT_METHOD
from spotfree.classify.multi import MultiModelStream
from spotfree.classify.stream import PRODUCED, RideClassifier
from spotfree.evaluation.lateral_road import MODELS, spec_split
from spotfree.evaluation.ride_models import raw_samples, stream_cost
from spotfree.model import DictionaryModel
from spotfree.signal.features import FeatureStream, ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario
from spotfree.presets import preset_learner

GOAL_US = 50.0
"""Median per raw sample, end to end, all three models (issue 7)."""
SEED = 100
NAMES = ("braking", "lateral", "road")


def trained_models() -> dict:
    """The three models of the module docstring."""
    scenarios = ("normal-braking", "sudden-braking")
    braking = preset_learner("braking", seed=SEED).fit(
        [ride_features(simulate_scenario(s, repeats=1, seed=SEED), derived=True) for s in scenarios],
        [list(CLASSES[s]) for s in scenarios])
    models = {"braking": braking.model_}
    for name, spec in MODELS.items():
        recordings, sets = zip(*spec_split(spec, SEED).training)
        models[name] = spec.learner(SEED).fit(list(recordings), list(sets)).model_
    return models


def load_or_train(folder: Path) -> dict:
    """The models saved in ``folder``, trained and saved there first when any is missing."""
    paths = {name: folder / f"{name}.npz" for name in NAMES}
    if not all(p.exists() for p in paths.values()):
        folder.mkdir(parents=True, exist_ok=True)
        for name, model in trained_models().items():
            model.save(paths[name])
    return {name: DictionaryModel.load(p) for name, p in paths.items()}


def timed(step, samples) -> np.ndarray:
    """Microseconds of each ``step(*sample)`` call."""
    out = np.empty(len(samples))
    for k, sample in enumerate(samples):
        start = time.perf_counter_ns()
        step(*sample)
        out[k] = (time.perf_counter_ns() - start) / 1e3
    return out


def measure(models: dict, samples: list, passes: int) -> dict[str, np.ndarray]:
    """Microseconds per call of every row of the module docstring, ``passes`` interleaved passes."""
    multi = MultiModelStream(models)
    paper = MultiModelStream(models, method="crc")
    features = FeatureStream(20.0, derived=True)
    rows = [(f"MultiModelStream.update (3 models, {DEFAULT_METHOD}, the default; end to end)", multi.update,
             multi.reset, samples),
            ("MultiModelStream.update (3 models, crc; end to end)", paper.update, paper.reset, samples)]
    for name, model in models.items():
        alone = RideClassifier(model)
        rows.append((f"RideClassifier.update {name} alone (end to end)", alone.update, alone.reset, samples))
    rows.append(("FeatureStream.update (features alone)", lambda a, w, t, s: features.update(a, w, s),
                 features.reset, samples))
    ring = getattr(multi, "_ring", None)
    if ring is not None:  # the two compiled calls inside MultiModelStream.update, where the code has them
        floats = [(*a.tolist(), *w.tolist(), float(s)) for a, w, _, s in samples]
        out = np.zeros(len(PRODUCED))
        vectors = []
        for row in floats:
            features.step(*row, out)
            vectors.append((out.copy(),))
        rows.append(("FeatureStream.step (compiled features, no copy)", lambda *row: features.step(*row, out),
                     features.reset, floats))
        rows.append((f"ModelRing.push (3 windows + {DEFAULT_METHOD})", ring.push, ring.reset, vectors))
    for _, step, reset, inputs in rows:  # warm-up: compiled kernels loaded
        reset()
        timed(step, inputs[:50])
    times: dict[str, list[np.ndarray]] = {label: [] for label, *_ in rows}
    for _ in range(passes):
        for label, step, reset, inputs in rows:
            reset()
            times[label].append(timed(step, inputs))
    return {label: np.concatenate(parts) for label, parts in times.items()}


def profile(models: dict, samples: list, top: int = 12) -> str:
    """The ``top`` functions by own time inside ``MultiModelStream.update`` over one pass (cProfile)."""
    multi = MultiModelStream(models)
    for sample in samples[:50]:
        multi.update(*sample)
    multi.reset()
    profiler = cProfile.Profile()
    profiler.enable()
    for sample in samples:
        multi.update(*sample)
    profiler.disable()
    text = io.StringIO()
    pstats.Stats(profiler, stream=text).sort_stats("tottime").print_stats(top)
    return "\n".join(line for line in text.getvalue().splitlines() if line.strip())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--passes", type=int, default=3)
    parser.add_argument("--models", type=Path, help="folder of braking.npz, lateral.npz, road.npz (written if missing)")
    parser.add_argument("--baseline", help="git revision whose spotfree runs the same rows first, for ratios")
    parser.add_argument("--profile", action="store_true", help="cProfile of MultiModelStream.update, one pass")
    parser.add_argument("--json", action="store_true", help="print only the figures, as JSON (used by --baseline)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as scratch:
        start = time.perf_counter()
        models = load_or_train(args.models or Path(scratch))
        trained_s = time.perf_counter() - start
        rides = simulate_scenario("lateral", repeats=2, seed=7)
        samples = raw_samples(rides)
        if args.json:
            rows = measure(models, samples, args.passes)
            figures = {label: [len(us), *np.percentile(us, [50, 90, 99]).tolist()] for label, us in rows.items()}
            print(json.dumps({"load": os.getloadavg()[0], "rows": figures,
                              "profile": profile(models, samples) if args.profile else ""}))
            return
        old = None
        if args.baseline:
            from baseline import run_at_revision

            flags = ["--json", "--passes", str(args.passes), "--models", str(args.models or Path(scratch))]
            old = run_at_revision(args.baseline, __file__, flags + (["--profile"] if args.profile else []))
        with results_file("multi_model_speed", "Three ride models on one stream: cost per raw sample"):
            load = os.getloadavg()[0]
            rows = measure(models, samples, args.passes)
            report(args, models, samples, rows, load, trained_s, old)
            if args.profile:
                if old is not None:
                    print(f"\ncProfile of MultiModelStream.update at {args.baseline} (one pass):\n\n{old['profile']}")
                print(f"\ncProfile of MultiModelStream.update, this tree (one pass):\n\n{profile(models, samples)}")


def report(args, models: dict, samples: list, rows: dict, load: float, trained_s: float, old: dict | None) -> None:
    """Print the header, the table (with the baseline's figures and ratios when given) and the conclusions."""
    print(f"# multi_model_speed {datetime.datetime.now():%Y-%m-%d %H:%M}: {platform.processor() or platform.machine()}"
          f", {os.cpu_count()} cores (shared), load average {load:.1f}; Python {platform.python_version()}, numpy "
          f"{np.__version__}; OPENBLAS_CORETYPE {os.environ.get('OPENBLAS_CORETYPE', 'not set')}")
    for name, m in models.items():
        print(f"model {name}: channels {','.join(m.channels)}, window {m.window}, {m.dictionary.shape[1]} columns, "
              f"classes {', '.join(map(str, m.classes))}")
    print(f"rides: {len(samples)} samples at 20 Hz; models ready in {trained_s:.0f} s")
    if old is not None:
        print(f"baseline: spotfree at {args.baseline}, measured just before, load average {old['load']:.1f}")

    differ = stream_cost(models, simulate_scenario("lateral", repeats=2, seed=7)).differing

    floor = float(np.median(rows["FeatureStream.update (features alone)"]))
    head = "| path | calls | median (us) | p90 (us) | p99 (us) | median / FeatureStream |"
    rule = "|---|---:|---:|---:|---:|---:|"
    if old is not None:
        head += f" median at {args.baseline} (us) | p99 at {args.baseline} (us) | median speed-up |"
        rule += "---:|---:|---:|"
    print(f"\n{head}\n{rule}")
    for label, us in rows.items():
        p50, p90, p99 = np.percentile(us, [50, 90, 99])
        line = f"| {label} | {len(us)} | {p50:.1f} | {p90:.1f} | {p99:.1f} | {p50 / floor:.2f} |"
        if old is not None:
            before = old["rows"].get(label)
            line += (f" {before[1]:.1f} | {before[3]:.1f} | {before[1] / p50:.1f}x |" if before else " | | |")
        print(line)
    multi_median = float(np.median(next(us for label, us in rows.items() if label.startswith("MultiModelStream"))))
    print(f"\n- three models end to end: median {multi_median:.1f} us per raw sample "
          f"({'within' if multi_median <= GOAL_US else 'beyond'} the {GOAL_US:.0f} us goal)")
    print(f"- stream labels differing from the batch table (3 models x {len(samples)} samples): {differ}")


if __name__ == "__main__":
    main()
