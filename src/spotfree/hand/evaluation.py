"""Evaluation of the hand recogniser in the style of the ride report: six test runs of held-out simulated people.

The recogniser is trained on the training protocol of people ``1 .. train_people`` and tested on one session of
the test protocol for each of people ``101 ..`` (never seen in training), per 20 Hz sample, causally (the labels a
live stream gives). Measures:

* **stage 1** (posture or gesture): share of labelled samples whose state is the true one;
* **stage 2**: among samples of true state ``s`` that stage 1 calls ``s``, the share with the true label
  (postures and gestures apart), and the confusion matrices;
* **end to end**: among labelled samples of true state ``s``, the share with the true label (a stage-1 miss counts
  as wrong); the paper's count (100 % of 5,850 labels over six test runs) beside ours;
* **commands**: latency from each true posture onset to its command (:func:`~spotfree.hand.commands.command_latencies`)
  and switches to a command that is not the current or the next posture's;
* **streaming**: samples per second of :class:`~spotfree.hand.recognition.HandRecognizer` and whether its labels
  equal the batch ones.

Ground truth is read here and only here.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from spotfree.hand.commands import COMMANDS, command_latencies
from spotfree.hand.features import FEATURES
from spotfree.hand.log import frames_to_recording
from spotfree.hand.recognition import HandLabels, HandModel, HandRecognizer, features_of, recognise, \
    session_tasks, train_hand
from spotfree.sim.hand import GESTURES, POSTURES, simulate_hands

PAPER = {"labels": 5850, "accuracy": 1.0, "runs": 6}
"""The paper's hand result (section V): 100 % of 5,850 labels over six test runs."""

TEST_FIRST = 101
"""Number of the first held-out test person."""


@dataclass
class HandEvaluation:
    """Per-run rows, overall accuracies, confusion matrices (rows true, columns recognised), command latency,
    streaming speed and the time each phase took."""

    runs: pd.DataFrame
    accuracy: dict[str, float]
    confusion: dict[str, pd.DataFrame]
    latency: dict[str, float]
    wrong_switches: int
    streaming: dict[str, float]
    seconds: dict[str, float] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)


def evaluate_hand(train_people: int = 4, test_people: int = 6, seed: int = 0, rounds: int = 3,
                  progress=None) -> HandEvaluation:
    """Train on simulated people ``1 .. train_people``, test on ``test_people`` held-out people (module docstring)."""
    say = progress or (lambda message: None)
    clock = time.perf_counter()
    say(f"simulating the training protocol of {train_people} people")
    training = frames_to_recording(simulate_hands(train_people, seed, rounds, protocol="training"))
    say(f"simulating {test_people} test runs (people {TEST_FIRST}..)")
    test = frames_to_recording(simulate_hands(test_people, seed, rounds, first=TEST_FIRST))
    seconds = {"simulation": time.perf_counter() - clock}
    clock = time.perf_counter()
    model = train_hand([(features_of(part), task) for part, task in session_tasks(training)], progress=say).model
    seconds["training"] = time.perf_counter() - clock
    clock = time.perf_counter()
    feats = features_of(test)
    labels = recognise(model, feats)
    seconds["recognition"] = time.perf_counter() - clock
    streaming = _streaming(model, feats, labels)
    truth_state, truth_label = feats.truth["state"], feats.truth["label"]
    latencies, wrong, rows = [], 0, []
    for number, part in feats.experiments():
        mask = feats.experiment == number if feats.experiment is not None else np.ones(len(feats), dtype=bool)
        latencies.append(command_latencies(part.time, labels.command[mask], truth_state[mask], truth_label[mask]))
        wrong += _wrong_switches(labels.state[mask], labels.command[mask], truth_state[mask], truth_label[mask])
        rows.append({"run": len(rows) + 1, "person": int(part.truth["person"][0]),
                     **_accuracy(labels.state[mask], labels.label[mask], truth_state[mask], truth_label[mask])})
    latency = np.concatenate([x.latency for x in latencies])
    reached = latency[np.isfinite(latency)]
    return HandEvaluation(
        runs=pd.DataFrame(rows),
        accuracy=_accuracy(labels.state, labels.label, truth_state, truth_label),
        confusion=_confusions(labels, truth_state, truth_label),
        latency={"onsets": int(len(latency)), "reached": float(len(reached) / max(1, len(latency))),
                 "median": float(np.median(reached)), "p95": float(np.percentile(reached, 95)),
                 "max": float(reached.max())},
        wrong_switches=wrong, streaming=streaming, seconds=seconds,
        settings={"train_people": train_people, "test_people": test_people, "seed": seed, "rounds": rounds,
                  "windows": {s: m.window for s, m in model.stages().items()}, "rate": model.state.rate},
    )


def _accuracy(state, label, truth_state, truth_label) -> dict[str, float]:
    """Labelled share, stage-1 accuracy, stage-2 accuracy given a correct stage 1, and end-to-end accuracy, for
    postures and gestures; also the counts behind the end-to-end figure."""
    labelled = state != ""
    out = {"samples": int(len(state)), "labelled": float(labelled.mean()),
           "stage1": float((state[labelled] == truth_state[labelled]).mean())}
    correct = 0
    for s in ("posture", "gesture"):
        true = labelled & (truth_state == s)
        caught = true & (state == s)
        out[f"stage1_{s}"] = float((state[true] == s).mean())
        out[f"stage2_{s}"] = float((label[caught] == truth_label[caught]).mean())
        out[f"end_{s}"] = float((label[true] == truth_label[true]).mean())
        correct += int((label[true] == truth_label[true]).sum())
    out["labels"] = int(labelled.sum())
    out["correct"] = correct
    return out


def _confusions(labels: HandLabels, truth_state, truth_label) -> dict[str, pd.DataFrame]:
    """Stage 1 over labelled samples; stage 2 over the samples whose state stage 1 got right."""
    labelled = labels.state != ""
    out = {"stage 1": pd.crosstab(pd.Categorical(truth_state[labelled], ["posture", "gesture"]),
                                  pd.Categorical(labels.state[labelled], ["posture", "gesture"]), dropna=False)}
    for s, classes in (("posture", POSTURES), ("gesture", GESTURES)):
        caught = labelled & (truth_state == s) & (labels.state == s)
        out[f"stage 2, {s}s"] = pd.crosstab(pd.Categorical(truth_label[caught], classes),
                                            pd.Categorical(labels.label[caught], classes), dropna=False)
    for table in out.values():
        table.index.name, table.columns.name = "true", "recognised"
    return out


def _wrong_switches(state, command, truth_state, truth_label) -> int:
    """Command changes (with a hand) to a command that is neither the current true posture's nor, during a
    gesture, its target posture's."""
    count = 0
    for k in np.flatnonzero(command[1:] != command[:-1]) + 1:
        if not state[k]:
            continue
        target = truth_label[k] if truth_state[k] == "posture" else str(truth_label[k]).rpartition("-to-")[2]
        count += command[k] != COMMANDS.get(target)
    return count


def _streaming(model: HandModel, feats, labels: HandLabels) -> dict[str, float]:
    """Samples per second of the streaming recogniser over the test runs, and its disagreements with batch."""
    rows = feats.array(FEATURES)
    experiment = feats.experiment if feats.experiment is not None else np.ones(len(feats), dtype=int)
    recogniser = HandRecognizer(model)
    out = []
    clock = time.perf_counter()
    for i, row in enumerate(rows):
        if i and experiment[i] != experiment[i - 1]:
            recogniser.reset()
        out.append(recogniser.update(row))
    seconds = time.perf_counter() - clock
    state, label, command = (np.array(x, dtype=str) for x in zip(*out))
    differ = (state != labels.state) | (label != labels.label) | (command != labels.command)
    return {"samples": len(rows), "seconds": seconds, "per_second": len(rows) / seconds,
            "per_sample_us": 1e6 * seconds / len(rows), "differ": int(differ.sum())}


def hand_report(ev: HandEvaluation) -> str:
    """The evaluation as Markdown."""
    a, s = ev.accuracy, ev.settings
    pct = lambda x: f"{100 * x:.2f} %"  # noqa: E731
    lines = [
        f"Trained on the training protocol of {s['train_people']} simulated people (seed {s['seed']}, {s['rounds']} "
        f"round trips per posture); tested on {s['test_people']} held-out people, one run each, at {s['rate']:g} Hz, "
        f"causal windows of {s['windows']} samples.",
        "",
        "| | paper | spotfree |",
        "|---|---:|---:|",
        f"| labels (posture + gesture samples, six runs) | {PAPER['labels']:,} | {a['labels']:,} |",
        f"| correct end to end | {pct(PAPER['accuracy'])} | {pct(a['correct'] / a['labels'])} |",
        "",
        "| run | person | samples | labelled | stage 1 | stage 2 postures | stage 2 gestures | end to end postures "
        "| end to end gestures |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for r in ev.runs.to_dict("records"):
        lines.append(f"| {r['run']} | {r['person']} | {r['samples']} | {pct(r['labelled'])} | {pct(r['stage1'])} | "
                     f"{pct(r['stage2_posture'])} | {pct(r['stage2_gesture'])} | {pct(r['end_posture'])} | "
                     f"{pct(r['end_gesture'])} |")
    lines.append(f"| all | | {a['samples']} | {pct(a['labelled'])} | {pct(a['stage1'])} | {pct(a['stage2_posture'])} "
                 f"| {pct(a['stage2_gesture'])} | {pct(a['end_posture'])} | {pct(a['end_gesture'])} |")
    lines += ["", f"Stage 1 per true state: postures {pct(a['stage1_posture'])}, gestures {pct(a['stage1_gesture'])}.",
              ""]
    for name, table in ev.confusion.items():
        lines += [f"Confusion, {name} (rows true, columns recognised):", "", "```", table.to_string(), "```", ""]
    lat = ev.latency
    lines += [
        f"Commands: {lat['onsets']} posture onsets, command reached for {pct(lat['reached'])}; latency from the true "
        f"onset median {lat['median']:.2f} s, 95th percentile {lat['p95']:.2f} s, max {lat['max']:.2f} s; "
        f"{ev.wrong_switches} switch(es) to a wrong command.",
        f"Streaming: {ev.streaming['per_second']:,.0f} samples per second ({ev.streaming['per_sample_us']:.0f} us per "
        f"20 Hz sample, three stages and the command), {ev.streaming['differ']} sample(s) differing from batch.",
        f"Time: " + ", ".join(f"{k} {v:.1f} s" for k, v in ev.seconds.items()) + ".",
    ]
    return "\n".join(lines)
