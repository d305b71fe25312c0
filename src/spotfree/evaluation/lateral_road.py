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
causally by :func:`~spotfree.classify.batch.classify_recording` and scored per true class
(:func:`~spotfree.evaluation.metrics.class_accuracy`); then again after the offline votes (:mod:`spotfree.votes`):
the segment vote at the spec's penalty, and the event vote and edges where the spec asks for them. The spec's short
classes (kerbs) are scored as detected events too (:func:`~spotfree.evaluation.metrics.event_detection`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spotfree.classify.batch import classify_recording
from spotfree.evaluation.metrics import EventScore, Score, class_accuracy, event_detection
from spotfree.io.recording import Recording
from spotfree.learner import SetSupervisedLearner
from spotfree.presets import PRESETS, preset_learner
from spotfree.model import DictionaryModel
from spotfree.signal.features import ride_features
from spotfree.sim.scenarios import CLASSES, simulate_scenario
from spotfree.votes.options import Votes, apply_votes, kept_classes, voted_labels


@dataclass(frozen=True)
class ModelSpec:
    """A model of one scenario's classes, learnt by the preset of the same name (:mod:`spotfree.presets`);
    ``one_kind``: trained on rides of one kind of manoeuvre each (:data:`KIND_RIDES`) rather than on mixed rides; its
    offline votes (:func:`spec_votes`): segment penalty, classes kept, event vote and event edges
    ``(channel, level)``; ``detections``: short classes also scored as detected events
    (:func:`~spotfree.evaluation.metrics.event_detection`)."""

    scenario: str
    one_kind: bool = False
    segments: float = 0.0
    keep: tuple[str, ...] = ()
    events: bool = False
    edges: tuple[tuple[str, float], ...] = ()
    detections: tuple[str, ...] = ()

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
                      detections=("kerb",)),
}
"""Per model: the offline votes it asks for (``segments``: the segment vote's
penalty, ``keep``: classes the votes leave as labelled, ``events``: the event vote outside the background after the
segment vote, ``edges``: where an event's start and end move to, by channel and level in its units); ``detections``:
short classes also scored as detected events: kerbs, which move the platform for the few tenths of a second of
their strike, are scored as strikes detected within 0.5 s.
``benchmarks/lateral_road.py`` measures the choices."""


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


@dataclass
class ModelScore:
    """A trained model and its per-class scores on the held-out experiments."""

    model: DictionaryModel
    per_class: dict[str, Score]
    overall: Score
    warnings: list[str] = field(default_factory=list)
    segmented: dict[str, Score] = field(default_factory=dict)
    segmented_overall: Score = Score(0, 0)
    detected: dict[str, EventScore] = field(default_factory=dict)
    """Per class of the spec's ``detections``, its events detected by the causal labels."""
    segmented_detected: dict[str, EventScore] = field(default_factory=dict)
    """The same after the offline votes."""

    @property
    def worst(self) -> float:
        """The lowest per-class accuracy (NaN classes skipped)."""
        rates = [s.rate for s in self.per_class.values() if s.total]
        return min(rates) if rates else float("nan")


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
    """Simulate ``scenario``; experiments ``n_train + 1..repeats`` are the tests. Training: experiments
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
    return Split(training, test, tests)


def score(model: DictionaryModel, test: Recording, scenario: str,
          votes: Votes = Votes()) -> tuple[dict[str, Score], Score]:
    """Per-class and overall accuracy of the causal labels of ``test`` (every labelled sample), after ``votes``
    (:func:`spec_votes`; the default runs none)."""
    return score_labels(voted_labels(model, test, votes).label, test, scenario)


def score_labels(labels: np.ndarray, test: Recording, scenario: str) -> tuple[dict[str, Score], Score]:
    """Per-class and overall accuracy of ``labels`` (one per sample of ``test``)."""
    per_class = class_accuracy(labels, test.truth["label"], CLASSES[scenario])
    return per_class, sum(per_class.values(), Score(0, 0))


def detections(spec: ModelSpec, labels: np.ndarray, test: Recording) -> dict[str, EventScore]:
    """The events of each class of ``spec.detections`` that ``labels`` detect in ``test``, per experiment."""
    return {name: event_detection(labels, test.truth["label"], name, test.experiment, test.rate)
            for name in spec.detections}


def spec_votes(spec: ModelSpec, model: DictionaryModel) -> Votes:
    """The offline votes of ``spec`` for ``model``: its segment penalty, the classes of ``spec.keep`` the model has,
    the background class of the event vote when ``spec.events`` and its event edges ``spec.edges``."""
    return Votes(spec.segments, kept_classes(spec.keep, model.classes),
                 (spec.background,) if spec.events else (), dict(spec.edges) if spec.events else {})


def train_and_score(spec: ModelSpec, data: Split, seed: int, **params) -> ModelScore:
    """Train ``spec`` on ``data.training`` (``params`` override the learner's parameters) and score it on
    ``data.test``."""
    recordings, sets = zip(*data.training)
    learner = spec.learner(seed, **params).fit(list(recordings), list(sets))
    model = learner.model_
    causal = classify_recording(model, data.test)
    per_class, overall = score_labels(causal.label, data.test, spec.scenario)
    scored = ModelScore(model, per_class, overall, list(learner.warnings_),
                        detected=detections(spec, causal.label, data.test))
    if spec.segments:
        voted = apply_votes(model, data.test, causal, spec_votes(spec, model)).label
        scored.segmented, scored.segmented_overall = score_labels(voted, data.test, spec.scenario)
        scored.segmented_detected = detections(spec, voted, data.test)
    return scored


def spec_split(spec: ModelSpec, seed: int, **options) -> Split:
    """:func:`split` of ``spec``'s scenario under its training protocol."""
    return split(spec.scenario, seed, one_kind=spec.one_kind, **options)
