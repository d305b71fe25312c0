"""Spotting-free learning from class sets: a dictionary of pure class representatives from whole recordings that
only declare which classes occur somewhere in them.

Method (``docs/training.md`` has the derivation and the references):

1. **Windows.** Every recording is cut into sliding windows of ``window`` samples every ``step`` samples (none
   spans a gap), each channel divided by its training scale, and represented (:mod:`spotfree.representation`,
   default ``summary``: level, spread, their change across the window and band powers per channel); a ``summary``
   is standardised over all training windows, a ``hankel`` window kept as the channel scales leave it (so that the
   streaming classifiers run it in compiled code, as they run the paper's).
2. **Partial labels.** A recording ``r`` is a bag of windows whose classes lie in its declared set ``S_r``: each
   window is a partial-label example (Cour, Sapp and Taskar, JMLR 2011), its candidates ``S_r``. Every window starts
   with soft names ``w(c) = 1 / |S_r|`` over its candidates (times the prior, when there is one).
   **Absence evidence.** A class's windows occur only in the recordings that declare it. Per class ``c`` declared by
   some recordings and not by others, a forest tells the windows of the two apart, cross-fitted over two halves of
   the recordings (a window is scored by a forest that never saw its recording), or, when a single recording
   declares ``c`` or a single one does not (no two halves each hold both kinds), over the rounds' alternating time
   blocks (a window is scored by a forest that saw other stretches of its recording, never the window itself); its
   probability ``s(x)`` that a window like ``x`` comes from a recording declaring ``c`` gives the ratio of the
   densities of such windows in the recordings without ``c`` and in those with it (Sugiyama, Suzuki and Kanamori,
   "Density Ratio Estimation in Machine Learning", 2012):

       r_c(x) = f_without(x) / f_with(x) = (1 - s(x)) / s(x) * b / (1 - b)      (b: the share of windows declaring c)

   ``r_c`` is near 0 for a window of ``c`` and near 1 or above for one of a class that occurs without ``c`` as often
   as with it: a window that is more frequent around an event than elsewhere, but does occur elsewhere, is not the
   event. ``exp(-absence r_c(x))`` multiplies the names as a prior does (parameter ``absence``).
3. **Rounds.** For ``rounds`` rounds, a classifier (extremely randomised trees) is fitted on the windows with their
   soft names as sample weights, each class's weights summing alike, cross-fitted so that no window is scored by a
   model that saw it (two folds of alternating ``block_seconds`` blocks). Its balanced posterior ``p(c | x)``
   gives the new names, restricted to the candidates, sharpened and weighed by a power of each class's share of the
   names:

       w(c) ∝ p(c | x)^t pr(c)^t pi(c)^a     for c in S_r, 0 elsewhere   (t = sharpen, a = share_power)

   (``pr``: the prior times the absence evidence; ``pi(c)``: the mean of the names ``w(c)`` over all windows). This
   is the progressive identification of true labels of Lv et al. (ICML 2020), with a forest for the network. A
   motion that occurs in bags of two classes goes to the one declared wherever that motion occurs: a window of
   walking in bags declaring walking and turning, and in bags declaring walking but not turning, weighs more on
   walking than on turning; the sharpening makes the soft names harden over the rounds. Weighing each class alike
   in the fit keeps a class declared in few recordings from being absorbed by one declared in many; but names from
   the balanced posterior alone pull every class towards an equal share of the windows, and names weighed by the shares
   themselves let a common class absorb, round after round, the windows of a rarer one declared with it. The default
   ``share_power`` 1/2 lies between, as square-root class sampling does in long-tailed learning (Kang et al.,
   ICLR 2020). The rounds stop early when the names move by less than ``changed`` (mean total variation).
   Then the windows of each recording are decoded into runs (:func:`decode_runs`): the class sequence inside
   ``S_r`` that maximises ``sum_i log w_i(z_i)`` minus ``smoothing * rate / step`` per change of class, in which every
   declared class occurs (a class lasts longer than one window; every declared class finds its windows).
4. **Dictionary.** Per class, the share ``column_share`` of its windows with the largest posterior margins (by
   default those at or above the class's median), at most ``max_columns`` of them spread evenly over time, become
   the dictionary's columns: windows that straddle a change stay eligible, so that the dictionary also holds a
   class's onsets and ends, which the test windows show as often. The causal columns are chosen alike among the
   windows named by the class at their last sample. Classification is kernel CRC_RLS on the dictionary
   (:class:`~spotfree.classify.kcrc.KernelCRCClassifier`).

**Settings.** The window, the share power, the column share and the smoothing (:data:`SELECTED`) are chosen from the
recordings and their sets when given as ``"auto"``, before the steps above run (:mod:`spotfree.selection`: held-out
recordings scored by the windows named outside their sets and the declared classes named nowhere); a value given
is kept.

Domain knowledge enters only through ``prior``: an object whose ``log_prior(recording, centres, classes)`` returns an
``(m, C)`` array, ``log pr``, for the windows centred at sample indices ``centres``, multiplied into the names at the
start and in every round; the generic learner knows nothing of any domain.

The learner's cost is linear in the number of windows: the forests are fitted on at most ``fit_windows`` windows
per class, and every other step is a pass over the windows.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
from scipy.ndimage import correlate1d
from sklearn.base import BaseEstimator
from sklearn.ensemble import ExtraTreesClassifier

from spotfree.classify.batch import classify_recording, dictionary_classifier
from spotfree.errors import InputError
from spotfree.io.recording import GPS_CHANNELS, Recording
from spotfree.model import DictionaryModel
from spotfree.representation import REPRESENTATIONS, represent
from spotfree.selection import AUTO, select_settings
from spotfree.windows import ChannelScaling, recording_windows

SEPARABLE = 0.5
"""Ratio, from which the summary warns, of a class's mean cross-fitted posterior on the windows of recordings without
it that it is given most (as large a part of them as it names of its own recordings' windows) to that on the windows
it names."""
AFFINE = 6.0
"""Constant row appended to a ``hankel`` window and to every column when classifying (``parameters["affine"]``): a
window is then represented by an affine combination of columns, which CRC_RLS needs once a class holds as many columns
as a window has values (every class then spans every window); the kernel's distances do not change."""
ABSENCE_CAP = 10.0
"""Largest density ratio ``r_c(x)`` used: beyond it a window is as good as absent from ``c``."""
SELECTED = ("window", "share_power", "column_share", "smoothing")
"""Parameters that :mod:`spotfree.selection` chooses from the class sets when given as ``"auto"``."""


@dataclass
class _Windows:
    """The training windows of all recordings: represented rows ``X`` ``(n, p)``, the recording of each row, its
    window's last sample in that recording, every run of contiguous windows and where each recording's rows start."""

    X: np.ndarray
    recording: np.ndarray
    ends: list[np.ndarray]
    runs: list[tuple[int, int]]
    offsets: np.ndarray

    def rows(self, r: int) -> slice:
        """The rows of recording ``r`` (the recordings' windows are stacked in order)."""
        return slice(int(self.offsets[r]), int(self.offsets[r + 1]))



@dataclass
class _Named:
    """What :meth:`SetSupervisedLearner._name` leaves for :meth:`SetSupervisedLearner._build`: the represented
    windows ``X`` and their final log names ``log_q`` (and the last round's posterior ``log_p``; None without
    rounds), with what the dictionary is built from."""

    X: np.ndarray
    log_q: np.ndarray
    log_p: np.ndarray | None
    data: _Windows
    allowed: np.ndarray
    channels: tuple[str, ...]
    scaling: ChannelScaling
    offset: np.ndarray
    scale: np.ndarray
    sets: list[set[str]]
    recordings: list[Recording]
    warnings: list[str]


class SetSupervisedLearner(BaseEstimator):
    """Learn a dictionary model from recordings that each declare only the set of classes occurring in them.

    The four settings of :data:`SELECTED` given as ``"auto"`` are chosen by :func:`spotfree.selection.select_settings`
    from the recordings and their sets alone (held-out recordings scored by the set risk); a value is kept as it is.

    Parameters
    ----------
    channels : tuple of str or None
        Channels windowed, in order; None: every channel of the first recording but the sparse GPS ones.
    window : int or "auto"
        Window length ``L``, samples; ``"auto"``: chosen (1 or 2 s).
    step : int
        Stride of the windows, samples (training and classification).
    representation : {"summary", "hankel"}
        What the dictionary holds of a window (:mod:`spotfree.representation`).
    rounds : int
        Most rounds of step 3; 0 decodes the starting names (uniform over each set, times the prior and the absence
        evidence of step 2).
    smoothing : float or "auto"
        Seconds of windows whose log-posterior a change of class must gain to be made (the switching cost of
        :func:`decode_runs`); the dictionary's margins are averaged over as many windows, and the offline labels are
        voted over as many seconds. ``"auto"``: chosen.
    max_columns : int
        Most dictionary columns per class.
    column_share : float or "auto"
        Share ``0 < s <= 1`` of each class's windows, those named with the largest margins, that its columns are
        drawn from (step 4): 0.5, the half above the class's median margin, keeps out most misnamed windows where the
        sets leave the names uncertain; 1 draws from every window of the class, its onsets and ends included, which
        pays where the sets pin the names down (each recording declares one class beside a background that other
        recordings declare alone); a short event that claims more than itself keeps only its surest windows at 0.25.
        ``"auto"``: chosen.
    share_power : float or "auto"
        Exponent ``a >= 0`` of each class's share of the names in the next round's names (module docstring, step
        3): 0 names from the balanced posterior alone, under which every class tends to an equal share of the
        windows and a short event declared in few recordings claims more than itself; 1 weighs the names by the
        shares, under which a common class grows at the expense of a rarer one declared with it. ``"auto"``:
        chosen.
    prior : object or None
        Domain prior with ``log_prior(recording, centres, classes) -> (m, C)`` (module docstring); None: none.
    seed : int
        Seed of the forests and of their samples; the same data and seed give the same model.
    sharpen : float
        Exponent ``t >= 1`` of the posterior in each round's names: above 1 the soft names harden over the rounds.
    absence : float
        Weight ``gamma >= 0`` of the absence evidence (module docstring, step 2): the names are multiplied by
        ``exp(-gamma r_c(x))``, so that a window as frequent in recordings without ``c`` as in those with it keeps
        about ``e^-gamma`` of its name ``c`` before the sharpening.
    changed : float
        Mean total variation of the soft names between two rounds below which the rounds stop.
    fit_windows : int
        Most windows per class the forests are fitted on (times the classes: the same windows every round, drawn at
        random among all), which keeps the cost linear in the data.
    block_seconds : float
        Length, s, of the time blocks that alternate between the two cross-fitting folds: short, so that a class that
        occurs in a few short runs still has windows in both folds (a forest that saw none of a class's windows cannot
        find them).
    trees : int
        Extremely randomised trees per forest (absence evidence and rounds).
    leaf : int
        Fewest windows in a leaf of those trees: a posterior averages several windows, so that a few wrong names
        among the training windows do not decide a leaf.
    landmarks : int
        Nystroem landmarks of the kernel CRC_RLS that labels with the dictionary
        (:class:`~spotfree.classify.kcrc.KernelCRCClassifier`; a window costs about ``m d + 2 C m^2`` operations).

    Attributes
    ----------
    classes_ : list of str
        Declared classes, sorted.
    rate_ : float
        Sampling rate of the recordings, Hz.
    settings_ : dict
        The value of each parameter of :data:`SELECTED` the model was fitted with, given or chosen.
    selection_ : list of dict
        One row per setting of :data:`SELECTED`: ``{"setting", "value", "given", "candidates": {value: risk}}``
        (:func:`spotfree.selection.select_settings`; no candidates for a given setting).
    model_ : DictionaryModel
        The dictionary (``model_.summary`` holds the training summary, the settings and the selection).
    window_labels_ : list of ndarray of str
        Final name of every training window, per recording.
    window_ends_ : list of ndarray of int
        Last sample of every training window, per recording.
    classifier_, causal_classifier_ : KernelCRCClassifier
        Fitted on the dictionary's columns and on its causal columns (offline and live labels).
    history_ : list of float
        Mean total variation of the soft names between rounds, per round.
    warnings_ : list of str
    """

    def __init__(self, channels: tuple[str, ...] | None = None, window: int | str = 20, step: int = 1,
                 representation: str = "summary", rounds: int = 5, smoothing: float | str = 0.5,
                 max_columns: int = 300, column_share: float | str = 0.5, share_power: float | str = 0.5,
                 prior=None, seed: int = 0, sharpen: float = 2.0, absence: float = 3.0, changed: float = 0.002,
                 fit_windows: int = 2000, block_seconds: float = 2.0, trees: int = 100, leaf: int = 8,
                 landmarks: int = 128):
        self.channels = channels
        self.window = window
        self.step = step
        self.representation = representation
        self.rounds = rounds
        self.smoothing = smoothing
        self.max_columns = max_columns
        self.column_share = column_share
        self.share_power = share_power
        self.prior = prior
        self.seed = seed
        self.sharpen = sharpen
        self.absence = absence
        self.changed = changed
        self.fit_windows = fit_windows
        self.block_seconds = block_seconds
        self.trees = trees
        self.leaf = leaf
        self.landmarks = landmarks

    # ------------------------------------------------------------------ fit
    def fit(self, recordings: Recording | list[Recording], class_sets):
        """Learn from ``recordings`` (a feature Recording or a list of them, of one rate) and the set of classes each
        declares (one set for one recording, a list of sets for a list); the settings given as ``"auto"`` are chosen
        first
        (:func:`spotfree.selection.select_settings`)."""
        recordings, sets = self._check_input(recordings, class_sets)
        self.settings_, self.selection_ = select_settings(self, recordings, sets)
        self._name(recordings, sets)
        self._build()
        del self._named  # the training windows: not needed to label
        return self

    def _name(self, recordings: list[Recording], sets: list[set[str]]) -> None:
        """Steps 1-3 up to the names: windows, absence evidence and rounds, with :attr:`settings_`; keeps what
        :meth:`_build` needs."""
        window, share_power = self.settings_["window"], self.settings_["share_power"]
        channels = (tuple(self.channels) if self.channels else
                    tuple(c for c in recordings[0].names if c not in GPS_CHANNELS))
        self.classes_ = sorted(set().union(*sets))
        self.rate_ = float(recordings[0].rate)
        n_classes = len(self.classes_)
        allowed = np.zeros((len(recordings), n_classes), dtype=bool)
        for r, s in enumerate(sets):
            allowed[r, [self.classes_.index(c) for c in s]] = True
        self.warnings_: list[str] = []
        self._warn_alike_names()

        scaling = ChannelScaling(channels).fit(recordings)
        data = self._windows(recordings, channels, scaling, window)
        offset, scale = data.X.mean(axis=0), data.X.std(axis=0)
        scale = np.where(scale > 1e-12 * max(scale.max(), 1.0), scale, 1.0)
        if self.representation == "hankel":  # the paper's windows, as the streaming classifiers take them
            offset, scale = np.zeros_like(offset), np.ones_like(scale)
        X = (data.X - offset) / scale
        rng = np.random.default_rng(self.seed)
        mask = allowed[data.recording]
        prior = self._log_prior(recordings, data, window) - self.absence * self._absence(X, data, allowed, rng)

        fitted = np.arange(len(X))
        if len(X) > self.fit_windows * n_classes:  # the same windows in every round, so that the rounds can settle
            fitted = np.sort(rng.choice(len(X), self.fit_windows * n_classes, replace=False))
        log_q = _single(np.where(mask, prior, -np.inf))
        weights = _normalised(log_q)
        log_p = None
        self.history_ = []
        for _ in range(self.rounds):
            log_p = self._cross_fitted(X, weights, data, fitted)
            share = np.maximum(weights.mean(axis=0), 1.0 / len(weights))
            log_q = _single(np.where(mask, self.sharpen * (log_p + prior) + share_power * np.log(share), -np.inf))
            new = _normalised(log_q)
            changed = 0.5 * float(np.abs(new - weights).sum(axis=1).mean())
            weights = new
            self.history_.append(changed)
            if changed < self.changed:
                break
        self._named = _Named(X=X, log_q=log_q, log_p=log_p, data=data, allowed=allowed, channels=channels,
                             scaling=scaling, offset=offset, scale=scale, sets=sets, recordings=recordings,
                             warnings=list(self.warnings_))

    def _build(self) -> None:
        """Step 3's decoding and step 4 on the names of :meth:`_name`, with :attr:`settings_`'s smoothing and column
        share: the fitted model and classifiers."""
        named = self._named
        self.warnings_ = list(named.warnings)
        labels = self._decide(named.log_q, named.data, named.allowed)  # log weights up to a constant per window
        if self.prior is None:
            self._warn_declared_together(named.allowed)
        if named.log_p is not None:
            self._warn_inseparable(named.log_p, labels, named.allowed[named.data.recording])
        margin = _margins(self._smoothed(named.log_q, named.data), labels)
        self.model_ = self._dictionary(named.X, labels, margin, named)
        names = np.asarray(self.classes_, dtype=object)
        self.window_labels_ = [names[labels[named.data.rows(r)]].astype(str) for r in range(len(named.recordings))]
        self.window_ends_ = named.data.ends
        self.classifier_ = dictionary_classifier(self.model_)
        self.causal_classifier_ = dictionary_classifier(self.model_, causal=True)

    def predict(self, recording: Recording | list[Recording], centred: bool = True,
                smoothing: int | None = None) -> np.ndarray | list[np.ndarray]:
        """One class name per sample of ``recording`` (``""`` where no window labels it), or a list of such arrays
        for a list of recordings; ``centred``: each window labels its centre (offline), else its last sample (live);
        ``smoothing``: majority vote over that many samples (0: none; None: the alignment's default,
        :func:`~spotfree.classify.smoothing.alignment_smoothing`)."""
        if not hasattr(self, "model_"):
            raise InputError("the learner is not fitted; call fit(recordings, class_sets) first")
        if not isinstance(recording, Recording):
            return [self.predict(r, centred, smoothing) for r in recording]
        classifier = self.classifier_ if centred else self.causal_classifier_
        return classify_recording(self.model_, recording, centred=centred, smoothing=smoothing,
                                  classifier=classifier).label.astype(str)

    # ------------------------------------------------------------------ steps
    def _check_input(self, recordings, class_sets) -> tuple[list[Recording], list[set[str]]]:
        if self.representation not in REPRESENTATIONS:
            raise InputError(f"representation {self.representation!r} is unknown; use one of "
                             f"{', '.join(REPRESENTATIONS)}")
        for name in ("step", "max_columns", "fit_windows", "trees", "leaf", "landmarks") + (
                ("window",) if self.window != AUTO else ()):
            _check_number(self, name, whole=True, low=1)
        _check_number(self, "rounds", whole=True, low=0)
        for name, low in (("sharpen", 1), ("absence", 0), ("changed", 0)):
            _check_number(self, name, low=low)
        _check_number(self, "block_seconds", low=0, open_low=True)
        if self.smoothing != AUTO:
            _check_number(self, "smoothing", low=0)
        if self.share_power != AUTO:
            _check_number(self, "share_power", low=0)
        if self.column_share != AUTO:
            _check_number(self, "column_share", low=0, open_low=True, high=1, what="a share")
        if isinstance(recordings, Recording):
            recordings, class_sets = [recordings], [class_sets]
        recordings = list(recordings)
        sets = [set(s) for s in class_sets]
        if not recordings:
            raise InputError("no training recording: give at least one recording and the classes that occur in it")
        if len(sets) != len(recordings):
            raise InputError(f"{len(recordings)} recordings but {len(sets)} class sets: give one set per recording")
        for rec, s in zip(recordings, sets):
            if not s or not all(isinstance(c, str) and c.strip() for c in s):
                raise InputError(f"{rec.source}: declare at least one class name for it")
        rates = {float(r.rate) for r in recordings}
        if len(rates) > 1:
            raise InputError(f"the recordings have different rates ({', '.join(f'{r:g}' for r in sorted(rates))} Hz); "
                             "read them at one rate")
        return recordings, sets

    def _windows(self, recordings: list[Recording], channels: tuple[str, ...], scaling: ChannelScaling,
                 window: int) -> _Windows:
        rows, owner, ends, runs, start = [], [], [], [], 0
        for r, rec in enumerate(recordings):
            w = recording_windows(rec, channels, window, self.step, scaling)
            rows.append(represent(w.matrix, len(channels), self.representation))
            owner.append(np.full(len(w.ends), r))
            ends.append(w.ends)
            breaks = np.flatnonzero(np.diff(w.ends) != self.step) + 1
            for a, b in zip(np.r_[0, breaks], np.r_[breaks, len(w.ends)]):
                runs.append((start + int(a), start + int(b)))
            start += len(w.ends)
        X = np.vstack(rows)
        if not np.all(np.isfinite(X)):
            raise InputError("a training window is not finite; check the recordings for NaN or infinite values")
        return _Windows(X=X, recording=np.concatenate(owner), ends=ends, runs=runs,
                        offsets=np.r_[0, np.cumsum([len(e) for e in ends])])

    def _log_prior(self, recordings: list[Recording], data: _Windows, window: int) -> np.ndarray:
        n = len(data.X)
        if self.prior is None:
            return np.zeros((n, len(self.classes_)))
        parts = [np.asarray(self.prior.log_prior(rec, ends - window // 2, self.classes_), dtype=float)
                 for rec, ends in zip(recordings, data.ends)]
        prior = np.vstack(parts)
        if prior.shape != (n, len(self.classes_)) or np.isnan(prior).any():
            raise InputError(f"the prior {type(self.prior).__name__} must give one finite row per window and class")
        return prior

    def _absence(self, X: np.ndarray, data: _Windows, allowed: np.ndarray,
                 rng: np.random.Generator) -> np.ndarray:
        """``r_c(x)`` ``(n, C)`` of every window and class (module docstring, step 2), at most :data:`ABSENCE_CAP`;
        0 for a class every recording declares, and in a half whose other half holds no window with or none without
        the class (nothing to tell apart). Per class, the recordings that declare it and those that do not are each
        dealt alternately, in a random order, to the two halves; when either kind is a single recording, the halves
        are the cross-fitting folds of the rounds (:meth:`_folds`) instead, since one recording cannot be on both
        sides and its windows would otherwise go without the evidence."""
        n_recordings, n_classes = allowed.shape
        ratio = np.zeros((len(X), n_classes))
        blocks = self._folds(data)
        for c in np.flatnonzero(~allowed.all(axis=0)):
            order = rng.permutation(n_recordings)
            halves = np.empty(n_recordings, dtype=int)
            for kind in (True, False):
                same = order[allowed[order, c] == kind]
                halves[same] = np.arange(len(same)) % 2
            declares = allowed[data.recording, c]
            by_recording = min(allowed[:, c].sum(), (~allowed[:, c]).sum()) >= 2
            half = halves[data.recording] if by_recording else blocks
            for h in (0, 1):
                train = np.flatnonzero(half != h)
                if declares[train].all() or not declares[train].any() or not (half == h).any():
                    continue
                if len(train) > self.fit_windows * n_classes:
                    train = np.sort(rng.choice(train, self.fit_windows * n_classes, replace=False))
                model = self._forest(X[train], declares[train])
                # s is kept from 0 only so that the odds are finite; the cap bounds the ratio
                s = np.maximum(model.predict_proba(X[half == h])[:, 1], 1.0 / ABSENCE_CAP ** 2)
                b = declares[train].mean()
                ratio[half == h, c] = np.minimum((1.0 - s) / s * b / (1.0 - b), ABSENCE_CAP)
        return ratio

    def _smoothed(self, log_q: np.ndarray, data: _Windows) -> np.ndarray:
        """``log_q`` averaged over ``span`` windows (``smoothing`` in windows, rounded) centred on each window,
        within each run of contiguous windows (edges repeated). An even span ``2h`` weighs the windows ``h`` before
        and after by one half, ``[1/2, 1, ..., 1, 1/2] / 2h`` (the centred moving average of time-series
        decomposition), so that the average is not shifted by half a window towards the past: a shift moves the
        margins of a class's onsets and ends, which the dictionary keeps or drops by them."""
        span = int(round(self._span))
        if span < 2:
            return log_q
        if span % 2:
            weights = np.ones(span)
        else:
            weights = np.r_[0.5, np.ones(span - 1), 0.5]
        finite = np.where(np.isfinite(log_q), log_q, 0.0)
        out = np.full_like(log_q, -np.inf)
        for a, b in data.runs:
            out[a:b] = correlate1d(finite[a:b], weights / span, axis=0, mode="nearest")
        return np.where(np.isfinite(log_q), out, -np.inf)

    def _decide(self, log_q: np.ndarray, data: _Windows, allowed: np.ndarray) -> np.ndarray:
        """Each recording's windows decoded into runs: the labels that maximise ``sum log q`` minus a switching
        cost per change of class, every declared class in at least one run (:func:`decode_runs`)."""
        labels = np.empty(len(log_q), dtype=int)
        for r in range(len(allowed)):
            classes = np.flatnonzero(allowed[r])
            rows = data.rows(r)
            labels[rows] = classes[decode_runs(log_q[rows][:, classes], self._span)]
            n = rows.stop - rows.start
            if n * len(classes) * 2 ** len(classes) > EXHAUSTIVE:
                warning = (f"recording {r + 1} declares {len(classes)} classes over {n} windows: too many to make "
                           "each appear; split it into shorter recordings")
                if warning not in self.warnings_:
                    self.warnings_.append(warning)
        return labels

    @property
    def _span(self) -> float:
        """``smoothing`` in windows: the switching cost of :func:`decode_runs` and the length of the margins'
        average."""
        return float(self.settings_["smoothing"] * self.rate_ / self.step)

    def _warn_alike_names(self) -> None:
        """Warn about class names that differ only in case or surrounding spaces (``Walking``, ``walking``): they are
        different classes, which is seldom what was meant."""
        spellings: dict[str, list[str]] = {}
        for name in self.classes_:
            spellings.setdefault(name.strip().casefold(), []).append(name)
        for names in spellings.values():
            if len(names) > 1:
                self.warnings_.append(f"classes {', '.join(repr(n) for n in names)} differ only in case or spaces, so "
                                      "they are different classes; spell each class one way")

    def _warn_declared_together(self, allowed: np.ndarray) -> None:
        """Warn about classes that every recording declares together (the same recordings declare each of them):
        every window then has them all as candidates alike, so the class sets cannot tell them apart and only a
        prior could."""
        groups: dict[bytes, list[str]] = {}
        for c, name in enumerate(self.classes_):
            groups.setdefault(allowed[:, c].tobytes(), []).append(name)
        for names in groups.values():
            if len(names) > 1:
                self.warnings_.append(f"classes {', '.join(names)} are declared by the same recordings, so nothing "
                                      "tells them apart and their names are arbitrary; add recordings that hold some "
                                      "of them without the others")

    def _warn_inseparable(self, log_p: np.ndarray, labels: np.ndarray, mask: np.ndarray) -> None:
        """Warn about a class whose windows are not told apart from what happens without it: a classifier which did
        not see the windows gives it, on average, at least :data:`SEPARABLE` times as much on the windows of
        recordings that do not declare it as on the windows it names, both chosen alike: of the windows without it,
        those it gives the class most, as large a part of them as the class names of its own recordings' windows;
        or it names fewer windows than ``leaf``."""
        p = np.exp(log_p)
        for c, name in enumerate(self.classes_):
            own, elsewhere = labels == c, ~mask[:, c]
            if not own.any() or not elsewhere.any():
                continue
            part = own.sum() / mask[:, c].sum()
            alike = np.sort(p[elsewhere, c])[-max(1, int(round(part * elsewhere.sum()))):]
            if own.sum() < self.leaf:
                reason = f"it names only {int(own.sum())} windows, fewer than a leaf of the trees holds"
            elif alike.mean() >= SEPARABLE * p[own, c].mean():
                reason = (f"its windows get it {p[own, c].mean():.2f} on average, as large a part of the "
                          f"windows of recordings without it {alike.mean():.2f}")
            else:
                continue
            self.warnings_.append(f"class {name} is not told apart from what happens without it ({reason}); check "
                                  "that it happens in the recordings that declare it")

    def _folds(self, data: _Windows) -> np.ndarray:
        """Cross-fitting fold (0 or 1) of every window: alternating ``block_seconds`` blocks of each recording,
        the first block's fold alternating between recordings."""
        block = max(1, int(round(self.block_seconds * self.rate_ / self.step)))
        position = np.arange(len(data.X)) - data.offsets[data.recording]
        return (data.recording + position // block) % 2

    def _forest(self, X: np.ndarray, y: np.ndarray, sample_weight: np.ndarray | None = None) -> ExtraTreesClassifier:
        """The extremely randomised trees of the absence evidence and of the rounds, fitted on ``X``, ``y``; they
        predict on one thread, since the threads of ``predict_proba`` add the trees up in any order (not
        reproducible)."""
        model = ExtraTreesClassifier(n_estimators=self.trees, min_samples_leaf=self.leaf, max_features="sqrt", n_jobs=-1,
                                     random_state=self.seed).fit(X, y, sample_weight=sample_weight)
        model.n_jobs = 1
        return model

    def _cross_fitted(self, X: np.ndarray, weights: np.ndarray, data: _Windows, fitted: np.ndarray) -> np.ndarray:
        """Balanced ``log p(c | x)`` of every window from a forest fitted on the soft names ``weights`` ``(n, C)`` of
        the windows ``fitted`` of the other fold."""
        n_classes = len(self.classes_)
        fold = self._folds(data)
        log_p = np.empty((len(X), n_classes))
        for f in (0, 1):
            held = fold == f
            if not held.any():
                continue
            train = fitted[~held[fitted]] if (~held[fitted]).any() else fitted  # one fold only: no hold-out
            rows, classes, sample_weight = _candidate_rows(weights, train)
            model = self._forest(X[rows], classes, sample_weight)
            proba = np.full((int(held.sum()), n_classes), 1e-3 / n_classes)
            proba[:, model.classes_] += model.predict_proba(X[held])
            log_p[held] = np.log(proba / proba.sum(axis=1, keepdims=True))
        return log_p

    def _dictionary(self, X: np.ndarray, labels: np.ndarray, margin: np.ndarray, named: _Named) -> DictionaryModel:
        """Step 4: the dictionary of the windows named ``labels`` with their smoothed ``margin``."""
        data, recordings, channels, sets = named.data, named.recordings, named.channels, named.sets
        window, share = self.settings_["window"], self.settings_["column_share"]
        half = max(1, window // 2 // self.step)
        names = np.asarray(self.classes_)
        causal = np.full(len(labels), -1)
        causal_margin = np.full(len(labels), -np.inf)
        for a, b in data.runs:
            if b - a > half:
                causal[a:b - half] = labels[a + half:b]
                causal_margin[a:b - half] = margin[a + half:b]
        columns, column_class = _pick(labels, margin, len(names), self.max_columns, share)
        causal_columns, causal_class = _pick(causal, causal_margin, len(names), self.max_columns, share)
        found = np.bincount(column_class, minlength=len(names))
        for c in np.flatnonzero(found == 0):
            self.warnings_.append(f"class {names[c]} names no window; declare it in recordings where it lasts longer "
                                  "than one window")
        counts = {str(names[c]): int(np.sum(labels == c)) for c in range(len(names))}
        per_recording = np.zeros((len(recordings), len(names)), dtype=int)
        np.add.at(per_recording, (data.recording, labels), 1)
        summary = {
            "learner": "set-supervised",
            "windows_per_class": counts,
            "columns_per_class": {str(names[c]): int(found[c]) for c in range(len(names))},
            "rounds_changed": [round(h, 5) for h in self.history_],
            "recordings": [{"source": rec.source, "classes": sorted(s),
                            "windows": {str(names[c]): int(k) for c, k in enumerate(per_recording[r]) if k}}
                           for r, (rec, s) in enumerate(zip(recordings, sets))],
            "warnings": self.warnings_,
            "selection": getattr(self, "selection_", []),
        }
        return DictionaryModel(
            classes=list(self.classes_), channels=list(channels), rate=self.rate_, window=window,
            step=self.step, normalisation="scale", scale=named.scaling.scale, dictionary=X[columns].T,
            column_class=column_class,
            causal_dictionary=X[causal_columns].T if len(causal_columns) else None,  # none: live uses the others
            causal_column_class=causal_class if len(causal_columns) else None,
            representation=self.representation,
            feature_offset=named.offset if self.representation == "summary" else None,
            feature_scale=named.scale if self.representation == "summary" else None,
            features=recordings[0].meta.get("features", "channels"),
            orientation=recordings[0].meta.get("orientation", "default"),
            parameters={**{name: value for name, value in self.get_params().items()
                           if name not in ("channels", "prior", "representation", "step") and name not in SELECTED},
                        **self.settings_, "affine": AFFINE if self.representation == "hankel" else 0.0,
                        "prior": type(self.prior).__name__ if self.prior is not None else None},
            summary=summary,
        )


def _check_number(learner: SetSupervisedLearner, name: str, low: float, whole: bool = False,
                  open_low: bool = False, high: float | None = None, what: str | None = None) -> None:
    """Refuse parameter ``name`` of ``learner`` unless it is a finite number (a whole one with ``whole``) ``>= low``
    (``> low`` with ``open_low``) and ``<= high``, naming the parameter and ``what`` to give."""
    value = getattr(learner, name)
    kinds = (int, np.integer) if whole else (int, float, np.integer, np.floating)
    ok = isinstance(value, kinds) and not isinstance(value, bool) and np.isfinite(value)
    ok = ok and (value > low if open_low else value >= low) and (high is None or value <= high)
    if not ok:
        what = what or ("a whole number" if whole else "a number")
        bound = f"{'>' if open_low else '>='} {low:g}" + (f" and <= {high:g}" if high is not None else "")
        raise InputError(f"{name}={value!r}: give {what} {bound}")


def _margins(log_q: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """``log q(label) - max_{c != label} log q(c)`` per window (``inf`` when the label is its set's only class)."""
    own = log_q[np.arange(len(labels)), labels]
    other = log_q.copy()
    other[np.arange(len(labels)), labels] = -np.inf
    return own - other.max(axis=1)


def _normalised(log_q: np.ndarray) -> np.ndarray:
    """``exp(log_q)`` normalised per row (rows of ``-inf`` but the finite entries), in single precision
    (:func:`_single`)."""
    w = np.exp(log_q - log_q.max(axis=1, keepdims=True))
    return _single(w / w.sum(axis=1, keepdims=True))


def _single(values: np.ndarray) -> np.ndarray:
    """``values`` rounded to single precision (kept as float64): the names the rounds, the decoding and the margins
    read. numpy's ``exp`` and ``log`` round the last bit differently on different processors (its AVX-512 kernels), and
    the trees, fitted on the names as sample weights, turn such a difference into other trees, round after round; a
    last-bit difference of float64 changes the value rounded to float32 only when it falls on a rounding boundary
    (about one value in 2^29), so the names and the columns chosen are the same on every machine (the trees see their
    features in float32 already)."""
    return values.astype(np.float32).astype(np.float64)


def _candidate_rows(weights: np.ndarray, windows: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rows, classes and sample weights a round's forest is fitted on: each of ``windows`` once per class ``c``
    with ``weights[:, c] > 0``, weighing ``weights[:, c]``, each class's weights scaled to sum to 1."""
    rows, classes = np.nonzero(weights[windows] > 1e-6)
    rows = windows[rows]
    sample_weight = weights[rows, classes]
    totals = np.bincount(classes, weights=sample_weight, minlength=weights.shape[1])
    return rows, classes, sample_weight / totals[classes]


def _pick(labels: np.ndarray, margin: np.ndarray, n_classes: int, max_columns: int,
          share: float) -> tuple[np.ndarray, np.ndarray]:
    """Per class ``c``, the windows labelled ``c`` (``labels`` ``-1``: none) with a margin at or above the class's
    ``1 - share`` quantile (the median for ``share`` 0.5; every window for 1), at most ``max_columns`` spread evenly
    over their order. An infinite margin (a window whose recording declares its class alone) counts as the largest
    finite one, so that the quantile is never undefined."""
    picked, owner = [], []
    for c in range(n_classes):
        idx = np.flatnonzero(labels == c)
        if len(idx) > 1 and share < 1:
            kept = np.minimum(margin[idx], np.finfo(float).max)
            idx = idx[kept >= np.quantile(kept, 1.0 - share)]
        if len(idx) > max_columns:
            idx = idx[np.linspace(0, len(idx) - 1, max_columns).round().astype(int)]
        picked.append(np.sort(idx))
        owner.append(np.full(len(idx), c))
    return np.concatenate(picked).astype(int), np.concatenate(owner).astype(int)


EXHAUSTIVE = 20_000_000
"""Largest ``m k 2^k`` (windows times classes times subsets of a recording) for which :func:`decode_runs` makes every
class appear; its back-pointers take 4 bytes each."""


def decode_runs(log_q: np.ndarray, switch: float) -> np.ndarray:
    """Best class index per row of ``log_q`` ``(m, k)``: the sequence ``z`` maximising

        sum_i log_q[i, z_i] - switch * #{i : z_i != z_{i-1}}

    among those in which every one of the ``k`` classes occurs (when ``m k 2^k <=`` :data:`EXHAUSTIVE` and
    ``m >= k``; else without that condition, which :meth:`SetSupervisedLearner.fit` warns about). Dynamic programming
    over (class, classes seen so far): ``O(m k^2 2^k)`` time and ``m k 2^k`` back-pointers."""
    log_q = np.ascontiguousarray(np.where(np.isfinite(log_q), log_q, -1e9), dtype=float)
    m, k = log_q.shape
    every = m * k * 2 ** k <= EXHAUSTIVE and m >= k
    return _viterbi(log_q, float(switch), every)


@numba.njit(cache=True)
def _viterbi(log_q, switch, every):  # pragma: no cover - compiled
    m, k = log_q.shape
    n_masks = 1 << k if every else 1
    score = np.full((k, n_masks), -np.inf)
    back = np.zeros((m, k, n_masks), dtype=np.int32)  # previous (class * n_masks + mask)
    for c in range(k):
        score[c, (1 << c) if every else 0] = log_q[0, c]
    for i in range(1, m):
        new = np.full((k, n_masks), -np.inf)
        for c in range(k):
            for mask in range(n_masks):
                if every and not (mask >> c) & 1:
                    continue
                best, arg = score[c, mask], c * n_masks + mask  # stay
                for p in range(k):
                    if p == c:
                        continue
                    for t in range(2 if every else 1):
                        pm = mask if t == 0 else mask & ~(1 << c)  # c seen before, or first seen now
                        if score[p, pm] - switch > best:
                            best, arg = score[p, pm] - switch, p * n_masks + pm
                new[c, mask] = best + log_q[i, c]
                back[i, c, mask] = arg
        score = new
    full = n_masks - 1
    c, mask = 0, full
    best = -np.inf
    for cc in range(k):
        if score[cc, full] > best:
            best, c = score[cc, full], cc
    out = np.empty(m, dtype=np.int64)
    for i in range(m - 1, -1, -1):
        out[i] = c
        if i > 0:
            arg = back[i, c, mask]
            c, mask = arg // n_masks, arg % n_masks
    return out
