"""Spotting-free learning on real recordings: the smartphone and smartwatch streams of ``../shared/data/sp_sw_har``.

Data: Matey-Sanz, Casteleyn and Granell, "Dataset of inertial measurements of smartphones and smartwatches for human
activity recognition", Data in Brief 109809 (2023), CC BY 4.0; 23 subjects, five activities (seated, standing up,
walking, turning, sitting down) in every recording, about 100 Hz, read here onto the 20 Hz grid of
:func:`spotfree.io.resample.merge_streams` (body channels of :mod:`spotfree.signal.body`).

Protocol (issue 31): the recordings of the first ``--train-subjects`` subjects are cut into clips of ``--clip``
seconds (each length a run of its own), each declared only with the set of classes in it (the learner never sees a
per-sample label; the longer the clips, the more of them declare the same set and the less the sets tell); the whole recordings of the other subjects are the test. Scores per sample, centred labels
(offline): balanced accuracy (mean of the per-class recalls) leaving out the samples within 0.5 s of a true change
("away"), and the strict figure beside; the same for live labels (each window labels its last sample, as a phone
labels a stream; the peers trained a second time on that alignment). The short transitions of :data:`EVENTS` are also scored as events
(:func:`spotfree.evaluation.metrics.event_detection`: a true run detected by a run of its label within 0.5 s, a run
that meets none a false alarm): precision, recall, F1 and false alarms per hour without that event. For the learner also the share of its training windows named right (its final name
of a window against the true label at the window's centre, :func:`named_right`): the naming of step 3, directly.

Methods in the same run:

* ``spotfree``: :class:`spotfree.learner.SetSupervisedLearner` with its defaults, class sets only, once per seed
  of ``--seeds`` (a summary below the table gives the mean and the range);
* ``spotfree, true names``: the same learner (first seed) with its naming (step 3) replaced by the true label at
  each window's centre (:class:`TrueNames`): the same windows, columns and classifier, so the ceiling of its naming;
* ``spotfree, true names, all columns``: the same with the columns drawn from every window of a class (column share
  1): the default share keeps the half of a class's windows named most surely, which guards against wrong names and
  with right names only leaves out windows; so what the representation and the classifier reach with right names;
* ``paper recipe``: :class:`spotfree.paper_recipe.PaperRecipe`, class sets only;
* ``1-NN``, ``MiniRocket``: sliding-window peers (:mod:`spotfree.evaluation.peers`) trained on the same clips with every
  sample's label.

    python benchmarks/real_har.py [--device sp sw] [--train-subjects 12] [--clip 2 3 5] [--seeds 0 1 2] [--last]
                                  [--accelerometer] [--quick]

``--last``: the other split, the last ``--train-subjects`` subjects train and the first ones are the test (the
defaults of the learner were chosen on the first split). ``--accelerometer``: every method on the acceleration's
body channels alone (``ax ay az acc_norm``), as from a log without a gyroscope. Writes
``benchmarks/results/real_har.md`` (command, machine, date, tables), ``real_har_last.md`` with ``--last``,
``real_har_acc.md`` (``real_har_acc_last.md``) with ``--accelerometer``.
"""

from __future__ import annotations

import argparse
import gzip
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from machine import describe
from spotfree.evaluation.metrics import event_detection, near_transitions
from spotfree.io.recording import IMU_CHANNELS, Recording
from spotfree.io.resample import Stream, merge_streams
from spotfree.learner import SetSupervisedLearner
from spotfree.paper_recipe import PaperRecipe
from spotfree.signal.body import ACC_BODY_CHANNELS, BODY_CHANNELS, body_features

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "sp_sw_har"
RESULTS = Path(__file__).resolve().parent / "results" / "real_har.md"
RATE = 20.0
EVENTS = ("STANDING_UP", "SITTING_DOWN")
"""Classes that are short transitions (a few seconds, once per recording): scored as events too."""
MINIROCKET_KERNELS = 2_016
"""MiniRocket features (aeon rounds to a multiple of 84): with the published 10,000 its ridge cross-validation on
the tens of thousands of training windows did not finish in 15 minutes on the 2-core machine."""


def on_grid(t: np.ndarray, values: np.ndarray, labels: np.ndarray, source: str) -> Recording:
    """Raw IMU samples (``t`` in s, ``values`` the six :data:`IMU_CHANNELS`) on the 20 Hz grid with their body
    channels and, as truth, the label of the nearest raw sample."""
    rec = merge_streams({"imu": Stream(t, values, IMU_CHANNELS)}, rate=RATE, source=source)
    nearest = np.clip(np.searchsorted(t, rec.time), 0, len(t) - 1)
    rec.truth["label"] = labels[nearest]
    return body_features(rec)


def load(path: Path) -> Recording:
    """One recording of the data set on the 20 Hz grid (:func:`on_grid`)."""
    with gzip.open(path, "rt") as fh:
        header = fh.readline().strip().split(",")
        rows = [line.rstrip("\n").split(",") for line in fh if line.strip()]
    values = np.array([[float(v) for v in r[:6]] for r in rows])
    t = np.array([float(r[6]) for r in rows]) / 1000.0
    labels = np.array([r[7] for r in rows])
    t, first = np.unique(t, return_index=True)  # duplicated timestamps: keep the first sample
    values, labels = values[first], labels[first]
    t = t - t[0]
    assert header[:6] == ["x_acc", "y_acc", "z_acc", "x_gyro", "y_gyro", "z_gyro"], header
    return on_grid(t, values, labels, path.stem.replace(".csv", ""))


def clips(rec: Recording, seconds: float) -> list[Recording]:
    """``rec`` cut into consecutive clips of ``seconds`` (the last one kept when at least half as long)."""
    n = int(round(seconds * rec.rate))
    out = [rec.take(slice(a, a + n)) for a in range(0, len(rec), n)]
    return [c for c in out if len(c) >= n // 2]


def balanced(predicted: np.ndarray, truth: np.ndarray, mask: np.ndarray, classes: list[str]) -> tuple[float, dict]:
    """Mean of the per-class recalls over the labelled samples inside ``mask``, and each recall."""
    recall = {}
    for c in classes:
        sel = mask & (truth == c) & (predicted != "")
        recall[c] = float(np.mean(predicted[sel] == c)) if sel.any() else float("nan")
    return float(np.nanmean(list(recall.values()))), recall


def score(predictions: list[np.ndarray], tests: list[Recording], classes: list[str]) -> dict:
    pred = np.concatenate(predictions).astype(str)
    truth = np.concatenate([r.truth["label"] for r in tests]).astype(str)
    away = ~np.concatenate([near_transitions(r.truth["label"], rate=r.rate) for r in tests])
    strict, _ = balanced(pred, truth, np.ones(len(truth), bool), classes)
    bal, recall = balanced(pred, truth, away, classes)
    recording = np.concatenate([np.full(len(r), k) for k, r in enumerate(tests)])
    events = {c: event_detection(pred, truth, c, recording, tests[0].rate) for c in EVENTS if c in classes}
    return {"away": bal, "strict": strict, "recall": recall, "events": events}


def centre_truth(recording: Recording, ends: np.ndarray, window: int) -> np.ndarray:
    """The true label at the centre sample of each window of ``recording`` whose last samples are ``ends``."""
    return np.asarray(recording.truth["label"]).astype(str)[ends - window // 2]


class TrueNames(SetSupervisedLearner):
    """:class:`SetSupervisedLearner` whose windows are named by the true label at their centre instead of by its
    rounds and decoding (its private step ``_decide``): what its dictionary and classifier reach with perfect names.
    For the benchmarks only; it reads the recordings' ``truth``, which the learner never does."""

    def fit(self, recordings, class_sets):
        self.recordings_ = list(recordings)
        return super().fit(recordings, class_sets)

    def _decide(self, log_q, data, allowed):
        truth = np.concatenate([centre_truth(rec, ends, self.window) for rec, ends in zip(self.recordings_, data.ends)])
        return np.searchsorted(self.classes_, truth)


def named_right(learner: SetSupervisedLearner, train: list[Recording]) -> float:
    """Share of the learner's training windows whose final name (``window_labels_``) is the true label at the
    window's centre sample (never shown to the learner): how well step 3 of the learner named the clips' windows."""
    right = total = 0
    for clip, names, ends in zip(train, learner.window_labels_, learner.window_ends_):
        right += int(np.sum(centre_truth(clip, ends, learner.window) == names))
        total += len(names)
    return right / total


def compare(train: list[Recording], tests: list[Recording], seeds: list[int], channels: tuple[str, ...] | None = None,
            **tags) -> list[dict]:
    """Every method fitted on the clips ``train`` (the learner and the paper's recipe given each clip's class set, the
    peers every sample's label) on ``channels`` (None: every body channel) and scored on the whole recordings
    ``tests``; one row a method, carrying ``tags``."""
    sets = [sorted(set(c.truth["label"])) for c in train]
    classes = sorted(set().union(*sets))
    rows = []
    name_of_run = " ".join(f"{v:g}" if isinstance(v, float) else str(v) for v in tags.values())

    def measure(name, supervision, fit, predict, live, named=None):
        t0 = time.perf_counter()
        fit()
        fit_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        preds = [predict(r) for r in tests]
        pred_s = time.perf_counter() - t0
        rows.append({**tags, "method": name, "supervision": supervision, "fit_s": fit_s,
                     "predict_s": pred_s, "named": named() if named else None, **score(preds, tests, classes),
                     "live": score([live(r) for r in tests], tests, classes)})
        print(f"{name_of_run} {name}: {rows[-1]['away']:.3f} away, {rows[-1]['strict']:.3f} strict, "
              f"live {rows[-1]['live']['away']:.3f} away, fit {fit_s:.1f} s", file=sys.stderr)

    for seed in seeds:  # the learner's forests and samples are seeded: its spread over seeds is part of the result
        learner = SetSupervisedLearner(channels=channels, seed=seed)
        measure(f"spotfree, seed {seed}", "class sets", lambda: learner.fit(train, sets), learner.predict,
                lambda r: learner.predict(r, centred=False), lambda: named_right(learner, train))
    for name, params in (("spotfree, true names", {}), ("spotfree, true names, all columns", {"column_share": 1.0})):
        labelled = TrueNames(channels=channels, seed=seeds[0], **params)
        measure(name, "every sample", lambda: labelled.fit(train, sets), labelled.predict,
                lambda r: labelled.predict(r, centred=False))
    paper = PaperRecipe(channels=channels, seed=seeds[0])
    measure("paper recipe", "class sets", lambda: paper.fit(train, sets), paper.predict,
            lambda r: paper.predict(r, centred=False))
    from spotfree.evaluation.peers import MiniRocketPeer, NearestNeighbourPeer

    peer_channels = channels or BODY_CHANNELS
    for name, make in (("sliding 1-NN", lambda a: NearestNeighbourPeer(channels=peer_channels, alignment=a)),
                       ("MiniRocket", lambda a: MiniRocketPeer(channels=peer_channels, alignment=a,
                                                               n_kernels=MINIROCKET_KERNELS))):
        centred, causal = make("centred"), make("causal")  # a peer is trained on the alignment it labels with
        measure(name, "every sample", lambda c=centred, k=causal: (c.fit(train), k.fit(train)), centred.predict,
                causal.predict)
    for r in rows:
        r.update(train_clips=len(train), test_recordings=len(tests), class_sets=len({tuple(s) for s in sets}))
    return rows


def run(device: str, train_subjects: int, clip: float, seeds: list[int], quick: bool,
        last: bool = False, channels: tuple[str, ...] | None = None) -> list[dict]:
    files = sorted((DATA / "DATA").glob(f"s*/s*_{device}.csv.gz"))
    subjects = sorted({f.parent.name for f in files})
    if last:  # the other split: the last subjects train, the first ones are the test
        subjects = subjects[::-1]
    train_ids, test_ids = set(subjects[:train_subjects]), set(subjects[train_subjects:])
    if quick:
        test_ids = set(sorted(test_ids)[:3])
    train = [c for f in files if f.parent.name in train_ids for c in clips(load(f), clip)]
    tests = [load(f) for f in files if f.parent.name in test_ids]
    return compare(train, tests, seeds, channels, device=device, clip=clip)


def table(rows: list[dict], first: str, prefix: str = "") -> list[str]:
    """The rows of :func:`compare` as a Markdown table (first column the tag ``first``, then the clip length), and
    below it the learner's mean and range over its seeds beside the peers, per ``first`` (named after ``prefix``) and
    clip length."""
    classes = list(rows[0]["recall"])
    lines = [f"| {first} | clip s (clips, distinct sets) | method | supervision | training windows named right | "
             "balanced, away | balanced, strict | " + " | ".join(f"{c} recall" for c in classes)
             + " | live: balanced, away | live: balanced, strict | fit s | predict s |",
             "|---|---|---|---|---|---|---|" + "---|" * len(classes) + "---|---|---|---|"]
    for r in rows:
        named = f"{100 * r['named']:.1f} %" if r.get("named") is not None else "-"
        lines.append(f"| {r[first]} | {r['clip']:g} ({r['train_clips']}, {r['class_sets']}) | {r['method']} | "
                     f"{r['supervision']} | {named} | {100 * r['away']:.1f} % | "
                     f"{100 * r['strict']:.1f} % | " + " | ".join(f"{100 * r['recall'][c]:.1f} %" for c in classes)
                     + f" | {100 * r['live']['away']:.1f} % | {100 * r['live']['strict']:.1f} %"
                     + f" | {r['fit_s']:.1f} | {r['predict_s']:.1f} |")
    lines += events_table(rows, first)
    lines += ["", "spotfree over its seeds, balanced accuracy away from changes (mean, lowest, highest), beside the peers:", ""]
    for key in dict.fromkeys((r[first], r["clip"]) for r in rows):
        group = [r for r in rows if (r[first], r["clip"]) == key]
        learned = [r for r in group if r["method"].startswith("spotfree, seed")]
        ours = [100 * r["away"] for r in learned]
        named = [100 * r["named"] for r in learned]
        live = [100 * r["live"]["away"] for r in learned]
        peers = ", ".join(f"{r['method']} {100 * r['away']:.1f} % (live {100 * r['live']['away']:.1f} %)"
                          for r in group if r["supervision"] == "every sample")
        lines.append(f"- {prefix}{key[0]}, {key[1]:g}-s clips: {np.mean(ours):.1f} % ({min(ours):.1f}-{max(ours):.1f}), "
                     f"live {np.mean(live):.1f} %, training windows named right {np.mean(named):.1f} %; {peers}")
    return lines


def events_table(rows: list[dict], first: str) -> list[str]:
    """The events of :data:`EVENTS` scored in ``rows`` (none when their classes have none) as a Markdown table."""
    names = list(rows[0].get("events", {}))
    if not names:
        return []
    lines = ["", "Transitions as events (detected / true, false alarms, precision / recall / F1, false alarms per hour "
             "without the event):", "",
             f"| {first} | clip s | method | " + " | ".join(names) + " |", "|---|---|---|" + "---|" * len(names)]
    for r in rows:
        cells = [f"{e.detected} / {e.events}, {e.false_alarms} false, {e.precision:.2f} / {e.rate:.2f} / {e.f1:.2f}, "
                 f"{e.false_alarms_per_hour:.0f} per h" for e in (r["events"][c] for c in names)]
        lines.append(f"| {r[first]} | {r['clip']:g} | {r['method']} | " + " | ".join(cells) + " |")
    return lines


def write(rows: list[dict], command: str, last: bool = False, channels: tuple[str, ...] | None = None) -> None:
    lines = ["# Spotting-free learning on real recordings (sp_sw_har)", "",
             f"- command: `{command}`",
             f"- machine: {describe()}",
             f"- date: {datetime.now(timezone.utc).strftime('%Y-%m-%d %H:%M UTC')}",
             f"- training: the recordings of the {'last' if last else 'first'} training subjects cut into clips, each "
             f"declared with its set of classes; test: {rows[0]['test_recordings']} whole recordings of the other "
             "subjects per device",
             f"- channels: {', '.join(channels or BODY_CHANNELS)} (every method)",
             "- balanced accuracy = mean of per-class recalls; away = leaving out samples within 0.5 s of a true "
             "change; centred labels (each window labels its centre, offline), and live: causal labels (each window "
             "labels its last sample, as a phone does live; a peer trained on that alignment, its fit time included); "
             "training windows named right = the learner's final names of its training windows "
             "against the true label at each window's centre", "", *table(rows, "device")]
    results = RESULTS.with_name("real_har" + "_acc" * (channels == ACC_BODY_CHANNELS) + "_last" * last + ".md")
    results.parent.mkdir(exist_ok=True)
    results.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", nargs="+", default=["sp", "sw"], choices=["sp", "sw"])
    parser.add_argument("--train-subjects", type=int, default=12)
    parser.add_argument("--clip", type=float, nargs="+", default=[2.0, 3.0, 5.0], help="clip lengths, s")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the learner (the paper's "
                        "recipe: the first)")
    parser.add_argument("--last", action="store_true", help="train on the last subjects and test on the others "
                        "(the other split; writes real_har_last.md)")
    parser.add_argument("--quick", action="store_true", help="three test subjects (for a smoke run)")
    parser.add_argument("--accelerometer", action="store_true", help="every method on the acceleration's body "
                        "channels alone, as from a log without a gyroscope (writes real_har_acc.md)")
    args = parser.parse_args()
    channels = ACC_BODY_CHANNELS if args.accelerometer else None
    rows = [r for d in args.device for c in args.clip
            for r in run(d, args.train_subjects, c, args.seeds, args.quick, args.last, channels)]
    write(rows, "python benchmarks/real_har.py " + " ".join(sys.argv[1:]), args.last, channels)


if __name__ == "__main__":
    main()
