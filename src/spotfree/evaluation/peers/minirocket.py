"""MiniRocket (Dempster, Schmidt, Webb, KDD 2021) trained on ground-truth-labelled windows.

Each multivariate window ``(c, L)`` becomes ``n_kernels`` features: the proportion of positive values (PPV) of
its convolution with fixed length-9 kernels of weights {-1, 2} at several dilations, with biases drawn from the
training windows' convolution quantiles; a ridge classifier with the ridge weight chosen by leave-one-out
cross-validation over ``10^-3 .. 10^3`` classifies the features divided by their standard deviations. aeon's
``MiniRocketClassifier`` does both. Unlike the paper's method, it needs every training window's label, i.e. the
pattern boundaries marked by hand.
"""

from __future__ import annotations

from spotfree.classify.smoothing import VOTE_SECONDS
from spotfree.errors import InputError
from spotfree.evaluation.peers.base import DEFAULT_CHANNELS, WindowClassifierPeer, from_aeon

MIN_WINDOW = 9
"""MiniRocket's kernels are 9 samples long: shorter windows have no valid convolution."""


class MiniRocketPeer(WindowClassifierPeer):
    """Supervised MiniRocket + ridge on sliding windows (see the module docstring).

    Parameters
    ----------
    channels, window, alignment, train_step, vote
        As for every window classifier (:class:`spotfree.evaluation.peers.base.WindowClassifierPeer`); ``window`` must be at least 9 samples.
    n_kernels : int
        Number of MiniRocket features (rounded down to a multiple of 84 by aeon; 10,000 is the published default).
    n_jobs : int
        Threads for the transform.
    random_state : int
        Seed of the bias sampling.
    """

    def __init__(self, channels=DEFAULT_CHANNELS, window: int = 20, alignment: str = "causal",
                 n_kernels: int = 10_000, n_jobs: int = 1, random_state: int = 0, train_step: int = 1,
                 vote: float = VOTE_SECONDS):
        super().__init__(channels=channels, window=window, alignment=alignment, train_step=train_step, vote=vote)
        self.n_kernels = n_kernels
        self.n_jobs = n_jobs
        self.random_state = random_state

    def _check_params(self) -> None:
        super()._check_params()
        if self.window < MIN_WINDOW:
            raise InputError(f"MiniRocket needs windows of at least {MIN_WINDOW} samples, got window={self.window}")

    def _make_estimator(self):
        MiniRocketClassifier = from_aeon("aeon.classification.convolution_based", "MiniRocketClassifier")
        return MiniRocketClassifier(n_kernels=self.n_kernels, n_jobs=self.n_jobs, random_state=self.random_state)
