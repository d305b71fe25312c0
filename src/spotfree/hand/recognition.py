"""Two-stage hand recognition trained without spotting: posture or gesture, then which one.

Four dictionaries, each learnt from class sets by :class:`~spotfree.learner.SetSupervisedLearner` (its parameters
per stage in :data:`STAGE_PARAMETERS`) and classified by its kernel CRC_RLS:

1. **state** (``posture`` / ``gesture``) on the :mod:`~spotfree.hand.motion` channels ``speed turn``, which do not
   depend on the posture held: ``state`` for offline labels and ``live-state``, learnt from the same sessions on
   whole windows, for live labels;
2. **posture** (the five postures) on palm position, normal (but its x) and direction;
3. **gesture** (the eight gestures) on palm velocity, normal, direction and the signed rates of the last two.

Training reads whole sessions of the training protocol (:data:`~spotfree.hand.vocabulary.TRAINING_TASKS`), each
declaring only the classes that occur in it:

======================  ===========================  ====================  ===========================================
session                 state                        posture               gesture
======================  ===========================  ====================  ===========================================
``hold``                posture                      straight              (not used: no gesture)
``out-X``               posture, gesture             straight, X           hold, straight-to-X
``round-X``             posture, gesture             straight, X           hold, straight-to-X, X-to-straight
======================  ===========================  ====================  ===========================================

The state stage is trained first; it then cuts every session (centred windows, offline) into the stretches it
calls posture and those it calls gesture, the latter widened by :data:`MARGIN` samples on both sides so that each
holds a little of the postures around it (``hold``, the gesture stage's background). The posture stage is trained
on the posture stretches and the gesture stage on the gesture stretches (the rest of a session is left NaN, so
that no window spans a cut); the ``hold`` class and its columns are then dropped from the gesture dictionary
(:func:`without_class`), so that it names one of the eight gestures. Ground truth is never read.

Recognition, per sample: the state label of the window that ends at it (live, ``live-state``) or is centred on it
(offline, ``state``), and the label of the posture or the gesture dictionary accordingly; offline, each stretch of
gesture samples then takes its most frequent gesture (:func:`vote_stretches`). The posture dictionary, trained on
posture stretches alone, reads only the samples of the current stretch of posture samples
(:mod:`spotfree.classify.confined`: a stretch that does not yet fill its window is completed with its first sample,
and offline with its last): the window of the first samples after a gesture would otherwise still hold the
gesture's end, unlike any window of its training. The gesture dictionary reads its windows as they come: it was
trained on gesture stretches widened by :data:`MARGIN`, so its windows hold the posture a gesture starts from.
:class:`HandRecognizer` gives the live labels one sample at a time, the same as :func:`recognise` on a whole
Recording. A sample at which any feature channel is not finite (no hand) gets no state and no label, and every stage
starts afresh after it.

Gestures as events, in both modes: one event per stretch of gesture samples at least as long as the state stage's
switching cost (its ``smoothing``: its decoding would make no shorter run), named by the gesture most of the
stretch's samples carry (:mod:`spotfree.classify.runs`). Live, the per-sample gesture label may change inside a
stretch (its first windows hold mostly the posture it leaves, which several gestures share); the event, known when
the stretch ends, is named by the whole movement.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from spotfree.classify.batch import classify_recording
from spotfree.classify.confined import StretchClassifier, classify_stretches
from spotfree.classify.runs import RunEvent, RunEvents, run_events, vote
from spotfree.classify.stream import RideClassifier
from spotfree.errors import InputError
from spotfree.hand.commands import CommandFilter
from spotfree.hand.features import FEATURES, hand_features
from spotfree.hand.frames import DIRECTION, NORMAL, VELOCITY
from spotfree.hand.motion import DIRECTION_RATE, MOTION, NORMAL_RATE, SOURCES, motion_channels, motion_step
from spotfree.hand.vocabulary import GESTURES, POSTURES, TRAINING_TASKS
from spotfree.io.checks import true_runs, write_text
from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.model import DictionaryModel

STAGES = ("state", "live-state", "posture", "gesture")
STATES = ("posture", "gesture")
HOLD = "hold"
"""Background class of the gesture stage's training (the postures at the ends of a gesture stretch)."""

STAGE_PARAMETERS = {
    "state": {"channels": ("speed", "turn"), "window": 4, "smoothing": 0.1, "column_share": 1.0,
              "share_power": 0.5},
    "live-state": {"channels": ("speed", "turn"), "window": 4, "smoothing": 0.1, "representation": "hankel",
                   "column_share": 1.0, "share_power": 0.5},
    "posture": {"channels": ("pos_x", "pos_y", "pos_z", "normal_y", "normal_z", *DIRECTION), "window": 6,
                "smoothing": 0.1, "column_share": 1.0, "share_power": 0.5},
    "gesture": {"channels": (*VELOCITY, *NORMAL, *DIRECTION, *NORMAL_RATE, *DIRECTION_RATE), "window": 6,
                "smoothing": 0.1, "representation": "hankel", "column_share": 1.0, "share_power": 0.5},
}
"""Parameters of each stage's :class:`~spotfree.learner.SetSupervisedLearner` beyond its defaults (``seed`` is
:attr:`HandTrainingConfig.seed`).

Windows, samples at 20 Hz: 0.2 s for the state (a causal window labels its last sample, so the live state lags a
change by up to a window), 0.3 s (the shortest gesture of the simulator) for the labels. ``smoothing``, the
switching cost of the learner's decoding in seconds, is 0.1 s in every stage, under the shortest gesture: a
gesture alternates with postures of a few seconds, and a longer cost merges it into them. ``column_share`` is 1 in
every stage: each session declares one posture, or one or two movements, beside the straight hand or the posture
held around them, which names the windows surely, so every window of a class may be a column, its slow starts and
ends included (the learner's step 4; measured on held-out people in ``benchmarks/hand_eval.py`` and
``benchmarks/evaluate_seeds.py``). ``share_power`` is the learner's first candidate, 0.5, given so that no stage's setting is
searched (:mod:`spotfree.selection`): the stages were measured with it.

Representations: the ``live-state`` stage (the state stage of live labels, learnt from the same sessions and class
sets as ``state``) and the gesture stage keep their windows whole (``hankel``), because the ``summary`` of a window
keeps of the order of its samples only the change of level and spread between its halves. A movement and its
reverse pass through the same orientations in the opposite order. And a live window labels its newest sample, while
the summary of a window in which the hand comes to rest is much like that of one in which it starts to move: with
summaries, the live windows just after a gesture, which still hold its end, were called gesture. Offline, a window
labels its middle sample, which its summary does not misplace, and the ``summary`` state finds a gesture's first
samples more often than ``hankel`` windows do; it also cuts the training sessions into the posture and gesture
stages' stretches.

Channels: the state stages read the motion channels ``speed`` and ``turn``, which do not depend on the posture held
(``flex`` is left out: the extended flags flip on tracking noise in a held posture as often as during a movement);
the posture stage reads palm position, normal and direction, but not ``normal_x`` (the palm's roll about the
forearm varies little between postures, so its small scale would let a person's habitual roll weigh much); the
gesture stage adds to the orientation the palm velocity and the signed rates of the normal and the direction,
which tell a movement ``X-to-straight`` from its reverse ``straight-to-X`` (the same orientations in the opposite
order)."""

MARGIN = 2
"""Samples by which a gesture stretch is widened on each side for the gesture stage's training (the ``hold``
background it then holds)."""


@dataclass
class HandTrainingConfig:
    """The learner's parameters per stage (:data:`STAGE_PARAMETERS`), the widening of gesture stretches (samples)
    and the seed of every stage's learner."""

    stages: dict[str, dict] = field(default_factory=lambda: {k: dict(v) for k, v in STAGE_PARAMETERS.items()})
    margin: int = MARGIN
    seed: int = 0


@dataclass
class HandModel:
    """The dictionaries of the two-stage recogniser: the state (offline), the state for live labels (a model
    without it, written before it existed, labels live with ``state``), the posture and the gesture."""

    state: DictionaryModel
    posture: DictionaryModel
    gesture: DictionaryModel
    live_state: DictionaryModel | None = None

    def stages(self) -> dict[str, DictionaryModel]:
        out = {"state": self.state, "live-state": self.live_state, "posture": self.posture, "gesture": self.gesture}
        return {stage: model for stage, model in out.items() if model is not None}

    def state_model(self, offline: bool) -> DictionaryModel:
        """The state dictionary of a mode: ``state`` offline, ``live_state`` (when there is one) live."""
        return self.state if offline or self.live_state is None else self.live_state

    def save(self, path: str | Path) -> None:
        """Write ``MODEL.npz`` (the state dictionary, naming its siblings) and ``MODEL.live-state.npz``,
        ``MODEL.posture.npz``, ``MODEL.gesture.npz`` next to it (:meth:`DictionaryModel.save` each)."""
        path = Path(path)
        if path.suffix != ".npz":
            raise InputError(f"{path}: a model file must end in .npz")
        stages = self.stages()
        siblings = {stage: _sibling(path, stage).name for stage in STAGES[1:] if stage in stages}
        for stage, name in siblings.items():
            stages[stage].save(path.parent / name)
        state = replace(self.state, parameters={**self.state.parameters, "hand": siblings})
        state.save(path)

    @classmethod
    def load(cls, path: str | Path) -> "HandModel":
        """Read a model written by :meth:`save` (four ``.npz`` files, or three without the live state; never
        unpickles)."""
        path = Path(path)
        state = DictionaryModel.load(path)
        siblings = state.parameters.get("hand")
        if not isinstance(siblings, dict) or not {"posture", "gesture"} <= set(siblings) <= set(STAGES[1:]):
            raise InputError(f"{path}: not a hand model (no posture and gesture stages); train one with "
                             f"'spotfree hand train -o {path.name}'")
        stages = {}
        for stage, name in siblings.items():
            if not (path.parent / name).exists():
                raise InputError(f"{path}: its {stage} stage {path.parent / name} is missing; keep the files of "
                                 f"'spotfree hand train' together")
            stages[stage.replace("-", "_")] = DictionaryModel.load(path.parent / name)
        for model in (state, stages.get("live_state")):
            if model is not None and sorted(model.classes) != sorted(STATES):
                raise InputError(f"{path}: state stage classes {model.classes} are not {list(STATES)}; retrain it")
        return cls(state=state, **stages)


@dataclass
class HandTrainingResult:
    """The model, each stage's fitted learner (window names, warnings) and what it was fitted on: per stage, the
    feature recordings and the class set each declares."""

    model: HandModel
    learners: dict[str, SetSupervisedLearner]
    inputs: dict[str, tuple[list[Recording], list[list[str]]]]


def _sibling(path: Path, stage: str) -> Path:
    return path.with_name(f"{path.stem}.{stage}.npz")


def session_tasks(rec: Recording) -> list[tuple[Recording, str]]:
    """The sessions of a training log, each with its task: the ``k``-th session in the file performs
    ``TRAINING_TASKS[k % 9]`` (the protocol of one person is its nine sessions in that order)."""
    parts = rec.experiments()
    if len(parts) % len(TRAINING_TASKS):
        raise InputError(
            f"{rec.source}: {len(parts)} session(s); a training log holds {len(TRAINING_TASKS)} sessions per person, "
            f"in the order {', '.join(TRAINING_TASKS)} (spotfree hand simulate --protocol training writes one)"
        )
    return [(part, TRAINING_TASKS[k % len(TRAINING_TASKS)]) for k, (_, part) in enumerate(parts)]


def features_of(rec: Recording) -> Recording:
    """Hand features and motion channels of a hand-tracking Recording (every channel a stage may use)."""
    feats = motion_channels(hand_features(rec))
    return feats.with_channels({c: feats.channels[c] for c in (*FEATURES, *MOTION)})


def declared(task: str, stage: str) -> list[str]:
    """Classes that occur in a session of ``task`` at ``stage`` (the table of the module docstring)."""
    kind, _, posture = task.partition("-")
    if stage == "state":
        return ["posture"] if kind == "hold" else ["posture", "gesture"]
    if stage == "posture":
        return ["straight"] if kind == "hold" else ["straight", posture]
    if kind == "hold":
        return []
    out = f"straight-to-{posture}"
    return [HOLD, out] if kind == "out" else [HOLD, out, f"{posture}-to-straight"]


def train_hand(sessions: list[tuple[Recording, str]], config: HandTrainingConfig | None = None,
               progress=None) -> HandTrainingResult:
    """Train the four stages from feature sessions (:func:`features_of`) of the training protocol, each with its
    task name (see the module docstring)."""
    config = config or HandTrainingConfig()
    say = progress or (lambda message: None)
    unknown = sorted({task for _, task in sessions} - set(TRAINING_TASKS))
    if unknown:
        raise InputError(f"unknown training task(s) {', '.join(unknown)}; use {', '.join(TRAINING_TASKS)}")
    missing = sorted(set(TRAINING_TASKS) - {task for _, task in sessions})
    if missing:
        raise InputError(f"training sessions lack the task(s) {', '.join(missing)}; record the whole protocol")

    learners = {stage: SetSupervisedLearner(**{**config.stages[stage], "seed": config.seed}) for stage in STAGES}
    inputs: dict[str, tuple[list[Recording], list[list[str]]]] = {}

    def fit(stage: str, recordings: list[Recording], class_sets: list[list[str]]) -> None:
        say(f"{stage} stage: {len(recordings)} sessions")
        inputs[stage] = (recordings, class_sets)
        for warning in learners[stage].fit(recordings, class_sets).warnings_:
            say(f"{stage} stage: {warning}")

    fit("state", [rec for rec, _ in sessions], [declared(task, "state") for _, task in sessions])
    fit("live-state", [rec for rec, _ in sessions], [declared(task, "state") for _, task in sessions])
    posture, gesture = ([], []), ([], [])
    for rec, task in sessions:
        labels = learners["state"].predict(rec, centred=True)
        moving = _widen(labels == "gesture", config.margin) & (labels != "")
        posture[0].append(_only(rec, (labels == "posture") & ~moving))
        posture[1].append(declared(task, "posture"))
        if declared(task, "gesture") and _longest_run(moving) >= learners["gesture"].window:
            gesture[0].append(_only(rec, moving))
            gesture[1].append(declared(task, "gesture"))
    fit("posture", *posture)
    fit("gesture", *gesture)
    model = HandModel(learners["state"].model_, learners["posture"].model_,
                      without_class(learners["gesture"].model_, HOLD), learners["live-state"].model_)
    for stage, classes in (("posture", POSTURES), ("gesture", GESTURES)):
        dictionary = getattr(model, stage)
        kept = {c for i, c in enumerate(dictionary.classes) if (dictionary.column_class == i).any()}
        absent = sorted(set(classes) - kept)
        if absent:
            raise InputError(f"the {stage} stage kept no windows of {', '.join(absent)}; the training sessions are "
                             f"too short or too few (record the protocol for more people)")
    return HandTrainingResult(model, learners, inputs)


def _widen(mask: np.ndarray, margin: int) -> np.ndarray:
    """``mask`` grown by ``margin`` samples on both sides."""
    if margin <= 0:
        return mask.copy()
    return np.convolve(mask.astype(int), np.ones(2 * margin + 1, dtype=int), mode="same") > 0


def _longest_run(mask: np.ndarray) -> int:
    return max((stop - start for start, stop in true_runs(mask)), default=0)


def _only(rec: Recording, keep: np.ndarray) -> Recording:
    """``rec`` with every channel NaN outside ``keep`` (no window spans the cut)."""
    return rec.with_channels({name: np.where(keep, values, np.nan) for name, values in rec.channels.items()})


def without_class(model: DictionaryModel, name: str) -> DictionaryModel:
    """``model`` without class ``name`` and its columns (centre-named and causal); the summary's column counts
    follow."""
    if name not in model.classes:
        return model
    classes = [c for c in model.classes if c != name]

    def drop(dictionary, column_class):
        named = np.asarray(model.classes)[column_class]
        keep = named != name
        return dictionary[:, keep], np.array([classes.index(c) for c in named[keep]], dtype=int)

    dictionary, index = drop(model.dictionary, model.column_class)
    causal = (None, None) if model.causal_dictionary is None else drop(model.causal_dictionary,
                                                                       model.causal_column_class)
    summary = {**model.summary, "dropped_class": name,
               "columns_per_class": {c: int((index == i).sum()) for i, c in enumerate(classes)}}
    return replace(model, classes=classes, dictionary=dictionary, column_class=index, causal_dictionary=causal[0],
                   causal_column_class=causal[1], summary=summary)


# ---------------------------------------------------------------- recognition


@dataclass
class HandLabels:
    """Per sample: ``state`` (posture / gesture), ``label`` and wheelchair ``command``; ``""`` where none. ``events``:
    the gestures as events (module docstring), their ``start`` and ``stop`` sample indices into these arrays."""

    time: np.ndarray
    state: np.ndarray
    label: np.ndarray
    command: np.ndarray
    experiment: np.ndarray | None = None
    events: list[RunEvent] = field(default_factory=list)

    def write_csv(self, path: str | Path) -> None:
        """Write ``time`` (s), ``state``, ``label`` and ``command`` as CSV, atomically."""
        columns = {"time": [repr(float(t)) for t in np.round(self.time, 9)], "state": self.state,
                   "label": self.label, "command": self.command}
        write_text(Path(path), pd.DataFrame(columns).to_csv(index=False, lineterminator="\n"))

    def write_events_csv(self, path: str | Path) -> None:
        """Write the gesture events as CSV, atomically: ``start`` and ``stop`` (s: the time of an event's first
        sample and of its last) and ``gesture``, one row per event."""
        columns = {"start": [repr(float(round(self.time[e.start], 9))) for e in self.events],
                   "stop": [repr(float(round(self.time[e.stop - 1], 9))) for e in self.events],
                   "gesture": [e.label for e in self.events]}
        write_text(Path(path), pd.DataFrame(columns, columns=["start", "stop", "gesture"])
                   .to_csv(index=False, lineterminator="\n"))


def recognise(model: HandModel, feats: Recording, confirm: float | None = None,
              offline: bool = False) -> HandLabels:
    """Label every sample of a feature Recording (:func:`features_of`), stage by stage, and derive the commands
    (:class:`~spotfree.hand.commands.CommandFilter`, ``confirm`` s, its default when None) and the gesture events.

    ``offline=False`` (live): causal windows, each labelling its newest sample, as :class:`HandRecognizer` does.
    ``offline=True`` (a whole log at once): centred windows, each labelling its middle sample, and one gesture per
    gesture stretch (:func:`vote_stretches`); it sees up to ``window // 2`` samples ahead, which a live stream
    cannot."""
    labels = {"state": classify_recording(model.state_model(offline), feats, centred=offline).label,
              "gesture": classify_recording(model.gesture, feats, centred=offline).label}
    state = labels["state"].astype(object)
    posture = classify_stretches(model.posture, feats, state == "posture", centred=offline)
    state = np.where((state != "") & (labels["gesture"] != ""), state, "")
    label = np.where(state == "posture", posture, np.where(state == "gesture", labels["gesture"], ""))
    return hand_labels(feats, state, label, offline, confirm, gesture_samples(model))


def hand_labels(feats: Recording, state: np.ndarray, label: np.ndarray, offline: bool, confirm: float | None = None,
                min_samples: int = 1) -> HandLabels:
    """:class:`HandLabels` from per-sample ``state`` and ``label`` (``""`` where none) of ``feats``' samples, by any
    recogniser: offline, every gesture stretch voted (:func:`vote_stretches`); the commands (``confirm`` s, the
    :class:`~spotfree.hand.commands.CommandFilter` default when None) and the gesture events (runs of the gesture
    state of at least ``min_samples``) of each experiment."""
    state = np.asarray(state, dtype=object)
    label = np.asarray(label, dtype=object)
    if offline:
        label = np.where(state == "gesture", vote_stretches(state == "gesture", label), label)
    commands = np.empty(len(feats), dtype=object)
    experiment = feats.experiment_numbers()
    for number in np.unique(experiment):
        rows = np.flatnonzero(experiment == number)
        command = CommandFilter(feats.rate) if confirm is None else CommandFilter(feats.rate, confirm)
        commands[rows] = [command.update(state[i], label[i]) for i in rows]
    events = run_events(state == "gesture", label.astype(str), min_samples, experiment)
    return HandLabels(feats.time, state.astype(str), label.astype(str), commands.astype(str), feats.experiment,
                      events)


def gesture_samples(model: HandModel) -> int:
    """Fewest samples of a gesture event: the state stage's switching cost (``smoothing``, s) in samples, at least
    one."""
    smoothing = float(model.state.parameters.get("smoothing", 0.0))
    return max(1, int(round(smoothing * model.state.rate / model.state.step)))


def vote_stretches(mask: np.ndarray, label: np.ndarray) -> np.ndarray:
    """``label`` with every run of consecutive ``mask`` samples given its most frequent label (ties: the one that
    comes first in the run, :func:`~spotfree.classify.runs.vote`); samples outside ``mask`` unchanged.

    A gesture is one movement from one posture to the next, so one stretch of gesture samples names one gesture:
    the windows at its ends, which hold part of the postures around it, are outvoted by those in its middle."""
    out = np.asarray(label, dtype=object).copy()
    for start, stop in true_runs(mask):
        out[start:stop] = vote(out[start:stop])
    return out


class HandRecognizer:
    """One feature sample in, ``(state, label, command)`` out; the same labels as :func:`recognise`. Each gesture
    event joins :attr:`events_` at the first sample after its stretch (or at :meth:`reset`), its sample indices
    counted from the recogniser's first sample: the events of :func:`recognise` on the same samples.

    A sample is the hand features of :data:`~spotfree.hand.features.FEATURES` (a dict by name, or a row in that
    order), e.g. a row of :func:`~spotfree.hand.features.hand_features`; the motion channels are computed here.
    """

    def __init__(self, model: HandModel, confirm: float | None = None):
        self.model = model
        self.rate = model.state.rate
        live = {"state": model.state_model(offline=False), "posture": model.posture, "gesture": model.gesture}
        missing = sorted({c for m in live.values() for c in m.channels} - set(_CHANNELS))
        if missing:
            raise InputError(f"model channel(s) {', '.join(missing)} are not hand features or motion channels")
        self._pick = {stage: np.array([_CHANNELS.index(c) for c in m.channels]) for stage, m in live.items()}
        self._classifiers = {stage: RideClassifier(live[stage]) for stage in ("state", "gesture")}
        self._posture = StretchClassifier(model.posture)
        self._sources = np.array([FEATURES.index(c) for c in SOURCES])
        self._commands = CommandFilter(self.rate) if confirm is None else CommandFilter(self.rate, confirm)
        self._events = RunEvents(gesture_samples(model))
        self.events_: list[RunEvent] = []
        self.reset()

    def reset(self) -> None:
        """A new session: every stage and the command start afresh; a gesture going on ends (its event, if it makes
        one, joins :attr:`events_`)."""
        for classifier in self._classifiers.values():
            classifier.reset()
        self._posture.reset()
        self._commands.reset()
        self._previous = np.full(len(SOURCES), np.nan)
        self._keep(self._events.finish())

    def _keep(self, event: RunEvent | None) -> None:
        if event is not None:
            self.events_.append(event)

    def update(self, sample) -> tuple[str, str, str]:
        """``(state, label, command)`` at this sample (``""`` for state and label where there is none)."""
        x = np.array([sample[c] for c in FEATURES] if isinstance(sample, dict) else sample, dtype=float)
        if x.shape != (len(FEATURES),):
            raise InputError(f"a hand sample holds {len(FEATURES)} features ({', '.join(FEATURES)}), got {x.shape}")
        source = x[self._sources]
        row = np.r_[x, motion_step(source, self._previous, self.rate)[0]]
        self._previous = source
        if not np.isfinite(row).all():
            row[:] = np.nan
        out = {stage: c.update_features(row[self._pick[stage]]) for stage, c in self._classifiers.items()}
        out["posture"] = self._posture.update(row[self._pick["posture"]], out["state"] == "posture")
        state = out["state"] if out["state"] and out["gesture"] else ""
        label = out[state] if state else ""
        self._keep(self._events.update(state == "gesture", label))
        return state, label, self._commands.update(state, label)


_CHANNELS = (*FEATURES, *MOTION)
