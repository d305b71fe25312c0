"""Nearest-neighbour baseline: each test window takes the ground-truth label of the closest training window.

Windows are the channel-scaled block-Hankel columns ``y in R^{cL}`` (:mod:`spotfree.windows`); the distance is
Euclidean, ``label(y) = label(argmin_j ||y - y_j||_2)`` over all training windows ``y_j``.
"""

from __future__ import annotations

import numpy as np
from sklearn.neighbors import KNeighborsClassifier

from spotfree.classify.smoothing import VOTE_SECONDS
from spotfree.evaluation.peers.base import DEFAULT_CHANNELS, WindowClassifierPeer


class NearestNeighbourPeer(WindowClassifierPeer):
    """Supervised k-nearest-neighbour window classifier (1-NN by default).

    Parameters
    ----------
    channels, window, alignment, train_step, vote
        As for every window classifier (:class:`spotfree.evaluation.peers.base.WindowClassifierPeer`).
    n_neighbors : int
        Neighbours that vote (1: the nearest window decides).
    """

    def __init__(self, channels=DEFAULT_CHANNELS, window: int = 20, alignment: str = "causal", n_neighbors: int = 1,
                 train_step: int = 1, vote: float = VOTE_SECONDS):
        super().__init__(channels=channels, window=window, alignment=alignment, train_step=train_step, vote=vote)
        self.n_neighbors = n_neighbors

    def _make_estimator(self):
        return KNeighborsClassifier(n_neighbors=self.n_neighbors)

    def _features(self, windows: np.ndarray) -> np.ndarray:
        return windows.reshape(len(windows), -1)
