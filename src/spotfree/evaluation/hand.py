"""Evaluation of the hand recogniser in the style of the ride report: six test runs of held-out simulated people.

The recogniser is trained on the training protocol of people ``1 .. train_people`` and tested on one session of
the test protocol for each of people ``101 ..`` (never seen in training), per 20 Hz sample, in both modes of
:func:`~spotfree.hand.recognition.recognise`: **offline** (centred windows, one gesture per gesture stretch) and
**live** (causal windows, the labels a live stream gives). Measures, per mode:

* **stage 1** (posture or gesture): share of labelled samples whose state is the true one;
* **stage 2**: among samples of true state ``s`` that stage 1 calls ``s``, the share with the true label
  (postures and gestures apart), and the confusion matrices;
* **end to end**: among labelled samples of true state ``s``, the share with the true label (a stage-1 miss counts
  as wrong); the paper's count (100 % of 5,850 labels over six test runs) beside ours; also with a *collar*: the
  samples within ``c`` samples of a true change of state left out (as diarisation scoring leaves a collar around
  every reference boundary), since the truth puts the change where the hand starts or stops moving, which no
  sensor sees at once;
* **from the observable onset**: end to end with the gestures of the truth cut to where the palm moves at
  least ``c`` of its movement's peak speed (:data:`ONSETS`; the truth's ``pace``, :func:`onset_truth`). Motion
  studies time a movement's onset and end by such a speed threshold (Botzer and Karniel 2009,
  doi:10.3389/neuro.20.002.2009, on how onsets are usually detected; 2 % of the peak in the reach-to-grasp
  kinematics of doi:10.1186/s12984-021-00895-3), whereas the simulator's gesture starts when the
  movement does, at rest;
* **gestures as events**: every gesture of the truth from its observable onset (:data:`EVENT_ONSET` of its peak
  speed, :func:`onset_truth`) is one event, detected by one recognised gesture event of the same gesture (a stretch
  of the gesture state named by its vote, :func:`~spotfree.hand.recognition.hand_labels`) whose first sample lies
  within :data:`EVENT_TOLERANCE` s of the event's; precision, recall and F1 over all gestures
  (:func:`gesture_events`);
* **supervised peers** (when given): window classifiers of :mod:`spotfree.evaluation.peers` trained on the same
  training sessions with every sample's true label (one classifier over the five postures and eight gestures, on
  :data:`PEER_CHANNELS`, every stage's channels), causal windows live and centred windows offline; their labels
  go through the same :func:`~spotfree.hand.recognition.hand_labels` (state from the label, offline votes, events)
  and are scored alike;
* **where gestures are lost**: end-to-end gesture accuracy by the sample's place in its gesture (first, second,
  ... sample from the start and from the end), beside the measured palm speed there and in postures;
* **commands**: latency from each true posture onset to its command (:func:`~spotfree.hand.commands.command_latencies`)
  and switches to a command that is not the current or the next posture's;
* **streaming**: samples per second of :class:`~spotfree.hand.recognition.HandRecognizer` and whether its labels
  equal the batch ones.

Ground truth is read here and only here.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd
from sklearn.base import clone

from spotfree.classify.batch import vote_seconds
from spotfree.classify.runs import RunEvent
from spotfree.evaluation.peers import Peer
from spotfree.hand.commands import COMMANDS, command_latencies
from spotfree.hand.features import FEATURES
from spotfree.hand.log import frames_to_recording
from spotfree.hand.recognition import STAGE_PARAMETERS, STATES, HandLabels, HandModel, HandRecognizer, \
    HandTrainingConfig, declared, features_of, gesture_samples, hand_labels, recognise, session_tasks, train_hand
from spotfree.hand.vocabulary import GESTURES, POSTURES
from spotfree.learner import SetSupervisedLearner
from spotfree.sim.hand import TRAINING_PEOPLE, simulate_hands

PAPER = {"labels": 5850, "accuracy": 1.0, "runs": 6}
"""The paper's hand result (section V): 100 % of 5,850 labels over six test runs."""

TEST_FIRST = 101
"""Number of the first held-out test person."""

MODES = ("offline", "live")
"""Recognition modes evaluated: centred windows with one gesture per stretch, and causal windows."""

COLLARS = (1, 2)
"""Collars (samples on each side of a true change of state left out) of the extra end-to-end figures."""

ONSETS = (0.02, 0.05, 0.10)
"""Shares of a movement's peak speed at which the end-to-end figures are also scored (:func:`onset_truth`)."""

EVENT_ONSET = 0.10
"""Share of a movement's peak speed at which a gesture event starts (:func:`gesture_events`)."""

EVENT_TOLERANCE = 0.5
"""Seconds by which a recognised gesture's first sample may miss the true onset and still detect it."""

PLACES = 4
"""Samples from each end of a gesture reported one by one in the table of where gestures are lost."""

PEER_CHANNELS = tuple(dict.fromkeys(c for p in STAGE_PARAMETERS.values() for c in p["channels"]))
"""Channels of the supervised peers: those of every stage of the recogniser."""

PEER_WINDOW = 9
"""Window of the supervised peers, samples: MiniRocket's shortest (its kernels are 9 samples long)."""

MODE_ALIGNMENT = {"offline": "centred", "live": "causal"}
"""The peers' window alignment in each mode."""


@dataclass
class PeerScores:
    """A supervised peer's scores, per mode as :class:`HandEvaluation`'s (``accuracy``, ``onsets``, ``events``),
    and the seconds its fits took (both alignments)."""

    accuracy: dict[str, dict[str, float]]
    onsets: dict[str, dict[float, dict[int, dict[str, float]]]]
    events: dict[str, dict[str, float]]
    fit_seconds: float


@dataclass
class HandEvaluation:
    """Per mode: per-run rows, overall accuracies, accuracies with collars, gesture accuracy by place, confusion
    matrices (rows true, columns recognised); command latency and streaming speed (live); the time each phase
    took."""

    runs: dict[str, pd.DataFrame]
    accuracy: dict[str, dict[str, float]]
    collars: dict[str, dict[int, dict[str, float]]]
    onsets: dict[str, dict[float, dict[int, dict[str, float]]]]
    events: dict[str, dict[str, float]]
    places: pd.DataFrame
    confusion: dict[str, dict[str, pd.DataFrame]]
    latency: dict[str, float]
    wrong_switches: int
    streaming: dict[str, float]
    seconds: dict[str, float] = field(default_factory=dict)
    settings: dict = field(default_factory=dict)
    peers: dict[str, PeerScores] = field(default_factory=dict)


def evaluate_hand(train_people: int = TRAINING_PEOPLE, test_people: int = 6, seed: int = 0, rounds: int = 3,
                  config: HandTrainingConfig | None = None, progress=None,
                  peers: dict[str, Peer] | None = None) -> HandEvaluation:
    """Train on simulated people ``1 .. train_people`` (``config``: the recogniser's training settings, the
    defaults when None, its seed ``seed``), test on ``test_people`` held-out people (module docstring). ``peers``:
    unfitted supervised peers by name, each fitted once per mode with that mode's alignment
    (:data:`MODE_ALIGNMENT`) on the training sessions and their truth; their channels and window are theirs."""
    config = replace(config or HandTrainingConfig(), seed=seed)
    say = progress or (lambda message: None)
    clock = time.perf_counter()
    say(f"simulating the training protocol of {train_people} people")
    training = frames_to_recording(simulate_hands(train_people, seed, rounds, protocol="training"))
    say(f"simulating {test_people} test runs (people {TEST_FIRST}..)")
    test = frames_to_recording(simulate_hands(test_people, seed, rounds, first=TEST_FIRST))
    seconds = {"simulation": time.perf_counter() - clock}
    clock = time.perf_counter()
    sessions = [(features_of(part), task) for part, task in session_tasks(training)]
    model = train_hand(sessions, config, progress=say).model
    seconds["training"] = time.perf_counter() - clock
    feats = features_of(test)
    labels = {}
    for mode in MODES:
        clock = time.perf_counter()
        labels[mode] = recognise(model, feats, offline=mode == "offline")
        seconds[f"recognition {mode}"] = time.perf_counter() - clock
    streaming = _streaming(model, feats, labels["live"])
    truth_state, truth_label = feats.truth["state"], feats.truth["label"]
    pace = feats.truth["pace"].astype(float)
    experiment = feats.experiment_numbers()
    latencies, wrong = [], 0
    runs = {mode: [] for mode in MODES}
    for number, part in feats.experiments():
        mask = experiment == number
        live = labels["live"]
        latencies.append(command_latencies(part.time, live.command[mask], truth_state[mask], truth_label[mask]))
        wrong += _wrong_switches(live.state[mask], live.command[mask], truth_state[mask], truth_label[mask])
        for mode in MODES:
            runs[mode].append({"run": len(runs[mode]) + 1, "person": int(part.truth["person"][0]),
                               **_accuracy(labels[mode].state[mask], labels[mode].label[mask], truth_state[mask],
                                           truth_label[mask])})
    latency = np.concatenate([x.latency for x in latencies])
    reached = latency[np.isfinite(latency)]
    return HandEvaluation(
        runs={mode: pd.DataFrame(rows) for mode, rows in runs.items()},
        accuracy={mode: _accuracy(x.state, x.label, truth_state, truth_label) for mode, x in labels.items()},
        collars={mode: {c: _accuracy(x.state, x.label, truth_state, truth_label,
                                     ~_near_change(truth_state, experiment, c)) for c in COLLARS}
                 for mode, x in labels.items()},
        onsets={mode: _onset_scores(x, truth_state, truth_label, pace, experiment) for mode, x in labels.items()},
        events={mode: _events(x, feats) for mode, x in labels.items()},
        places=_places(labels, truth_state, truth_label, experiment, feats.channels["speed"]),
        confusion={mode: _confusions(x, truth_state, truth_label) for mode, x in labels.items()},
        latency={"onsets": int(len(latency)), "reached": float(len(reached) / max(1, len(latency))),
                 "median": float(np.median(reached)), "p95": float(np.percentile(reached, 95)),
                 "max": float(reached.max())},
        wrong_switches=wrong, streaming=streaming, seconds=seconds,
        settings={"train_people": train_people, "test_people": test_people, "seed": seed, "rounds": rounds,
                  "windows": {s: m.window for s, m in model.stages().items()},
                  "learner": {s: {k: v for k, v in p.items() if k not in ("channels", "window")}
                              for s, p in config.stages.items()},
                  "channels": {s: list(m.channels) for s, m in model.stages().items()}, "rate": model.state.rate,
                  "event_samples": gesture_samples(model)},
        peers={name: _peer_scores(peer, [rec for rec, _ in sessions], feats, gesture_samples(model),
                                  vote_seconds(model.state), say)
               for name, peer in (peers or {}).items()},
    )


def hand_figures(accuracy: dict, onsets: dict, events: dict) -> dict[str, dict[str, float]]:
    """Per mode, the figures issue 35 sets goals for, from a recogniser's or a peer's scores: ``postures`` per frame
    (end to end, the simulator's truth), ``postures_onset`` and ``gestures`` end to end from the observable onset
    (:data:`EVENT_ONSET` of the peak speed) with the widest of :data:`COLLARS`, and the gesture events' ``precision``,
    ``recall`` and ``f1``."""
    out = {}
    for mode in MODES:
        onset = onsets[mode][EVENT_ONSET][COLLARS[-1]]
        out[mode] = {"postures": accuracy[mode]["end_posture"], "postures_onset": onset["end_posture"],
                     "gestures": onset["end_gesture"],
                     **{k: events[mode][k] for k in ("precision", "recall", "f1")}}
    return out


def _events(labels: HandLabels, feats) -> dict[str, float]:
    """:func:`gesture_events` of ``labels`` against the test truth from :data:`EVENT_ONSET`."""
    experiment = feats.experiment_numbers()
    truth = onset_truth(feats.truth["state"], feats.truth["label"], feats.truth["pace"].astype(float), experiment,
                        EVENT_ONSET)[1]
    return gesture_events(labels.events, truth, experiment, feats.rate)


def _peer_scores(peer: Peer, training: list, feats, min_samples: int, vote: float, say) -> PeerScores:
    """Fit ``peer`` with each mode's alignment on the ``training`` feature sessions (their truth labels), label the
    test ``feats`` and score them as the recogniser's labels (the state is the one the label belongs to); its centred
    labels get the recogniser's vote of ``vote`` s."""
    truth_state, truth_label = feats.truth["state"], feats.truth["label"]
    pace = feats.truth["pace"].astype(float)
    experiment = feats.experiment_numbers()
    accuracy, onsets, events, fit = {}, {}, {}, 0.0
    for mode, alignment in MODE_ALIGNMENT.items():
        say(f"peer {type(peer).__name__}, {alignment} windows")
        fitted = clone(peer).set_params(alignment=alignment, vote=vote).fit(training)
        fit += fitted.fit_time_
        label = fitted.predict(feats)
        state = np.where(np.isin(label, GESTURES), "gesture", np.where(np.isin(label, POSTURES), "posture", ""))
        labels = hand_labels(feats, state, np.where(state != "", label, ""), mode == "offline",
                             min_samples=min_samples)
        accuracy[mode] = _accuracy(labels.state, labels.label, truth_state, truth_label)
        onsets[mode] = _onset_scores(labels, truth_state, truth_label, pace, experiment)
        events[mode] = _events(labels, feats)
    return PeerScores(accuracy, onsets, events, fit)


DEV_FIRST = 201
"""Number of the first development person (the grid of :func:`state_grid`; never a test person)."""


def state_grid(settings: list[tuple[tuple[str, ...], int]], train_people: int = 4, dev_people: int = 6,
               seed: int = 0, dev_seed: int = 1, rounds: int = 3) -> pd.DataFrame:
    """Stage 1 alone for each ``(channels, window)`` of ``settings``: trained on the training protocol of people
    ``1 .. train_people`` (``seed``), scored on ``dev_people`` development people from :data:`DEV_FIRST` of
    ``dev_seed`` (not the test people): share of true posture and gesture samples given their state, centred and
    causal, without and with each of the :data:`COLLARS`."""
    training = frames_to_recording(simulate_hands(train_people, seed, rounds, protocol="training"))
    sessions = [(features_of(part), task) for part, task in session_tasks(training)]
    dev = features_of(frames_to_recording(simulate_hands(dev_people, dev_seed, rounds, first=DEV_FIRST)))
    truth = dev.truth["state"]
    experiment = dev.experiment_numbers()
    rows = []
    for channels, window in settings:
        learner = SetSupervisedLearner(**{**STAGE_PARAMETERS["state"], "channels": tuple(channels), "window": window,
                                          "seed": seed})
        learner.fit([rec for rec, _ in sessions], [declared(task, "state") for _, task in sessions])
        for centred in (True, False):
            state = learner.predict(dev, centred=centred)
            row = {"channels": ",".join(channels), "window": window, "windows": "centred" if centred else "causal"}
            for c in (0, *COLLARS):
                keep = (state != "") & ~_near_change(truth, experiment, c)
                for s in STATES:
                    row[f"{s}s" + (f", collar {c}" if c else "")] = float((state[keep & (truth == s)] == s).mean())
            rows.append(row)
    return pd.DataFrame(rows)


def _near_change(truth_state: np.ndarray, experiment: np.ndarray, collar: int) -> np.ndarray:
    """True on the samples within ``collar`` samples of a true change of state (the ``collar`` samples before it
    and the ``collar`` from it on), within one experiment."""
    near = np.zeros(len(truth_state), dtype=bool)
    change = np.flatnonzero((truth_state[1:] != truth_state[:-1]) & (experiment[1:] == experiment[:-1])) + 1
    for k in change:
        near[max(0, k - collar):k + collar] = True
    return near


def onset_truth(truth_state: np.ndarray, truth_label: np.ndarray, pace: np.ndarray, experiment: np.ndarray,
                threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """The truth with every gesture cut to its samples from the first to the last whose ``pace`` (the palm's speed
    over its movement's peak) is at least ``threshold``: the samples before take the posture the gesture leaves
    (``X`` of ``X-to-Y``), those after the posture it reaches (``Y``); a gesture that never reaches ``threshold``
    is split in the middle."""
    state, label = truth_state.astype(object).copy(), truth_label.astype(object).copy()
    for start, stop in _runs(truth_state == "gesture", experiment):
        leaves, _, reaches = str(truth_label[start]).partition("-to-")
        above = np.flatnonzero(pace[start:stop] >= threshold)
        first, last = (above[0], above[-1] + 1) if len(above) else ((stop - start) // 2,) * 2
        state[start:start + first] = state[start + last:stop] = "posture"
        label[start:start + first], label[start + last:stop] = leaves, reaches
    return state.astype(str), label.astype(str)


def gesture_events(events: list[RunEvent], truth_label: np.ndarray, experiment: np.ndarray, rate: float,
                   tolerance: float = EVENT_TOLERANCE) -> dict[str, float]:
    """Gestures scored as detections: each true run of a gesture (in ``truth_label``) is matched to at most one
    recognised event of the same gesture (``events``, sample indices into ``truth_label``) that starts within
    ``tolerance`` s of it in the same experiment, nearest first; an unmatched event is a false detection. Returns
    ``events`` (true gestures), ``detections`` (recognised events), ``matched``, ``precision``, ``recall`` and
    ``f1``, over every gesture and experiment."""
    reach = tolerance * rate
    true_count = detections = matched = 0
    for gesture in GESTURES:
        true = _runs(truth_label == gesture, experiment)
        found = [e.start for e in events if e.label == gesture]
        true_count, detections = true_count + len(true), detections + len(found)
        free = {start: experiment[start] for start in found}
        for start, _ in true:
            near = [f for f in free if experiment[f] == experiment[start] and abs(f - start) <= reach]
            if near:
                del free[min(near, key=lambda f: abs(f - start))]
                matched += 1
    precision = matched / detections if detections else float("nan")
    recall = matched / true_count if true_count else float("nan")
    return {"events": true_count, "detections": detections, "matched": matched, "precision": precision,
            "recall": recall,
            "f1": 2 * matched / (true_count + detections) if true_count + detections else float("nan")}


def _onset_scores(labels: HandLabels, truth_state, truth_label, pace, experiment) -> dict[float, dict[int, dict]]:
    """Per threshold ``c`` (0 and :data:`ONSETS`): the scores against :func:`onset_truth`, without a collar (key 0)
    and with the widest of :data:`COLLARS` around its changes of state."""
    out = {}
    for c in (0.0, *ONSETS):
        state, label = onset_truth(truth_state, truth_label, pace, experiment, c)
        out[c] = {k: _accuracy(labels.state, labels.label, state, label,
                               ~_near_change(state, experiment, k) if k else None) for k in (0, COLLARS[-1])}
    return out


def _places(labels: dict[str, HandLabels], truth_state, truth_label, experiment, speed) -> pd.DataFrame:
    """Per place in a gesture (``k``-th sample from its start, from its end, or further inside), the number of
    labelled samples, the median measured palm speed (mm/s), and each mode's end-to-end gesture accuracy; a last
    row for the posture samples."""
    gesture = truth_state == "gesture"
    place = np.full(len(truth_state), "", dtype=object)
    for start, stop in _runs(gesture, experiment):
        for i in range(stop - start):
            back = stop - start - 1 - i
            place[start + i] = (f"start +{i}" if i < PLACES and i <= back
                                else f"end -{back}" if back < PLACES else "inside")
    place[truth_state == "posture"] = "postures"
    order = [f"start +{k}" for k in range(PLACES)] + ["inside"] + [f"end -{k}" for k in reversed(range(PLACES))]
    rows = []
    labelled = np.all([x.state != "" for x in labels.values()], axis=0)
    for name in order + ["postures"]:
        at = labelled & (place == name)
        row = {"place": name, "samples": int(at.sum()), "speed mm/s": 1e3 * float(np.nanmedian(speed[at]))}
        row.update({mode: float((x.label[at] == truth_label[at]).mean()) for mode, x in labels.items()})
        rows.append(row)
    return pd.DataFrame(rows)


def _runs(mask: np.ndarray, experiment: np.ndarray) -> list[tuple[int, int]]:
    """``(start, stop)`` of the runs of consecutive ``mask`` samples within one experiment."""
    cut = np.r_[True, experiment[1:] != experiment[:-1]]
    starts = np.flatnonzero(mask & (cut | ~np.r_[False, mask[:-1]]))
    stops = np.flatnonzero(mask & (np.r_[cut[1:], True] | ~np.r_[mask[1:], False])) + 1
    return list(zip(starts.tolist(), stops.tolist()))


def _accuracy(state, label, truth_state, truth_label, keep=None) -> dict[str, float]:
    """Labelled share, stage-1 accuracy, stage-2 accuracy given a correct stage 1, and end-to-end accuracy, for
    postures and gestures; also the counts behind the end-to-end figure. ``keep``: the samples scored (all when
    None)."""
    if keep is not None:
        state, label, truth_state, truth_label = state[keep], label[keep], truth_state[keep], truth_label[keep]
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
    out["gestures"] = int((labelled & (truth_state == "gesture")).sum())
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
    """Samples per second of the streaming recogniser over the test runs, and its disagreements with batch: samples
    and gesture events (those of one but not the other)."""
    rows = feats.array(FEATURES)
    experiment = feats.experiment_numbers()
    recogniser = HandRecognizer(model)
    out = []
    clock = time.perf_counter()
    for i, row in enumerate(rows):
        if i and experiment[i] != experiment[i - 1]:
            recogniser.reset()
        out.append(recogniser.update(row))
    recogniser.reset()  # the last gesture's event
    seconds = time.perf_counter() - clock
    state, label, command = (np.array(x, dtype=str) for x in zip(*out))
    differ = (state != labels.state) | (label != labels.label) | (command != labels.command)
    return {"samples": len(rows), "seconds": seconds, "per_second": len(rows) / seconds,
            "per_sample_us": 1e6 * seconds / len(rows), "differ": int(differ.sum()),
            "events_differ": len(set(recogniser.events_) ^ set(labels.events))}


def hand_report(ev: HandEvaluation) -> str:
    """The evaluation as Markdown."""
    s = ev.settings
    pct = lambda x: f"{100 * x:.2f} %"  # noqa: E731
    off, live = ev.accuracy["offline"], ev.accuracy["live"]
    lines = [
        f"Trained on the training protocol of {s['train_people']} simulated people (seed {s['seed']}, {s['rounds']} "
        f"round trips per posture); tested on {s['test_people']} held-out people, one run each, at {s['rate']:g} Hz. "
        f"Windows (samples) {s['windows']}; channels {s['channels']}; other learner parameters "
        f"(`SetSupervisedLearner`, beyond its defaults) {s['learner']}. Offline: centred windows and one gesture per "
        f"gesture stretch; live: causal windows (what `HandRecognizer` gives sample by sample).",
        "",
        "| | paper | offline | live |",
        "|---|---:|---:|---:|",
        f"| labels (posture + gesture samples, six runs) | {PAPER['labels']:,} | {off['labels']:,} | "
        f"{live['labels']:,} |",
        f"| correct end to end | {pct(PAPER['accuracy'])} | {pct(off['correct'] / off['labels'])} | "
        f"{pct(live['correct'] / live['labels'])} |",
        f"| postures, end to end | | {pct(off['end_posture'])} | {pct(live['end_posture'])} |",
        f"| gestures, end to end | | {pct(off['end_gesture'])} | {pct(live['end_gesture'])} |",
    ]
    for c in COLLARS:
        o, v = ev.collars["offline"][c], ev.collars["live"][c]
        lines += [f"| postures, collar {c} ({c / s['rate']:.2f} s) | | {pct(o['end_posture'])} | "
                  f"{pct(v['end_posture'])} |",
                  f"| gestures, collar {c} ({c / s['rate']:.2f} s) | | {pct(o['end_gesture'])} | "
                  f"{pct(v['end_gesture'])} |"]
    lines += ["", "A collar of c leaves out the c samples on each side of every true change of state.", "",
              "From the observable onset: end to end, with each gesture of the truth taken to start and end where the "
              "palm moves at c of its movement's peak speed (c = 0: the simulator's truth, from rest to rest):", "",
              f"| c | gesture samples | offline postures | offline gestures | live postures | live gestures | "
              f"offline postures, collar {COLLARS[-1]} | offline gestures, collar {COLLARS[-1]} | "
              f"live postures, collar {COLLARS[-1]} | live gestures, collar {COLLARS[-1]} |",
              "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for c, o in ev.onsets["offline"].items():
        v, wide, live_wide = ev.onsets["live"][c][0], o[COLLARS[-1]], ev.onsets["live"][c][COLLARS[-1]]
        lines.append(f"| {100 * c:.0f} % | {o[0]['gestures']:,} | {pct(o[0]['end_posture'])} | "
                     f"{pct(o[0]['end_gesture'])} | {pct(v['end_posture'])} | {pct(v['end_gesture'])} | "
                     f"{pct(wide['end_posture'])} | {pct(wide['end_gesture'])} | "
                     f"{pct(live_wide['end_posture'])} | {pct(live_wide['end_gesture'])} |")
    lines.append("")
    lines += ["| mode | run | person | samples | labelled | stage 1 | stage 2 postures | stage 2 gestures "
              "| end to end postures | end to end gestures |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for mode in MODES:
        a = ev.accuracy[mode]
        for r in [*ev.runs[mode].to_dict("records"), {**a, "run": "all", "person": ""}]:
            lines.append(f"| {mode} | {r['run']} | {r['person']} | {r['samples']} | {pct(r['labelled'])} | "
                         f"{pct(r['stage1'])} | {pct(r['stage2_posture'])} | {pct(r['stage2_gesture'])} | "
                         f"{pct(r['end_posture'])} | {pct(r['end_gesture'])} |")
    lines += ["", "Stage 1 per true state: " + "; ".join(
        f"{mode} postures {pct(ev.accuracy[mode]['stage1_posture'])}, gestures "
        f"{pct(ev.accuracy[mode]['stage1_gesture'])}" for mode in MODES) + ".", ""]
    lines += [f"Gestures as events (a true gesture from {100 * EVENT_ONSET:.0f} % of its peak speed, detected by one "
              f"recognised event of that gesture starting within {EVENT_TOLERANCE:g} s of it; an event is a stretch "
              f"of the gesture state of at least {s['event_samples']} sample(s), named by the gesture most of its "
              f"samples carry):", "",
              "| mode | true gestures | recognised events | matched | precision | recall | F1 |",
              "|---|---:|---:|---:|---:|---:|---:|"]
    for mode in MODES:
        e = ev.events[mode]
        lines.append(f"| {mode} | {e['events']} | {e['detections']} | {e['matched']} | {e['precision']:.3f} | "
                     f"{e['recall']:.3f} | {e['f1']:.3f} |")
    lines.append("")
    if ev.peers:
        lines += _peer_table(ev, pct)
    places = ev.places.copy()
    for mode in MODES:
        places[mode] = places[mode].map(pct)
    places["speed mm/s"] = places["speed mm/s"].map(lambda x: f"{x:.1f}")
    lines += ["Where gestures are lost: end-to-end accuracy by the sample's place in its gesture (start +0 is the "
              "first sample the truth calls gesture), and the median measured palm speed there:", "",
              _markdown(places), ""]
    for mode in MODES:
        for name, table in ev.confusion[mode].items():
            if mode == "live" and name != "stage 1":
                continue
            lines += [f"Confusion, {mode}, {name} (rows true, columns recognised):", "", "```", table.to_string(),
                      "```", ""]
    lat = ev.latency
    lines += [
        f"Commands (live): {lat['onsets']} posture onsets, command reached for {pct(lat['reached'])}; latency from "
        f"the true onset median {lat['median']:.2f} s, 95th percentile {lat['p95']:.2f} s, max {lat['max']:.2f} s; "
        f"{ev.wrong_switches} switch(es) to a wrong command.",
        f"Streaming: {ev.streaming['per_second']:,.0f} samples per second ({ev.streaming['per_sample_us']:.0f} us per "
        f"20 Hz sample, three stages and the command), {ev.streaming['differ']} sample(s) and "
        f"{ev.streaming['events_differ']} gesture event(s) differing from live batch.",
        "Time: " + ", ".join(f"{k} {v:.1f} s" for k, v in ev.seconds.items()) + ".",
    ]
    return "\n".join(lines)


def _peer_table(ev: HandEvaluation, pct) -> list[str]:
    """Markdown lines: the recogniser beside each supervised peer, per mode (:func:`hand_figures`)."""
    rows = [("spotfree (class sets only)", hand_figures(ev.accuracy, ev.onsets, ev.events), ev.seconds["training"])]
    rows += [(name, hand_figures(p.accuracy, p.onsets, p.events), p.fit_seconds)
             for name, p in ev.peers.items()]
    collar = f"{100 * EVENT_ONSET:.0f} % onset, collar {COLLARS[-1] / ev.settings['rate']:g} s"
    lines = [f"Beside supervised peers trained on the same training sessions with every sample's true label (one "
             f"classifier of the five postures and eight gestures on every stage's channels, windows of "
             f"{PEER_WINDOW} samples: causal live, centred and voted per gesture stretch offline; fit: both "
             f"alignments, s; spotfree: its training):", "",
             f"| method | mode | postures per frame | postures ({collar}) | gestures ({collar}) | "
             f"events precision / recall / F1 | fit (s) |", "|---|---|---:|---:|---:|---:|---:|"]
    for name, figures, fit in rows:
        for mode in MODES:
            f = figures[mode]
            lines.append(f"| {name} | {mode} | {pct(f['postures'])} | {pct(f['postures_onset'])} | "
                         f"{pct(f['gestures'])} | {f['precision']:.3f} / {f['recall']:.3f} / {f['f1']:.3f} | "
                         f"{fit:.1f} |")
    return lines + [""]


def _markdown(table: pd.DataFrame) -> str:
    """A Markdown table of ``table``'s cells as they are (first column left-aligned, the others right)."""
    rows = [list(table.columns), ["---"] + ["---:"] * (len(table.columns) - 1)]
    rows += [[str(x) for x in row] for row in table.itertuples(index=False)]
    return "\n".join("| " + " | ".join(map(str, row)) + " |" for row in rows)
