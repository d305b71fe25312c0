"""spotfree's defaults across protocols (issue 71, point 6): randomised clip protocols on real recordings and the
simulator's protocols, each beside supervised peers and a naive set-supervised baseline trained on the same data.

spotfree is called through one function, :func:`spotfree_default`, with the training recordings and their class
sets and nothing else: a raw IMU log (channels ``ax ay az gx gy gz``) gets the features ``spotfree train`` gives it
with no option (ride or body features, chosen from the sets: :func:`spotfree.selection.select_features`), any other
recording is used as it is.

Real sets (``sp``, ``sw``, ``hapt``, ``basicmotions``): every recording is put on a 20 Hz grid with its six raw IMU
channels (accelerations in m/s^2 with gravity, rotation rates in rad/s) and, as truth, the label of the nearest raw
sample (:func:`real_har.on_grid`). The recordings of each training subject are joined, in their order, into one
stream (each recording an experiment of it, so that no window spans two). A protocol draws, from a seeded generator
(stratified over the draws of a set: :func:`draws`), a clip length from 2 to 20 s (log-uniform) and how many clips
each training subject gives, from 4 to all of those that fit in its stream (log-spaced); the clips are placed at
random in the stream without overlap, and a clip declares only the set of the classes in it. A clip longer than a
recording runs over into the next one (a run of concatenated clips). Whole recordings of the test subjects are
labelled per sample (at most :data:`TESTS` of them per set, spread evenly over the test subjects). Each draw is run with the channels named generically (``c1 .. c6``: spotfree sees plain
channels) and as an IMU log (``ax ay az gx gy gz``: spotfree's own feature choice applies); the two namings are two
protocols for spotfree, while every other method reads the same six channels under either name and runs once per
draw. Per set: two splits of its subjects, each with every seed of ``--seeds``, and both namings: 12 protocols
with the default three seeds.

* ``sp``, ``sw``: the phone and the watch of ``../shared/data/sp_sw_har`` (``real_har.py``'s reader); split
  ``first``: the first 12 subjects train, the other 11 are the test; ``last``: the last 12 train, the first 11 are
  the test. The short transitions ``STANDING_UP`` and ``SITTING_DOWN`` are also scored as events.
* ``hapt``: UCI HAPT's raw waist-phone streams (``../shared/data/hapt``, users 1-26, the first of each user's two
  sessions, 50 Hz read onto the 20 Hz grid; accelerations from g to m/s^2); split ``first``: users 1-13 train, 14-26 are the test;
  ``last`` the other way round. The six postural transitions are also scored as events. The stretches no label row
  covers (the lead-in, the pauses and turns between walks: 28 % of the samples) stay in the streams as recorded;
  they are named by no class: a clip declares the classes of its labelled samples only (a clip with none is
  dropped), the supervised peers skip the windows whose labelled sample has no label, and no method is scored
  on them (the 0.5-s collar of the scores also lies around their edges).
* ``basicmotions``: BasicMotions of the UEA archive joined into 80-s recordings as ``basic_motions.py`` joins them
  (the order seeded by the protocol's seed); each joined recording of the training split counts as a subject;
  split ``first``: the archive's training cases train and its test cases are the test, ``last`` the other way
  round.

Simulator sets (per seed of ``--seeds``, one protocol each; the ride features of every simulated file, which
``spotfree train`` would also compute, reach :func:`spotfree_default` as they are):

* ``braking``: ``learner_braking.py``'s protocol: experiment 1 of the normal-braking, sudden-braking and cruising
  files trains, each declaring its scenario's classes; experiments 2-7 are the test; sudden stops scored as events
  too;
* ``lateral``, ``road``: :mod:`spotfree.evaluation.lateral_road`'s split of each model (riders 1-4 trained on
  their rides of one manoeuvre or surface each, each declaring the classes in it; riders 5-7 of the mixed scenario
  are the test); the road is not scored while the vehicle stands still; kerb strikes scored as events too; no
  offline votes beyond the default labels' (the preset votes of ``spotfree evaluate`` are options);
* ``rare-events``: ``rare_events.py``'s protocol: rides 1-2 of each braking file cut into 10-s clips that declare
  ``sudden-braking, other`` or ``other``; rides 3-7 are the test; sudden stops scored as events.

Methods in the same run, on the same training data:

* ``spotfree``: :func:`spotfree_default`, class sets only;
* ``paper recipe``: :class:`spotfree.paper_recipe.PaperRecipe` with its defaults, class sets only;
* ``naive set forest``: the naive set-supervised baseline, class sets only: a random forest on the window features
  below, trained with one row per training window and class of its recording's declared set (every candidate taken
  as a label; the forest's class probabilities then share a window among its candidates);
* ``sliding 1-NN``, ``forest``, ``MiniRocket``: supervised peers given the label of every training sample
  (:mod:`spotfree.evaluation.peers`; the forest is a random forest on the window features of :class:`ForestPeer`).

Every window method (the peers and the naive baseline) uses windows of 1 s (20 samples) of every channel (the six
raw channels of a real set, every ride channel of a simulated one), each channel divided by its training standard
deviation; it is trained once per alignment (centred windows for the offline labels, with spotfree's vote over
0.5 s; causal windows for the live ones) on at most :data:`PEER_WINDOWS` training windows (every k-th window of
each training recording). The window features of the two forests are spotfree's ``summary`` representation
(:func:`spotfree.representation.represent`: level, spread, their change across the window and four band powers per
channel).

Scores (:mod:`spotfree.evaluation.metrics`): per-sample balanced accuracy (the mean of the per-class recalls) over
the labelled samples that lie more than 0.5 s from a true change, and the strict figure over every labelled
sample; offline (centred labels) and live (causal labels: each window labels its last sample); a set's short
classes also as events (a true run detected by a run of its label within 0.5 s; F1 and false alarms per hour
without the event). Per set and method: the median and the worst case over its protocols, offline and live.

    python benchmarks/protocols.py [--sets sp sw hapt basicmotions braking lateral road rare-events]
                                   [--seeds 0 1 2] [--jobs 1] [--results protocols] [--quick]

``--jobs N``: N sets at once, each in its own process; ``--results NAME``: write ``NAME.md`` instead. ``--quick``: one protocol draw per real set (seed 0, split
``first``, four clips per subject, both namings) on a few test recordings and seed 0 of each simulator set, printed
only (a smoke run). Otherwise writes ``benchmarks/results/protocols.md`` (command, machine, date, the measured
spotfree's commit, tables), after every protocol (the sets still running named at its end).
"""

from __future__ import annotations

import argparse
import functools
import math
import queue
import shlex
import subprocess
import sys
import time
import zlib
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field, replace
from datetime import datetime, timezone
from multiprocessing import Manager
from pathlib import Path

import numpy as np
from sklearn.ensemble import RandomForestClassifier

from basic_motions import recordings as basic_motions_recordings
from machine import RESULTS, describe
from rare_events import EVENT as SUDDEN, SCENARIOS as BRAKING_SCENARIOS, two_classes
from real_har import DATA as SP_SW_HAR, EVENTS as HAR_EVENTS, balanced, clips, load as load_har, on_grid
from spotfree.classify.smoothing import VOTE_SECONDS
from spotfree.evaluation.lateral_road import MODELS, STANDING_SPEED, spec_split
from spotfree.evaluation.metrics import EventScore, event_detection, near_transitions
from spotfree.evaluation.peers import MiniRocketPeer, NearestNeighbourPeer
from spotfree.evaluation.peers.base import WindowClassifierPeer
from spotfree.io.recording import GPS_CHANNELS, IMU_CHANNELS, Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.paper_recipe import PaperRecipe
from spotfree.selection import select_features
from spotfree.pipeline import feature_recording
from spotfree.representation import represent
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario


def spotfree_default(train_recordings, class_sets):
    """spotfree with no option beyond the recordings and their class sets, as ``spotfree train`` trains: raw IMU logs
    become ride or body features, whichever the held-out set risk prefers
    (:func:`spotfree.selection.select_features`), other channels are used as they are; then
    :class:`~spotfree.learner.SetSupervisedLearner` with its defaults (its settings chosen from the sets). Returns a
    model whose ``predict(recording, centred=bool)`` labels every sample of a recording read the same way."""
    learner = SetSupervisedLearner()
    kinds = ("ride", "body") if all(r.has_imu for r in train_recordings) else ("ride",)
    candidates = {kind: [feature_recording(r, features=kind) for r in train_recordings] for kind in kinds}
    kind = select_features(learner, candidates, [set(s) for s in class_sets])[0] if len(kinds) > 1 else kinds[0]
    return _Featured(learner.fit(candidates[kind], class_sets), kind)


class _Featured:
    """A fitted learner that turns each recording it labels into the features (``kind``) it was trained on."""

    def __init__(self, learner, kind: str):
        self.learner, self.kind = learner, kind

    def predict(self, recording: Recording, centred: bool = True) -> np.ndarray:
        return self.learner.predict(feature_recording(recording, features=self.kind), centred=centred)


TITLE = "spotfree's defaults across protocols"
RATE = 20.0
HAPT = SP_SW_HAR.parent / "hapt"
GENERIC = tuple(f"c{k}" for k in range(1, 7))
"""The six raw channels named generically: spotfree sees plain channels."""
NAMINGS = {"generic": GENERIC, "IMU": IMU_CHANNELS}
CLIP_SECONDS = (2.0, 20.0)
"""Range of the clip lengths drawn (log-uniform), s."""
FEWEST_CLIPS = 4
"""Fewest clips a training subject gives (all of them when fewer fit)."""
SPLITS = ("first", "last")
PEER_WINDOWS = 2_000
"""Most training windows a window method fits on per alignment (every k-th window of each recording)."""
MINIROCKET_KERNELS = 1_008
"""MiniRocket features (aeon rounds to a multiple of 84): fewer than ``real_har.py``'s 2,016 so that the run fits
its time on the shared 2-core machine."""
FOREST_TREES = 100
REAL_SETS = ("sp", "sw", "hapt", "basicmotions")
SIMULATED_SETS = ("braking", "lateral", "road", "rare-events")
TESTS = {"sp": 36, "sw": 36, "hapt": 6, "basicmotions": 5}
"""Most test recordings per real set, spread evenly over its test subjects' recordings (each whole), so that the
run fits its time: a third of sp_sw_har's, six of HAPT's sessions of the test users (about 6 min each), every
joined BasicMotions recording."""
QUICK_TESTS = 6
"""Most test recordings per real set in a ``--quick`` run."""
HAPT_SESSIONS = 1
"""Sessions per HAPT user read (each user recorded two): the first only, so that the run fits its time."""
SIMULATOR_EVENTS = {"braking": (SUDDEN,), "rare-events": (SUDDEN,), "lateral": MODELS["lateral"].detections,
                    "road": MODELS["road"].detections}
"""The short classes of each simulator set scored as events too."""
SIMULATOR_CLIP = 10.0
"""Clip length of the rare-event protocol, s (``rare_events.py``'s default)."""


# ------------------------------------------------------------------ data
@dataclass
class Task:
    """One protocol's data: training recordings and their declared sets (``namings``: the training and test
    recordings under each naming of their channels, for spotfree only), the tests (``truth["label"]``, ``""``
    where unlabelled; ``truth["scored"]``, when present, marks the samples that count) and the short classes
    scored as events."""

    train: list[Recording]
    sets: list[list[str]]
    tests: list[Recording]
    events: tuple[str, ...]
    params: dict
    namings: dict[str, tuple[list[Recording], list[Recording]]] = field(default_factory=dict)


def raw(rec: Recording) -> Recording:
    """``rec`` with its six raw IMU channels only, named generically (:data:`GENERIC`)."""
    return rec.with_channels({g: rec.channels[c] for g, c in zip(GENERIC, IMU_CHANNELS)})


def named(rec: Recording, names: tuple[str, ...]) -> Recording:
    """``rec`` (channels :data:`GENERIC`) with its channels named ``names``."""
    return rec.with_channels({n: rec.channels[g] for n, g in zip(names, GENERIC)})


def joined(recordings: list[Recording], source: str) -> Recording:
    """``recordings`` (one rate, the same channels) one after the other, each an experiment of the result."""
    n = [len(r) for r in recordings]
    return Recording(np.arange(sum(n)) / RATE,
                     {c: np.concatenate([r.channels[c] for r in recordings]) for c in recordings[0].channels},
                     RATE, source, {"label": np.concatenate([r.truth["label"] for r in recordings]).astype(str)},
                     np.repeat(np.arange(1, len(n) + 1), n))


def har_subjects(device: str) -> dict[str, list[Recording]]:
    """Per subject of sp_sw_har, its recordings of ``device`` (``sp`` or ``sw``) in order, raw channels."""
    out: dict[str, list[Recording]] = {}
    for path in sorted((SP_SW_HAR / "DATA").glob(f"s*/s*_{device}.csv.gz")):
        out.setdefault(path.parent.name, []).append(raw(load_har(path)))
    return out


def hapt_subjects() -> dict[str, list[Recording]]:
    """Per HAPT user, its first session (:data:`HAPT_SESSIONS`), raw channels; unlabelled samples ``""``."""
    sys.path.insert(0, str(HAPT))
    from load_hapt import CLASSES as HAPT_CLASSES, FS, G, iter_recordings

    out: dict[str, list[Recording]] = {}
    names = np.array(HAPT_CLASSES + ("",))  # index -1 (unlabelled) is the last one
    for rid, t, values, y in iter_recordings(str(HAPT)):
        values = values * np.r_[[G] * 3, [1.0] * 3]  # accelerometer g -> m/s^2
        user = rid.split("_")[1]
        if len(out.get(user, [])) < HAPT_SESSIONS:
            out.setdefault(user, []).append(raw(on_grid(np.arange(len(values)) / FS, values, names[y], rid)))
    return out


def basic_motions_subjects(order: int) -> dict[str, dict[str, list[Recording]]]:
    """Per archive split, BasicMotions' cases joined in the order seeded by ``order`` (each joined recording a
    subject of one recording), raw channels."""
    return {split: {f"{split} {k}": [raw(r)] for k, r in enumerate(basic_motions_recordings(split, order))}
            for split in ("train", "test")}


@dataclass(frozen=True)
class Draw:
    """The parameters of one protocol of a real set: its split, seed, clip length (s) and where between
    :data:`FEWEST_CLIPS` (0) and every clip that fits (1) each subject's number of clips lies, on a log scale."""

    split: str
    seed: int
    clip: float
    share: float


def draws(name: str, seeds: list[int]) -> list[Draw]:
    """The protocol draws of real set ``name``: one per split and seed. Clip lengths are log-uniform over
    :data:`CLIP_SECONDS`, stratified (one in each of as many equal strata as draws, the strata in a random order)
    and the shares of clips spread evenly from 0 (the fewest) to 1 (all), in a random order, so that the draws of
    a set cover both ranges; the generator is seeded by the set's name and the seeds."""
    rng = np.random.default_rng([zlib.crc32(name.encode()), *seeds])
    k = len(SPLITS) * len(seeds)
    strata = (rng.permutation(k) + rng.uniform(size=k)) / k
    clip = CLIP_SECONDS[0] * (CLIP_SECONDS[1] / CLIP_SECONDS[0]) ** strata
    share = rng.permutation(np.linspace(0.0, 1.0, k)) if k > 1 else np.ones(1)
    cells = [(split, seed) for split in SPLITS for seed in seeds]
    return [Draw(split, seed, round(float(c), 1), float(s)) for (split, seed), c, s in zip(cells, clip, share)]


def place_clips(stream: Recording, seconds: float, share: float, rng: np.random.Generator) -> list[Recording]:
    """Clips of ``seconds`` placed at random in ``stream`` without overlap (uniformly over such placements): from
    :data:`FEWEST_CLIPS` (``share`` 0) to all that fit (``share`` 1), log-spaced; clips without a labelled sample
    are dropped."""
    length = int(round(seconds * RATE))
    fit = len(stream) // length
    count = fit if fit <= FEWEST_CLIPS else int(round(FEWEST_CLIPS * (fit / FEWEST_CLIPS) ** share))
    starts = np.sort(rng.integers(0, len(stream) - count * length + 1, count)) + length * np.arange(count)
    out = [stream.take(slice(int(a), int(a) + length)) for a in starts]
    return [c for c in out if np.any(c.truth["label"] != "")]


def declared(rec: Recording) -> list[str]:
    """The classes of the labelled samples of ``rec``: what its clip declares."""
    return sorted(set(rec.truth["label"].astype(str)) - {""})


def real_task(subjects: dict[str, list[Recording]], train_ids: list[str], test_ids: list[str], draw: Draw,
              events: tuple[str, ...], most_tests: int) -> Task:
    """The :class:`Task` of ``draw``: clips of the training subjects' streams, and at most ``most_tests`` of the
    test subjects' recordings, spread evenly over them."""
    rng = np.random.default_rng([draw.seed, int(draw.clip * 10), SPLITS.index(draw.split)])
    train, per_subject = [], []
    for s in train_ids:
        placed = place_clips(joined(subjects[s], s), draw.clip, draw.share, rng)
        train += placed
        per_subject.append(len(placed))
    tests = [r for s in test_ids for r in subjects[s]]
    tests = [tests[k] for k in np.unique(np.linspace(0, len(tests) - 1, most_tests).round().astype(int))]
    sets = [declared(c) for c in train]
    params = {"split": draw.split, "seed": draw.seed, "clip s": draw.clip,
              "clips per subject": f"{min(per_subject)}-{max(per_subject)}", "clips": len(train),
              "distinct sets": len({tuple(s) for s in sets}), "test recordings": len(tests)}
    namings = {name: ([named(c, names) for c in train], [named(r, names) for r in tests])
               for name, names in NAMINGS.items()}
    return Task(train, sets, tests, events, params, namings)


class RealSet:
    """A real data set: its subjects (loaded once) and the split of their ids."""

    def __init__(self, name: str):
        self.name = name
        self.events = {"sp": HAR_EVENTS, "sw": HAR_EVENTS, "hapt": None, "basicmotions": ()}[name]
        self._subjects: dict[str, list[Recording]] | None = None
        if name == "hapt":
            sys.path.insert(0, str(HAPT))
            from load_hapt import CLASSES as HAPT_CLASSES, TRANSITIONS

            self.events = tuple(HAPT_CLASSES[k] for k in TRANSITIONS)

    def task(self, draw: Draw, quick: bool) -> Task:
        most_tests = min(TESTS[self.name], QUICK_TESTS) if quick else TESTS[self.name]
        if self.name == "basicmotions":  # the archive's own split; the order of the cases is the protocol's seed
            data = basic_motions_subjects(draw.seed)
            train, test = ("train", "test") if draw.split == "first" else ("test", "train")
            return real_task({**data[train], **data[test]}, list(data[train]), list(data[test]), draw, self.events,
                             most_tests)
        if self._subjects is None:
            self._subjects = hapt_subjects() if self.name == "hapt" else har_subjects(self.name)
        ids = sorted(self._subjects)
        if draw.split == "last":
            ids = ids[::-1]
        first = 12 if self.name in ("sp", "sw") else len(ids) // 2
        return real_task(self._subjects, ids[:first], ids[first:], draw, self.events, most_tests)


@functools.lru_cache(maxsize=None)
def braking_rides(seed: int) -> dict[str, Recording]:
    """The ride features of the simulator's normal-braking, sudden-braking and cruising files (seven rides each),
    simulated once per seed for the braking and the rare-event protocols."""
    return {s: ride_features(simulate_scenario(s, repeats=7, seed=seed), derived=True) for s in BRAKING_SCENARIOS}


def simulated_task(name: str, seed: int) -> Task:
    """The :class:`Task` of simulator set ``name`` (module docstring) for ``seed``."""
    if name == "braking":
        feats = braking_rides(seed)
        train = [feats[s].select_experiment(1) for s in BRAKING_SCENARIOS]
        sets = [list(CLASSES[s]) for s in BRAKING_SCENARIOS]
        tests = [feats[s].select_experiment(k) for s in BRAKING_SCENARIOS for k in range(2, 8)]
    elif name == "rare-events":
        feats = braking_rides(seed)
        train = [c for s in BRAKING_SCENARIOS for k in (1, 2)
                 for c in clips(two_classes(feats[s].select_experiment(k)), SIMULATOR_CLIP)]
        sets = [declared(c) for c in train]
        tests = [two_classes(feats[s].select_experiment(k)) for s in BRAKING_SCENARIOS for k in range(3, 8)]
    else:
        spec = MODELS[name]
        data = spec_split(spec, seed)
        train, sets = [r for r, _ in data.training], [list(s) for _, s in data.training]
        test = data.test
        if spec.moving_only:
            test.truth["scored"] = data.speed >= STANDING_SPEED
        tests = [test]
    params = {"seed": seed, "training recordings": len(train), "distinct sets": len({tuple(s) for s in sets}),
              "test recordings": len(tests)}
    return Task(train, sets, tests, SIMULATOR_EVENTS[name], params)


# ------------------------------------------------------------------ methods
class ForestPeer(WindowClassifierPeer):
    """Supervised random forest on the window features of spotfree's ``summary`` representation
    (:func:`spotfree.representation.represent`) of the channel-scaled windows."""

    def __init__(self, channels=GENERIC, window: int = 20, alignment: str = "causal", train_step: int = 1,
                 vote: float = VOTE_SECONDS, n_estimators: int = FOREST_TREES, random_state: int = 0):
        super().__init__(channels=channels, window=window, alignment=alignment, train_step=train_step, vote=vote)
        self.n_estimators = n_estimators
        self.random_state = random_state

    def _make_estimator(self):
        return RandomForestClassifier(n_estimators=self.n_estimators, random_state=self.random_state, n_jobs=1)

    def _features(self, windows: np.ndarray) -> np.ndarray:
        m, c, length = windows.shape
        return represent(windows.reshape(m, c * length).T, c, "summary")


def every_candidate(train: list[Recording], sets: list[list[str]]) -> list[Recording]:
    """Each training recording once per class of its declared set, every sample labelled that class: the naive
    set-supervised baseline's training data (one row per window and candidate class)."""
    out = []
    for rec, classes in zip(train, sets):
        for c in classes:
            copy = rec.take(slice(None))
            copy.truth["label"] = np.full(len(rec), c)
            out.append(copy)
    return out


def train_step(train: list[Recording], window: int = 20) -> int:
    """Every how many windows a window method fits on: at most :data:`PEER_WINDOWS` over ``train``."""
    windows = sum(max(0, len(r) - window + 1) for r in train)
    return max(1, math.ceil(windows / PEER_WINDOWS))


class Aligned:
    """A window method trained once per alignment: ``predict(recording, centred)`` takes the matching one."""

    def __init__(self, make: Callable[[str], WindowClassifierPeer], train: list[Recording]):
        self.centred, self.causal = make("centred").fit(train), make("causal").fit(train)

    def predict(self, recording: Recording, centred: bool = True) -> np.ndarray:
        return (self.centred if centred else self.causal).predict(recording)


def methods(task: Task) -> dict[str, tuple[str, Callable[[], object], list[Recording] | None]]:
    """Per method name: its supervision, a function that fits it on the task's training data (returning an object
    with ``predict(recording, centred)``), and the test recordings it labels (None: the task's own)."""
    channels = tuple(c for c in task.train[0].names if c not in GPS_CHANNELS)
    step = train_step(task.train)

    def window_method(make):
        return lambda: Aligned(make, task.train)

    def naive():
        candidates = every_candidate(task.train, task.sets)
        naive_step = train_step(candidates)
        return Aligned(lambda a: ForestPeer(channels, alignment=a, train_step=naive_step), candidates)

    out = {}
    for naming, (train, tests) in (task.namings or {"": (task.train, None)}).items():
        name = f"spotfree, {naming} names" if naming else "spotfree"
        out[name] = ("class sets", lambda train=train: spotfree_default(train, task.sets), tests)
    out.update({
        "paper recipe": ("class sets", lambda: PaperRecipe().fit(task.train, task.sets), None),
        "naive set forest": ("class sets", naive, None),
        "sliding 1-NN": ("every label", window_method(
            lambda a: NearestNeighbourPeer(channels, alignment=a, train_step=step)), None),
        "forest": ("every label", window_method(lambda a: ForestPeer(channels, alignment=a, train_step=step)), None),
        "MiniRocket": ("every label", window_method(
            lambda a: MiniRocketPeer(channels, alignment=a, train_step=step, n_kernels=MINIROCKET_KERNELS)), None),
    })
    return out


# ------------------------------------------------------------------ scores
def score(predictions: list[np.ndarray], tests: list[Recording], classes: list[str], events: tuple[str, ...]) -> dict:
    """Balanced accuracy away from true changes (``away``) and over every scored sample (``strict``), each class's
    recall away from changes, and the ``events`` pooled (:class:`~spotfree.evaluation.metrics.EventScore` summed
    over the classes) of ``predictions`` on ``tests``. Scored: samples with a label (and ``truth["scored"]``)."""
    pred = np.concatenate(predictions).astype(str)
    truth = np.concatenate([r.truth["label"] for r in tests]).astype(str)
    scored = (truth != "") & np.concatenate([r.truth.get("scored", np.ones(len(r), bool)) for r in tests])
    near = np.concatenate([near_transitions(r.truth["label"], r.experiment, r.rate) for r in tests])
    strict, _ = balanced(pred, truth, scored, classes)
    away, recall = balanced(pred, truth, scored & ~near, classes)
    ride = np.concatenate([1000 * k + r.experiment_numbers() for k, r in enumerate(tests)])
    shown = np.where(scored, pred, "")
    pooled = sum((event_detection(shown, truth, c, ride, tests[0].rate) for c in events if c in classes),
                 EventScore(0, 0, 0, 0.0))
    return {"away": away, "strict": strict, "recall": recall, "events": pooled if events else None}


def run_task(task: Task, label: str) -> dict[str, dict]:
    """Every method of :func:`methods` fitted on ``task`` and scored offline and live on its tests; a method that
    fails is reported with its error and left out."""
    classes = sorted(set().union(*task.sets))
    results = {}
    for name, (supervision, fit, tests) in methods(task).items():
        start = time.perf_counter()
        try:
            model = fit()
            offline = [model.predict(r, centred=True) for r in tests or task.tests]
            live = [model.predict(r, centred=False) for r in tests or task.tests]
        except Exception as err:  # noqa: BLE001 - one failed method must not end a 40-minute run
            print(f"{label} {name}: failed: {type(err).__name__}: {err}", file=sys.stderr)
            continue
        results[name] = {"supervision": supervision, "seconds": time.perf_counter() - start,
                         "offline": score(offline, task.tests, classes, task.events),
                         "live": score(live, task.tests, classes, task.events)}
        r = results[name]
        print(f"{label} {name}: offline {100 * r['offline']['away']:.1f} %, live {100 * r['live']['away']:.1f} % "
              f"({r['seconds']:.0f} s)", file=sys.stderr, flush=True)
    return results


# ------------------------------------------------------------------ report
def pct(value: float) -> str:
    return "-" if value is None or not np.isfinite(value) else f"{100 * value:.1f}"


def f1(e: EventScore) -> float:
    """The events' F1, 0 when there were events and none was detected (nothing fired or only false alarms)."""
    return e.f1 if np.isfinite(e.f1) or not e.events else 0.0


def event_cell(e: EventScore | None) -> str:
    return "-" if e is None else f"{f1(e):.2f} ({e.detected}/{e.events}, {e.false_alarms_per_hour:.0f}/h)"


def summary_rows(runs: list[tuple[dict, dict]], spotfree_names: list[str]) -> list[tuple[str, str, list[dict]]]:
    """Per summary row: its name, supervision and the results it summarises (one per protocol). spotfree's
    namings are pooled into one row (every protocol) and also shown apart."""
    rows = []
    if len(spotfree_names) > 1:
        rows.append(("spotfree (every protocol)", "class sets",
                     [res[n] for _, res in runs for n in spotfree_names if n in res]))
    names = dict.fromkeys(n for _, res in runs for n in res)
    for name in names:
        got = [res[name] for _, res in runs if name in res]
        rows.append((name, got[0]["supervision"], got))
    return rows


def summary_table(runs: list[tuple[dict, dict]], events: bool) -> list[str]:
    """Median and worst case over the protocols, per method, offline and live."""
    spotfree_names = [n for n in dict.fromkeys(n for _, res in runs for n in res) if n.startswith("spotfree")]
    head = ("| method | supervision | protocols | offline: median | offline: worst | live: median | live: worst | "
            "offline strict: median | live strict: median |")
    rule = "|---|---|---|---|---|---|---|---|---|"
    if events:
        head += " events offline F1: median / worst | events live F1: median / worst | false alarms per h offline / live: median |"
        rule += "---|---|---|"
    lines = [head, rule]
    for name, supervision, got in summary_rows(runs, spotfree_names):
        cells = []
        for mode in ("offline", "live"):
            away = np.array([g[mode]["away"] for g in got])
            cells += [pct(np.nanmedian(away)), pct(np.nanmin(away))]
        strict = [pct(np.nanmedian([g[mode]["strict"] for g in got])) for mode in ("offline", "live")]
        line = f"| {name} | {supervision} | {len(got)} | " + " | ".join(cells + strict) + " |"
        if events:
            scores = {m: np.array([f1(g[m]["events"]) for g in got]) for m in ("offline", "live")}
            alarms = [np.nanmedian([g[m]["events"].false_alarms_per_hour for g in got]) for m in ("offline", "live")]
            line += (" " + " | ".join(f"{np.nanmedian(scores[m]):.2f} / {np.nanmin(scores[m]):.2f}"
                                      for m in ("offline", "live")) + f" | {alarms[0]:.0f} / {alarms[1]:.0f} |")
        lines.append(line)
    return lines


def protocol_table(runs: list[tuple[dict, dict]], events: bool) -> list[str]:
    """One row per protocol and method: the protocol's parameters, balanced accuracy away from changes (strict in
    brackets) offline and live, the events and the method's time (fit and labelling)."""
    keys = list(runs[0][0])
    head = "| " + " | ".join(keys) + " | method | offline | live |" + (" events offline | events live |" if events else "") + " s |"
    lines = [head, "|" + "---|" * (len(keys) + 4 + 2 * events)]
    for params, res in runs:
        for name, r in res.items():
            cells = [f"{pct(r[m]['away'])} ({pct(r[m]['strict'])})" for m in ("offline", "live")]
            if events:
                cells += [event_cell(r[m]["events"]) for m in ("offline", "live")]
            lines.append("| " + " | ".join(str(params[k]) for k in keys) + f" | {name} | " + " | ".join(cells)
                         + f" | {r['seconds']:.0f} |")
    return lines


def goals(runs: list[tuple[dict, dict]]) -> list[str]:
    """Issue 71's goals for a set, read off its runs: spotfree's worst case against 1-NN's, its median against
    MiniRocket's, and per protocol against the naive set-supervised baseline."""
    spotfree_names = [n for n in dict.fromkeys(n for _, res in runs for n in res) if n.startswith("spotfree")]
    lines = []
    for mode in ("offline", "live"):
        ours = [res[n][mode]["away"] for _, res in runs for n in spotfree_names if n in res]
        peer = {m: [res[m][mode]["away"] for _, res in runs if m in res]
                for m in ("sliding 1-NN", "MiniRocket", "naive set forest")}
        if not ours or not all(peer.values()):
            continue
        beaten = [(p["seed"] if "split" not in p else f"{p['split']} seed {p['seed']}", n)
                  for p, res in runs for n in spotfree_names
                  if n in res and "naive set forest" in res and res[n][mode]["away"] < res["naive set forest"][mode]["away"]]
        lines.append(
            f"- {mode}: spotfree's worst case {pct(min(ours))} % against 1-NN's {pct(min(peer['sliding 1-NN']))} % "
            f"({'met' if min(ours) >= min(peer['sliding 1-NN']) else 'not met'}); its median {pct(np.median(ours))} % "
            f"against MiniRocket's {pct(np.median(peer['MiniRocket']))} % "
            f"({'met' if np.median(ours) >= np.median(peer['MiniRocket']) else 'not met'}); below the naive set "
            f"forest in {len(beaten)} of {len(ours)} protocols"
            + (": " + ", ".join(f"{where} ({n.removeprefix('spotfree, ') or 'spotfree'})" for where, n in beaten)
               if beaten else ""))
    return lines


def settings() -> list[str]:
    """The run's fixed settings, for the results file."""
    namings = ", ".join(f"{name} ({' '.join(channels)})" for name, channels in NAMINGS.items())
    return [f"- real sets: splits {', '.join(SPLITS)}; clip lengths {CLIP_SECONDS[0]:g}-{CLIP_SECONDS[1]:g} s "
            f"(log-uniform, stratified); {FEWEST_CLIPS} to all clips per training subject; namings {namings}",
            f"- window methods: 1-s windows (20 samples), at most {PEER_WINDOWS:,} training windows per alignment; "
            f"forests of {FOREST_TREES} trees on the summary features; MiniRocket {MINIROCKET_KERNELS:,} features; "
            "naive set forest: one row per training window and declared class",
            "- scores: balanced accuracy (mean of per-class recalls over the classes declared in training) of the "
            "labelled samples more than 0.5 s from a true change, strict (every labelled sample) beside; offline = "
            "centred labels, live = causal labels; the worst case is the lowest figure over a set's protocols"]


def report(name: str, runs: list[tuple[dict, dict]], events: tuple[str, ...], seconds: float,
           planned: int) -> list[str]:
    """The section of set ``name`` (``runs`` of its ``planned`` protocol draws or seeds): summary, goals and the
    per-protocol table."""
    state = "" if len(runs) == planned else f" of {planned} (the others not run yet)"
    lines = [f"## {name}", "", f"{len(runs)}{state} protocol draw(s) or seed(s), {seconds / 60:.1f} min.", ""]
    if events:
        lines += [f"Events: {', '.join(events)}, pooled over these classes (F1; detected / true, false alarms per "
                  "hour without the event).", ""]
    uninformative = [str(p["draw"]) for p, _ in runs if p.get("distinct sets") == 1]
    if uninformative:
        lines += [f"In draw(s) {', '.join(uninformative)} every clip declares the same set (clips longer than the "
                  "recordings' sequences of classes): the sets tell nothing there, so no method learns from them.", ""]
    lines += ["Median and worst case over the protocols, balanced accuracy away from changes (%):", "",
              *summary_table(runs, bool(events)), "", "Goals (issue 71):", "", *goals(runs), "",
              "Per protocol (balanced accuracy away from changes, %, strict in brackets; s: fit and labelling):", "",
              *protocol_table(runs, bool(events)), ""]
    return lines


def run_set(name: str, seeds: list[int], quick: bool, progress) -> None:
    """Every protocol of set ``name``; after each, its section of the report so far goes to the queue ``progress``
    as ``(name, lines, finished)``. The draws of a real set run from the fewest clips per subject to the most, so
    that a run stopped early has its cheaper protocols."""
    started, runs = time.perf_counter(), []
    if name in REAL_SETS:
        data = RealSet(name)
        protocols = [replace(draws(name, seeds)[0], share=0.0)] if quick else draws(name, seeds)
        cases = sorted(enumerate(protocols, 1), key=lambda case: case[1].share)
        events = data.events
    else:
        cases = [(seed, seed) for seed in (seeds[:1] if quick else seeds)]
        events = SIMULATOR_EVENTS[name]
    for k, case in cases:
        task = data.task(case, quick) if name in REAL_SETS else simulated_task(name, case)
        params = {"draw": k, **task.params} if name in REAL_SETS else task.params
        print(f"{name}: " + ", ".join(f"{key} {value}" for key, value in params.items()), file=sys.stderr, flush=True)
        runs.append((params, run_task(task, f"{name} {'draw' if name in REAL_SETS else 'seed'} {k}")))
        runs.sort(key=lambda run: tuple(run[0].values())[0])
        progress.put((name, report(name, runs, events, time.perf_counter() - started, len(cases)),
                      len(runs) == len(cases)))


def source() -> str:
    """Where the measured spotfree comes from: its folder, git commit and whether its ``src`` differs from it."""
    import spotfree

    folder = Path(spotfree.__file__).resolve().parent
    git = ["git", "-C", str(folder)]
    try:
        commit = subprocess.run([*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = subprocess.run([*git, "status", "--porcelain", "--", "."], capture_output=True, text=True,
                               check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return f"spotfree from {folder} (not a git checkout)"
    return f"spotfree from {folder}, commit {commit}" + (", with uncommitted changes" if dirty else ", clean")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sets", nargs="+", default=[*REAL_SETS, *SIMULATED_SETS],
                        choices=[*REAL_SETS, *SIMULATED_SETS])
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="protocol seeds (real sets: per "
                        "split; simulator sets: the simulator's seed)")
    parser.add_argument("--quick", action="store_true", help="one protocol per set (4 clips per subject) on a few "
                        "test recordings, printed only (a smoke run)")
    parser.add_argument("--jobs", type=int, default=1, help="sets run at once, each in its own process")
    parser.add_argument("--results", default="protocols", help="name of the results file in benchmarks/results "
                        "(without .md)")
    args = parser.parse_args()
    if args.jobs < 1:
        parser.error("--jobs takes a number of processes >= 1")
    started = time.perf_counter()
    header = [f"# {TITLE}", "", f"- command: `{shlex.join(['python', 'benchmarks/protocols.py', *sys.argv[1:]])}`",
              f"- machine: {describe(('numpy', 'scipy', 'scikit-learn', 'aeon'))}",
              f"- date: {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC", f"- measured: {source()}", "",
              " ".join(__doc__.split("\n\n")[0].split()), "", *settings(), ""]
    sections: list[str] = []
    print("\n".join(header))
    sections: dict[str, list[str]] = {}
    finished: set[str] = set()
    with Manager() as manager, ProcessPoolExecutor(max_workers=args.jobs) as pool:
        progress = manager.Queue()
        running = [pool.submit(run_set, name, args.seeds, args.quick, progress) for name in args.sets]
        while len(finished) < len(args.sets):
            try:
                name, lines, complete = progress.get(timeout=10)
            except queue.Empty:
                failed = [f for f in running if f.done() and f.exception()]
                if failed:
                    raise failed[0].exception()
                continue
            sections[name] = lines
            if complete:
                finished.add(name)
                print("\n".join(lines), flush=True)
            left = [n for n in args.sets if n not in finished]
            footer = (f"Sets still running or to run: {', '.join(left)}." if left else
                      f"Wall time of the run: {(time.perf_counter() - started) / 60:.1f} min.")
            if not args.quick:  # after every protocol, so that a run stopped early leaves what it measured
                RESULTS.mkdir(exist_ok=True)
                (RESULTS / f"{args.results}.md").write_text(
                    "\n".join([*header, *(line for n in args.sets if n in sections for line in sections[n]),
                               footer]) + "\n")
    print(footer)


if __name__ == "__main__":
    main()
