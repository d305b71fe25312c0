"""ClaSP unsupervised segmentation (Schäfer, Ermshaus, Leser, CIKM 2021), its segments then named.

**Segmentation (no labels).** For a univariate series, ClaSP slides a window of ``m`` samples, finds each
window's ``k = 3`` nearest neighbours (z-normalised Euclidean distance), and scores every candidate split ``s``
by how well "left of ``s``" versus "right of ``s``" is predicted from the neighbours' sides (ROC AUC of the
cross-validated k-NN labels; 0.5 means no change), excluding ``max(m, exclusion_radius * n)`` samples at
either end. Binary segmentation: the best-scoring split of all pieces is taken first and its two halves are
profiled in turn, until the best split left scores below ``min_score`` or no piece holds :data:`MIN_PIECE` windows.
aeon's ``ClaSPTransformer`` computes the profile (univariate; aeon's ``ClaSPSegmenter`` wraps the same profile in
a recursion that needs the number of change points and fails on short pieces, hence the loop here). Each channel
is segmented on its own and the change points are pooled, best score first, each kept at least ``m`` samples from
those already kept. ``m`` is the peer's ``window``. Each gap-free stretch of a test recording is segmented alone.

**Naming (the supervision used).** A segmentation has no class names; two namings are offered:

* ``naming="centroid"`` (default, deployable): the segment takes the class ``argmin_i ||mean(segment) - mu_i||_2``
  whose centroid ``mu_i`` (mean of the channel-scaled training samples of class ``i``, from the training
  recordings' ground truth) is nearest to the segment's mean scaled sample. The mean of a segment's windows is
  its mean sample repeated ``L`` times (up to the segment's edges), so this is the nearest training-window
  centroid. Supervision: the class means of the training recordings, no test labels.
* ``naming="truth"`` (upper bound): the segment takes the majority ground-truth label of its own samples in the
  test recording. No naming of these segments can score higher, so its accuracy measures the segmentation alone;
  it reads the test labels and is not a method a rider could run.

Every sample of a stretch at least one window long is labelled; shorter stretches get ``""``.
"""

from __future__ import annotations

import numpy as np

from spotfree.errors import InputError
from spotfree.io.recording import Recording
from spotfree.evaluation.peers.base import DEFAULT_CHANNELS, Peer, from_aeon

NAMINGS = ("centroid", "truth")
MIN_PIECE = 5
"""A piece of a stretch is split further only when it holds at least this many windows (ClaSP's k-NN and its
exclusion zones need room on both sides of a split)."""


class ClaspPeer(Peer):
    """ClaSP segmentation with segments named by training centroids or, as an upper bound, by the test truth.

    Parameters
    ----------
    channels, window
        As for every peer (:class:`~spotfree.evaluation.peers.base.Peer`); ``window`` is ClaSP's subsequence length
        ``m``.
    naming : {"centroid", "truth"}
        How segments get a class (module docstring).
    min_score : float
        Lowest ClaSP score (ROC AUC, 0.5 = no change) of a change point that is kept.
    exclusion_radius : float
        Fraction of a piece's length at either end where no split is sought (at least ``window`` samples;
        ClaSP's default 0.05).
    n_jobs : int
        Threads for ClaSP's nearest-neighbour search.

    Attributes
    ----------
    classes_ : ndarray of str
        Classes of the training truth.
    centroids_ : ndarray (n_classes, n_channels)
        Mean channel-scaled training sample of each class (dimensionless).
    change_points_ : list of int
        Sample indices where the last ``predict`` started a new segment.
    """

    def __init__(self, channels=DEFAULT_CHANNELS, window: int = 20, naming: str = "centroid",
                 min_score: float = 0.7, exclusion_radius: float = 0.05, n_jobs: int = 1):
        super().__init__(channels=channels, window=window)
        self.naming = naming
        self.min_score = min_score
        self.exclusion_radius = exclusion_radius
        self.n_jobs = n_jobs

    def _check_params(self) -> None:
        super()._check_params()
        if self.naming not in NAMINGS:
            raise InputError(f"naming {self.naming!r} is unknown: use one of {', '.join(NAMINGS)}")
        if not 0 < self.exclusion_radius < 0.5:
            raise InputError(f"exclusion_radius must lie in (0, 0.5), got {self.exclusion_radius}")

    def _fit(self, recordings: list[Recording]) -> None:
        x = np.vstack([self.scaling_.transform(r.array(self.channels)) for r in recordings])
        y = np.concatenate([np.asarray(r.truth["label"], dtype=str) for r in recordings])
        keep = np.all(np.isfinite(x), axis=1) & (y != "")
        self.classes_ = np.unique(y[keep])
        if len(self.classes_) < 2:
            raise InputError(
                f"training labels hold {len(self.classes_)} class(es); a peer needs recordings with at least two"
            )
        self.centroids_ = np.stack([x[keep & (y == c)].mean(axis=0) for c in self.classes_])  # (k, c)

    def _predict(self, recording: Recording) -> np.ndarray:
        if self.naming == "truth" and "label" not in recording.truth:
            raise InputError(
                f"{recording.source}: no 'label' column; naming='truth' names segments by the test ground truth, "
                "use naming='centroid' for a recording without it"
            )
        stretches = [(a, b) for a, b in recording.segments() if b - a >= self.window]
        if not stretches:
            raise InputError(
                f"{recording.source}: no gap-free stretch is as long as one window ({self.window} samples = "
                f"{self.window / recording.rate:.2f} s); use a shorter window or a longer recording"
            )
        x = self.scaling_.transform(recording.array(self.channels))
        truth = np.asarray(recording.truth.get("label", np.full(len(recording), "")), dtype=str)
        labels = np.full(len(recording), "", dtype=object)
        self.change_points_ = []
        for a, b in stretches:
            cuts = [0, *self.segment(x[a:b]), b - a]
            self.change_points_.extend(a + c for c in cuts[1:-1])
            for lo, hi in zip(cuts[:-1], cuts[1:]):
                labels[a + lo:a + hi] = self._name(x[a + lo:a + hi], truth[a + lo:a + hi])
        return labels.astype(str)

    def segment(self, x: np.ndarray) -> list[int]:
        """Sorted change points (sample indices) of one gap-free stretch ``x`` ``(n, c)``, pooled over channels."""
        candidates = [cp for column in x.T for cp in self._binary_segmentation(column)]
        kept: list[int] = []
        for _, cp in sorted(candidates, reverse=True):
            if all(abs(cp - k) >= self.window for k in kept):
                kept.append(cp)
        return sorted(kept)

    def _binary_segmentation(self, series: np.ndarray) -> list[tuple[float, int]]:
        """``(score, change point)`` of one channel: the best-scoring split first, while scores reach
        ``min_score``."""
        found: list[tuple[float, int]] = []
        queue = [self._best_split(series, 0, len(series))]
        while queue:
            score, cp, lo, hi = queue.pop(int(np.argmax([q[0] for q in queue])))
            if not score >= self.min_score:
                break  # every split left in the queue scores lower
            found.append((score, cp))
            queue += [self._best_split(series, a, b) for a, b in ((lo, cp), (cp, hi))]
        return found

    def _best_split(self, series: np.ndarray, lo: int, hi: int) -> tuple[float, int, int, int]:
        """``(score, change point, lo, hi)`` of the ClaSP profile maximum of ``series[lo:hi]``; score ``-inf``
        when the piece is shorter than :data:`MIN_PIECE` windows."""
        if hi - lo < MIN_PIECE * self.window:
            return -np.inf, lo, lo, hi
        ClaSPTransformer = from_aeon("aeon.transformations.series", "ClaSPTransformer")
        clasp = ClaSPTransformer(window_length=int(self.window), exclusion_radius=self.exclusion_radius,
                                 n_jobs=self.n_jobs)
        profile = clasp.fit_transform(series[lo:hi])
        edge = max(int(self.window), int(len(profile) * self.exclusion_radius))  # aeon fills the ends by copying
        best = edge + int(np.argmax(profile[edge:len(profile) - edge]))
        return float(profile[best]), lo + best, lo, hi

    def _name(self, x: np.ndarray, truth: np.ndarray) -> str:
        if self.naming == "truth":
            values, counts = np.unique(truth[truth != ""], return_counts=True)
            return str(values[np.argmax(counts)]) if len(values) else ""
        distances = np.linalg.norm(self.centroids_ - x.mean(axis=0), axis=1)
        return str(self.classes_[np.argmin(distances)])
