"""The paper's dictionary recipe taken literally (section IV-B), kept as a baseline for the general learner.

Each recording is treated alone. Its windows (block-Hankel columns, each divided by its l2 norm) are split in two by
Ordered Subspace Clustering (:class:`~spotfree.cluster.osc.OrderedSubspaceClustering`); the larger cluster is named
the recording's most common class (the declared class found in the most recordings: the background), the smaller
its most specific one (the declared class found in the fewest). A recording that declares three or more classes has
its smaller cluster split once more and keeps the larger half, as the paper's sudden stop keeps the hard braking
inside it. A recording that declares one class gives all its windows to it. At most ``max_columns`` windows per
class, spread evenly, become the dictionary, classified by CRC_RLS (:class:`~spotfree.classify.crc.CRCClassifier`).
"""

from __future__ import annotations

from collections import Counter

import numpy as np
from sklearn.base import BaseEstimator

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.cluster.osc import OrderedSubspaceClustering
from spotfree.errors import InputError
from spotfree.io.recording import GPS_CHANNELS, Recording
from spotfree.model import DictionaryModel
from spotfree.windows import ChannelScaling, recording_windows


class PaperRecipe(BaseEstimator):
    """The paper's recipe (module docstring) with the estimator interface of
    :class:`~spotfree.learner.SetSupervisedLearner`.

    Parameters
    ----------
    channels : tuple of str or None
        Channels windowed; None: every channel of the first recording but the sparse GPS ones.
    window, step : int
        Window length and stride, samples.
    max_columns : int
        Most dictionary columns per class.
    seed : int
        Seed of the clustering.
    """

    def __init__(self, channels: tuple[str, ...] | None = None, window: int = 20, step: int = 1,
                 max_columns: int = 300, seed: int = 0):
        self.channels = channels
        self.window = window
        self.step = step
        self.max_columns = max_columns
        self.seed = seed

    def fit(self, recordings: list[Recording], class_sets):
        recordings, sets = list(recordings), [set(s) for s in class_sets]
        if not recordings or len(sets) != len(recordings) or not all(sets):
            raise InputError("give one recording per class set, each declaring at least one class")
        channels = (tuple(self.channels) if self.channels else
                    tuple(c for c in recordings[0].names if c not in GPS_CHANNELS))
        frequency = Counter(c for s in sets for c in s)
        self.classes_ = sorted(frequency)
        scaling = ChannelScaling(channels).fit(recordings)
        columns, names = [], []
        for rec, declared in zip(recordings, sets):
            matrix = recording_windows(rec, channels, self.window, self.step, scaling, "unit").matrix
            order = sorted(declared, key=lambda c: (-frequency[c], c))
            per = self._split(matrix, order)
            columns.append(matrix[:, per != ""])
            names.append(per[per != ""])
        matrix, names = np.hstack(columns), np.concatenate(names)
        keep = []
        for c in self.classes_:
            idx = np.flatnonzero(names == c)
            if len(idx) > self.max_columns:
                idx = idx[np.linspace(0, len(idx) - 1, self.max_columns).round().astype(int)]
            keep.append(idx)
        keep = np.concatenate(keep)
        self.model_ = DictionaryModel(
            classes=self.classes_, channels=list(channels), rate=float(recordings[0].rate), window=self.window,
            step=self.step, normalisation="unit", scale=scaling.scale, dictionary=matrix[:, keep],
            column_class=np.searchsorted(self.classes_, names[keep]),
            features=recordings[0].meta.get("features", "channels"),
            orientation=recordings[0].meta.get("orientation", "default"),
            parameters={"learner": "paper recipe", "seed": self.seed},
            summary={"learner": "paper recipe",
                     "columns_per_class": {c: int(np.sum(names[keep] == c)) for c in self.classes_}})
        self.classifier_ = dictionary_classifier(self.model_, "crc")
        return self

    def predict(self, recording: Recording, centred: bool = True) -> np.ndarray:
        """One class name per sample of ``recording`` (``""`` where no window labels it)."""
        return classify_recording(self.model_, recording, method="crc", centred=centred,
                                  classifier=self.classifier_).label.astype(str)

    def _split(self, matrix: np.ndarray, order: list[str]) -> np.ndarray:
        """Per window, the class the recipe names it, ``""`` for a dropped half."""
        per = np.full(matrix.shape[1], order[0], dtype=object)
        if len(order) == 1 or matrix.shape[1] < 2:
            return per.astype(str)
        labels = self._two_way(matrix)
        larger = int(np.bincount(labels, minlength=2).argmax())
        smaller = np.flatnonzero(labels != larger)
        per[smaller] = order[-1]
        if len(order) > 2 and len(smaller) >= 2:
            halves = self._two_way(matrix[:, smaller])
            per[smaller[halves != int(np.bincount(halves, minlength=2).argmax())]] = ""
        return per.astype(str)

    def _two_way(self, matrix: np.ndarray) -> np.ndarray:
        return OrderedSubspaceClustering(n_clusters=2, random_state=self.seed).fit(matrix.T).labels_
