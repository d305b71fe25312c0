"""Lateral-manoeuvre and road-surface models: spotting-free training and per-class accuracy on held-out riders.

Per model (:data:`MODELS`), one simulated file of its scenario and one of the other scenario (``repeats``
experiments each, one seed; every experiment draws its own rider) are split: experiments ``1..n_train`` of both are
trained on, experiments ``n_train + 1..repeats`` of the model's own scenario are the held-out tests. Training is
the general learner (:class:`~spotfree.learner.SetSupervisedLearner`) on the ride features, each training experiment
declaring only the set of the model's classes that occur somewhere in it, as a rider who knows what the ride held
would declare it: in its own scenario the classes of its labels; in the other scenario the classes its confounders
amount to (:data:`EVENT_CLASSES`: a road ride's gentle turns, a lateral ride's surface patches and kerbs). A spec
with ``one_kind`` (both models now) trains instead, as the paper does, on one recording per manoeuvre: each training
rider rides once per kind of manoeuvre or road event and once without any (:data:`KIND_RIDES`). Tests are labelled
by :func:`~spotfree.classify.batch.classify_recording` in the streams of :data:`STREAMS`: causal windows (live),
centred windows, and the centred labels after the offline votes (:mod:`spotfree.votes`: the segment vote at the
spec's penalty, and the event vote and edges where the spec asks for them); supervised peers trained on the same
rides with every label may label them beside. Each stream is scored per true class
(:func:`~spotfree.evaluation.metrics.class_accuracy`), strictly and away from true label changes
(:func:`~spotfree.evaluation.metrics.near_transitions`), leaving out where the vehicle stands still for a spec that
asks it; the spec's short classes (kerbs) are scored as detected events too
(:func:`~spotfree.evaluation.metrics.event_detection`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from spotfree.classify.batch import classify_recording
from spotfree.evaluation.peers.base import Peer
from spotfree.evaluation.metrics import EventScore, Score, class_accuracy, event_detection, near_transitions
from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.presets import PRESETS, preset_learner
from spotfree.model import DictionaryModel
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_ride, simulate_scenario
from spotfree.votes.options import Votes, apply_votes, kept_classes, voted_labels


@dataclass(frozen=True)
class ModelSpec:
    """A model of one scenario's classes, learnt by the preset of the same name (:mod:`spotfree.presets`);
    ``one_kind``: trained on rides of one kind of manoeuvre each (:data:`KIND_RIDES`) rather than on mixed rides; its
    offline votes (:func:`spec_votes`): segment penalty, classes kept, event vote and event edges
    ``(channel, level)``; ``detections``: short classes also scored as detected events
    (:func:`~spotfree.evaluation.metrics.event_detection`); ``moving_only``: samples where the vehicle stands still
    (true speed under :data:`STANDING_SPEED`) are not scored."""

    scenario: str
    one_kind: bool = False
    segments: float = 0.0
    keep: tuple[str, ...] = ()
    events: bool = False
    edges: tuple[tuple[str, float], ...] = ()
    detections: tuple[str, ...] = ()
    moving_only: bool = False

    @property
    def background(self) -> str:
        """The scenario's background class (the first of :data:`~spotfree.sim.scenarios.CLASSES`)."""
        return CLASSES[self.scenario][0]

    @property
    def channels(self) -> tuple[str, ...]:
        """The channels of the scenario's preset."""
        return PRESETS[self.scenario]["channels"]

    @property
    def window(self) -> int:
        """The window (samples) of the scenario's preset."""
        return PRESETS[self.scenario]["window"]

    def learner(self, seed: int, **params) -> SetSupervisedLearner:
        """The learner of the scenario's preset (``params`` override the learner's parameters)."""
        return preset_learner(self.scenario, seed=seed, **params)


MODELS = {
    "lateral": ModelSpec("lateral", one_kind=True, segments=4.0,
                         events=True, edges=(("yaw_rate", 0.09),)),
    "road": ModelSpec("road", one_kind=True, segments=8.0, keep=("kerb",),
                      detections=("kerb",), moving_only=True),
}
"""Per model: the offline votes it asks for (``segments``: the segment vote's
penalty, ``keep``: classes the votes leave as labelled, ``events``: the event vote outside the background after the
segment vote, ``edges``: where an event's start and end move to, by channel and level in its units); ``detections``:
short classes also scored as detected events: kerbs, which move the platform for the few tenths of a second of
their strike, are scored as strikes detected within 0.5 s; ``moving_only``: the road surface is not scored while
the vehicle stands still, where no sensor sees it.
``benchmarks/lateral_road.py`` measures the choices."""

STANDING_SPEED = 0.3
"""True speed (m/s) under which the vehicle stands still (:attr:`ModelSpec.moving_only`)."""
STREAMS = ("live", "centred", "offline vote")
"""A model's own label streams: causal windows (what a live ride shows), centred windows (offline, half a window
later) and the centred labels after the spec's offline votes (:func:`spec_votes`; they see the whole ride)."""


KIND_RIDES = {"lateral": (("gentle",), ("sharp",), ("slalom",), ()),
              "road": (("rough-asphalt",), ("cobblestone",), ("kerb",), ())}
"""Per scenario, the rides each training rider records under the ``one_kind`` protocol: the kinds of manoeuvre of
each ride (:func:`~spotfree.sim.scenarios.simulate_scenario` ``manoeuvres``; none: a straight ride)."""

OTHER = {"lateral": "road", "road": "lateral"}
"""The scenario whose rides are added to a model's training."""
EVENT_CLASSES = {
    "lateral": {"turn": "gentle-turn"},
    "road": {"rough-asphalt": "rough-asphalt", "cobblestone": "cobblestone", "kerb": "kerb", "bump": "kerb"},
}
"""Per model, the class a confounder of the other scenario (:data:`spotfree.sim.scenarios` ``event``) amounts to:
a confounding turn is 0.15-0.35 rad/s (below :data:`~spotfree.sim.scenarios.SHARP`), a bump strikes like a kerb."""


@dataclass
class Split:
    """One scenario file as ride features: the training experiments with their declared classes, and the tests."""

    training: list[tuple[Recording, list[str]]]
    test: Recording
    test_experiments: list[int]
    speed: np.ndarray
    """The simulator's true speed (m/s) at every test sample."""


@dataclass
class ModelScore:
    """A trained model and its label streams on the held-out experiments ``test``: per stream name (:data:`STREAMS`,
    then any peer's name) one label per test sample, ``""`` where the stream gives none or the sample is not scored
    (:func:`scored_labels`)."""

    spec: ModelSpec
    model: DictionaryModel
    test: Recording
    labels: dict[str, np.ndarray]
    warnings: list[str] = field(default_factory=list)
    peer_seconds: dict[str, float] = field(default_factory=dict)
    """Per peer, the wall time (s) of its fit and its labelling of the tests."""

    def per_class(self, stream: str = "live", collar: bool = False) -> dict[str, Score]:
        """Per true class, the share of its scored samples that ``stream`` labels so; ``collar``: leaving out the
        samples within :data:`~spotfree.evaluation.metrics.TRANSITION_BAND` of a true label change."""
        truth = self.test.truth["label"]
        label = self.labels[stream]
        if collar:
            label = np.where(near_transitions(truth, self.test.experiment, self.test.rate), "", label)
        return class_accuracy(label, truth, CLASSES[self.spec.scenario])

    def overall(self, stream: str = "live", collar: bool = False) -> Score:
        """Every scored sample of ``stream`` (:meth:`per_class` summed)."""
        return sum(self.per_class(stream, collar).values(), Score(0, 0))

    def worst(self, stream: str = "live", collar: bool = True) -> tuple[str, Score]:
        """The class of lowest :meth:`per_class` rate and its score (classes with no scored sample skipped)."""
        scored = [(c, s) for c, s in self.per_class(stream, collar).items() if s.total]
        return min(scored, key=lambda item: item[1].rate)

    def events(self, name: str, stream: str = "live") -> EventScore:
        """The true events of class ``name`` that ``stream`` detects, per experiment
        (:func:`~spotfree.evaluation.metrics.event_detection`)."""
        return event_detection(self.labels[stream], self.test.truth["label"], name, self.test.experiment,
                               self.test.rate)


def declared_classes(labels: np.ndarray, scenario: str) -> list[str]:
    """The scenario's classes that occur in ``labels``, in :data:`~spotfree.sim.scenarios.CLASSES` order."""
    present = set(np.asarray(labels).astype(str))
    return [c for c in CLASSES[scenario] if c in present]


def event_classes(events: np.ndarray, scenario: str) -> list[str]:
    """The classes of ``scenario`` that the confounders ``events`` (``+``-joined names) of another scenario's ride
    amount to, with the background class, in :data:`~spotfree.sim.scenarios.CLASSES` order."""
    names = {name for joined in np.asarray(events).astype(str) for name in joined.split("+")}
    present = {CLASSES[scenario][0]} | {c for name, c in EVENT_CLASSES[scenario].items() if name in names}
    return [c for c in CLASSES[scenario] if c in present]


def split(scenario: str, seed: int, repeats: int = 7, n_train: int = 4, rate: float = 20.0,
          one_kind: bool = False) -> Split:
    """Simulate ``scenario``; experiments ``n_train + 1..repeats`` are the tests, with their true speed. Training: experiments
    ``1..n_train`` of ``scenario`` and of :data:`OTHER` of it, or with ``one_kind`` the rides of the same riders
    (experiments ``1..n_train``) of :data:`KIND_RIDES`, each declaring the classes of its labels."""
    def features(other: bool = False, manoeuvres: tuple[str, ...] | None = None) -> Recording:
        return ride_features(simulate_scenario(OTHER[scenario] if other else scenario, repeats=repeats, seed=seed,
                                               rate=rate, manoeuvres=manoeuvres), derived=True)

    feats = features()
    by_labels = lambda rec: declared_classes(rec.truth["label"], scenario)  # noqa: E731
    by_events = lambda rec: event_classes(rec.truth["event"], scenario)  # noqa: E731
    sources = ([(features(manoeuvres=kinds), f" ({', '.join(kinds) or 'straight'})", by_labels)
                for kinds in KIND_RIDES[scenario]] if one_kind else
               [(feats, "", by_labels), (features(other=True), "", by_events)])
    training = []
    for source, kinds, declare in sources:
        for k in range(1, n_train + 1):
            rec = source.select_experiment(k)
            rec.source = f"{source.meta['scenario']}{kinds} seed {seed} experiment {k}"
            training.append((rec, declare(rec)))
    tests = list(range(n_train + 1, repeats + 1))
    test = feats.take(np.isin(feats.experiment, tests))
    test.source = f"{scenario} seed {seed} experiments {tests[0]}-{tests[-1]}"
    speed = np.concatenate([simulate_ride(scenario, k, repeats=repeats, seed=seed, rate=rate).truth["speed"]
                            for k in tests])
    return Split(training, test, tests, speed)


def score(model: DictionaryModel, test: Recording, scenario: str,
          votes: Votes = Votes()) -> tuple[dict[str, Score], Score]:
    """Per-class and overall accuracy of the centred labels of ``test`` (every labelled sample), after ``votes``
    (:func:`spec_votes`; the default runs none)."""
    return score_labels(voted_labels(model, test, votes).label, test, scenario)


def score_labels(labels: np.ndarray, test: Recording, scenario: str) -> tuple[dict[str, Score], Score]:
    """Per-class and overall accuracy of ``labels`` (one per sample of ``test``)."""
    per_class = class_accuracy(labels, test.truth["label"], CLASSES[scenario])
    return per_class, sum(per_class.values(), Score(0, 0))


def scored_labels(spec: ModelSpec, labels: np.ndarray, data: Split) -> np.ndarray:
    """``labels`` with ``""`` on the test samples ``spec`` does not score (standing still when ``moving_only``)."""
    labels = np.asarray(labels).astype(str)
    return np.where(data.speed < STANDING_SPEED, "", labels) if spec.moving_only else labels


def spec_votes(spec: ModelSpec, model: DictionaryModel) -> Votes:
    """The offline votes of ``spec`` for ``model``: its segment penalty, the classes of ``spec.keep`` the model has,
    the background class of the event vote when ``spec.events`` and its event edges ``spec.edges``."""
    return Votes(spec.segments, kept_classes(spec.keep, model.classes),
                 (spec.background,) if spec.events else (), dict(spec.edges) if spec.events else {})


def train_and_score(spec: ModelSpec, data: Split, seed: int, peers: dict[str, Peer] | None = None,
                    **params) -> ModelScore:
    """Train ``spec`` on ``data.training`` (``params`` override the learner's parameters), label ``data.test`` in
    every stream of :data:`STREAMS`; each of ``peers`` is fitted on the same training rides with their ground truth
    and labels the tests too (under its name), a peer on centred windows (offline) after the spec's votes, as the
    model's offline labels are."""
    recordings, sets = zip(*data.training)
    learner = spec.learner(seed, **params).fit(list(recordings), list(sets))
    model = learner.model_
    centred, votes = classify_recording(model, data.test, centred=True), spec_votes(spec, model)
    streams = {"live": classify_recording(model, data.test).label, "centred": centred.label,
               "offline vote": apply_votes(model, data.test, centred, votes).label}
    scored = ModelScore(spec, model, data.test, {name: scored_labels(spec, label, data)
                                                for name, label in streams.items()}, list(learner.warnings_))
    for name, peer in (peers or {}).items():
        predicted = peer.fit(list(recordings)).predict(data.test)
        if getattr(peer, "alignment", None) == "centred":
            predicted = apply_votes(model, data.test, replace(centred, label=predicted, meta={}), votes).label
        scored.labels[name] = scored_labels(spec, predicted, data)
        scored.peer_seconds[name] = peer.fit_time_ + peer.predict_time_
    return scored


def spec_split(spec: ModelSpec, seed: int, **options) -> Split:
    """:func:`split` of ``spec``'s scenario under its training protocol."""
    return split(spec.scenario, seed, one_kind=spec.one_kind, **options)
