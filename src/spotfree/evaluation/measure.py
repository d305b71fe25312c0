"""The runs of an evaluation, each timed by wall clock (``time.perf_counter``, seconds) on the test rides.

* Spotting-free CRC_RLS on every test window, with causal and with centred windows
  (:mod:`spotfree.classify.batch`; :data:`HEADLINE` is the alignment a live ride assistant can use); the same for
  kernel CRC_RLS (:mod:`spotfree.classify.kcrc`, not in the paper) on the same dictionary.
* CRC_RLS vs SRC vs B_SRC on one subsample of test windows: the model's stride raised to ``k`` so that each
  scenario gives about ``Protocol.method_windows`` windows, the same windows for the three methods; only the
  samples a window decides (every ``k``-th labelled sample, not the ones its label is held over) are scored.
* The peers (:mod:`spotfree.evaluation.peers`), trained on the training experiments with their ground-truth
  labels, on the model's channels and window, labelling the same tests.
"""

from __future__ import annotations

import math
import time
import warnings
from contextlib import contextmanager
from dataclasses import dataclass, field, replace

import numpy as np

from spotfree.classify.batch import Labels, classify_recording, dictionary_classifier
from spotfree.evaluation.protocol import TRAINED_ON, Protocol, ScenarioData
from spotfree.model import DictionaryModel
from spotfree.evaluation.peers import ClaspPeer, MiniRocketPeer, NearestNeighbourPeer, Peer
from spotfree.evaluation.peers.base import from_aeon

ALIGNMENTS = ("causal", "centred")
HEADLINE = "causal"
"""The alignment of the headline figures: the window ending at a sample labels it, as on the phone."""
METHODS = {"crc": "CRC_RLS", "kcrc": "kernel CRC_RLS (not in the paper)", "src": "SRC", "bsrc": "B_SRC",
           "nearest": "nearest columns (not in the paper)"}
"""Classifier methods compared (:data:`spotfree.classify.METHODS` names) and their names in the paper."""


@dataclass
class Run:
    """One method's labels on one scenario's tests: ``seconds`` to make ``decisions`` of them (one window each for
    a window classifier); ``scored`` marks the samples decided (None: every labelled sample)."""

    labels: Labels
    seconds: float
    decisions: int
    scored: np.ndarray | None = None

    def decided(self) -> np.ndarray:
        """Labels of the scored samples, ``""`` elsewhere."""
        if self.scored is None:
            return self.labels.label.astype(str)
        return np.where(self.scored, self.labels.label, "").astype(str)


@dataclass
class MethodRuns:
    """One classifier method (or peer): fit time (s) and a :class:`Run` per scenario; messages it raised."""

    name: str
    fit_seconds: float
    runs: dict[str, Run] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    @property
    def seconds(self) -> float:
        return sum(r.seconds for r in self.runs.values())

    @property
    def decisions(self) -> int:
        return sum(r.decisions for r in self.runs.values())


def crc_runs(model: DictionaryModel, data: dict[str, ScenarioData], method: str = "crc") -> dict[str, MethodRuns]:
    """Labels of every test sample by ``method`` (``"crc"`` or ``"kcrc"``), per alignment (:data:`ALIGNMENTS`)."""
    out = {}
    for alignment in ALIGNMENTS:
        start = time.perf_counter()
        clf = dictionary_classifier(model, method, causal=alignment == "causal")
        runs = MethodRuns(f"{METHODS[method]} ({alignment})", time.perf_counter() - start)
        for name, scenario in data.items():
            start = time.perf_counter()
            labels = classify_recording(model, scenario.test, method, centred=alignment == "centred",
                                        classifier=clf)
            runs.runs[name] = Run(labels, time.perf_counter() - start, int(labels.labelled().sum()))
        out[alignment] = runs
    return out


def method_runs(model: DictionaryModel, data: dict[str, ScenarioData], target: int) -> dict[str, MethodRuns]:
    """Every method of :data:`METHODS` (causal windows) on a common subsample of about ``target`` windows per
    scenario."""
    out = {}
    for method, name in METHODS.items():
        start = time.perf_counter()
        clf = dictionary_classifier(model, method, causal=True)
        runs = MethodRuns(name, time.perf_counter() - start)
        for scenario_name, scenario in data.items():
            stride = max(1, math.ceil(_window_count(scenario, model.window) / target))
            strided = replace(model, step=stride)
            with _noted(runs, scenario_name):
                start = time.perf_counter()
                labels = classify_recording(strided, scenario.test, method, classifier=clf)
                seconds = time.perf_counter() - start
            scored = np.zeros(len(labels), dtype=bool)
            for a, b in labels.stretches():
                scored[a:b:stride] = True
            runs.runs[scenario_name] = Run(labels, seconds, int(scored.sum()), scored)
        out[method] = runs
    return out


def check_peers() -> None:
    """Raise before a long run when a peer's library is missing (MiniRocket and ClaSP come from aeon)."""
    from_aeon("aeon.classification.convolution_based", "MiniRocketClassifier")
    from_aeon("aeon.transformations.series", "ClaSPTransformer")


MINIROCKET = "MiniRocket (supervised)"
"""The name of the MiniRocket peer, the supervised peer of every ride model (causal windows: live)."""
MINIROCKET_OFFLINE = "MiniRocket (supervised, centred)"
"""The name of the same peer on centred windows (offline), with the majority vote every offline label gets."""
NEAREST = "1-NN (supervised)"
"""The name of the 1-nearest-neighbour peer."""


def make_peers(channels, window: int, protocol: Protocol, train_step: int = 1) -> dict[str, Peer]:
    """The peers on ``channels`` and ``window`` (samples), window classifiers aligned as :data:`HEADLINE` (and
    MiniRocket once more on centred windows) and fitted on every ``train_step``-th training window."""
    common = {"channels": tuple(channels), "window": int(window)}
    minirocket = {"n_kernels": protocol.minirocket_kernels, "random_state": protocol.seed, "train_step": train_step}
    return {
        MINIROCKET: MiniRocketPeer(**common, alignment=HEADLINE, **minirocket),
        MINIROCKET_OFFLINE: MiniRocketPeer(**common, alignment="centred", **minirocket),
        NEAREST: NearestNeighbourPeer(**common, alignment=HEADLINE, train_step=train_step),
        "ClaSP (segments named by class centroids)": ClaspPeer(**common),
    }


def peer_runs(peers: dict[str, Peer], data: dict[str, ScenarioData]) -> dict[str, MethodRuns]:
    """Fit every peer on the training experiments (with their ``label`` truth) and label every scenario's tests."""
    training = [data[s].training for s in TRAINED_ON]
    out = {}
    for name, peer in peers.items():
        runs = MethodRuns(name, 0.0)
        with _noted(runs, "training"):
            peer.fit(training)
        runs.fit_seconds = peer.fit_time_
        for scenario_name, scenario in data.items():
            with _noted(runs, scenario_name):
                predicted = peer.predict(scenario.test)
            labels = Labels(time=scenario.test.time, label=np.asarray(predicted, dtype=object),
                            rate=scenario.test.rate, experiment=scenario.test.experiment, source=scenario.test.source,
                            meta={"method": name})
            runs.runs[scenario_name] = Run(labels, peer.predict_time_, int(np.sum(predicted != "")))
        out[name] = runs
    return out


@contextmanager
def _noted(runs: MethodRuns, where: str):
    """Keep the warnings raised inside the block as ``runs.notes`` (``where: message``) for the report."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield
    runs.notes += [f"{runs.name}, {where}: {w.message}" for w in caught]


def _window_count(scenario: ScenarioData, window: int) -> int:
    """Windows of ``window`` samples (stride 1) inside the gap-free segments of the tests."""
    return sum(max(0, stop - start - window + 1) for start, stop in scenario.test.segments())
