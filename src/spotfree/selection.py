"""Settings of the set-supervised learner chosen from the class sets alone: held-out recordings scored by the set
risk.

Nobody marks where a class occurs, so no per-sample error can be measured; but the declared sets bound it. A model
fitted without a recording ``u`` labels its samples ``z_i``; what the set ``S_u`` of ``u`` says about them:

* a sample named ``c`` outside ``S_u`` is certainly wrong: it is a false positive of ``c`` (``u`` holds no ``c``);
* a class ``c`` in ``S_u`` that names no sample of ``u`` is certainly missed there: every sample of ``c`` in ``u``
  (at least one) is a false negative of ``c``.

Per class ``c``, with ``U_c`` the held-out recordings that declare ``c`` and ``V_c`` those that do not,

    FP_c = sum_{u in V_c} #{i in u : z_i = c} / sum_{u in V_c} #{i in u}          (labelled samples)
    MISS_c = #{u in U_c : no z_i = c} / |U_c|

``FP_c`` estimates the rate at which samples of other classes are called ``c`` (on the samples known not to be
``c``), and ``MISS_c`` is at most the share of recordings in which ``c``'s recall is zero, a lower bound of the mean
per-recording miss rate of ``c``. The set risk

    R = 1/C sum_c (FP_c + MISS_c)

is the sum of the two as a class-balanced error is, each term measured only where the sets make it certain; it is
the zero-one form of the held-out likelihood of the sets under the multiple-instance assumption (a recording's
samples all lie in its set, and each declared class is in at least one of them: Dietterich, Lathrop and
Lozano-Perez, "Solving the multiple instance problem with axis-parallel rectangles", Artificial Intelligence 1997;
the noisy-or bag likelihood of Maron and Lozano-Perez, NIPS 1998), and it makes a class that claims windows in
recordings that do not declare it, a declared class that finds no run, and windows named outside their set all
count against a candidate. Model selection by the held-out risk of the weak labels themselves is how partial-label
and multiple-instance learners are validated when no instance label exists (Cour, Sapp and Taskar, "Learning from
Partial Labels", JMLR 2011, section 7; Zhou, "A brief introduction to weakly supervised learning", National Science
Review 2018). Both the offline (centred) and the live (causal) labels are scored, and ``R`` is their mean.

**Held out.** The recordings are dealt to two folds, whole logs to each where the recordings come from several
logs (so that a model is scored on logs it never saw, as it will be used: group cross-validation), else those that
declare the same set alternately, so that each set is in both folds where it has two recordings or more; either
only where both folds then declare the same classes. Each fold's model is fitted on the other fold. With fewer
than :data:`FEWEST_RECORDINGS` recordings, each recording is cut at its middle instead, the models are fitted on
the first halves and scored on the second ones and the other way round; a half need not hold every class of its
recording, so ``MISS`` is not counted then. Only the samples that every candidate window labels are scored (a
recording's first window and last half window are left out), and a window is a candidate only where the median
recording's half leaves at least a window of such samples.

**Search.** The settings of :data:`CANDIDATES` are chosen one at a time in that order (coordinate descent), each
over its candidates with the others at the values chosen so far, the defaults first: the window (in seconds), the
share power, the column share, the smoothing. A naming (window and share power: the rounds, the learner's cost) is
fitted once per fold, with forests of half the learner's trees, and kept; a column share or a smoothing then costs
one dictionary and one classification of the held-out recordings. A candidate replaces the one in hand only if its
risk is lower by more than :data:`TOLERANCE`, so that the defaults stay where the sets cannot tell the candidates
apart. A setting given by the user is not searched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from sklearn.base import clone

from spotfree.io.recording import Recording

AUTO = "auto"
"""The value of a setting of :class:`~spotfree.learner.SetSupervisedLearner` that asks for it to be chosen."""
CANDIDATES = {"window": (1.0, 2.0), "share_power": (0.5, 1.0), "column_share": (0.5, 0.25, 1.0),
              "smoothing": (0.5, 1.0, 0.25)}
"""Candidate values per setting, the default first: the window in seconds (made samples at the recordings' rate),
the share power, the column share and the smoothing (s) of
:class:`~spotfree.learner.SetSupervisedLearner`."""
TOLERANCE = 0.005
"""Least fall of the set risk for which a candidate replaces the one in hand."""
SCORED_WINDOWS = 1.0
"""Least scored length, in windows, of the median held-out recording for a window to be a candidate."""
FEWEST_RECORDINGS = 4
"""Fewest recordings for which whole recordings are held out (fewer: halves of each recording)."""


@dataclass
class Fold:
    """Recordings a candidate is fitted on and those it is scored on, with their sets; ``whole``: the scored ones are
    whole recordings (so that a declared class must occur in each)."""

    train: list[Recording]
    train_sets: list[set[str]]
    test: list[Recording]
    test_sets: list[set[str]]
    whole: bool


def select_settings(learner, recordings: list[Recording], sets: list[set[str]]) -> tuple[dict, list[dict]]:
    """The settings of :data:`~spotfree.learner.SELECTED` for ``learner`` (a
    :class:`~spotfree.learner.SetSupervisedLearner`; given ones kept) and one row per setting: ``{"setting",
    "value", "given", "candidates"}``, ``candidates`` mapping each value tried to the set risk of the settings
    chosen with it (empty for a given setting, or where nothing could be held out)."""
    values = _candidate_values(learner, float(recordings[0].rate))
    values["window"] = _fitting_windows(values["window"], recordings, learner.window != AUTO)
    searched = any(len(v) > 1 for v in values.values())
    folds = held_out_folds(recordings, sets, np.random.default_rng(learner.seed), max(values["window"])) if searched \
        else []
    chosen = {name: v[0] for name, v in values.items()}
    tried: dict[str, dict] = {name: {} for name in CANDIDATES}
    if folds:
        search = _Search(learner, folds, max(values["window"]))
        for name in CANDIDATES:  # one setting at a time, the others at the values chosen so far
            tried[name] = {value: search.risk({**chosen, name: value}) for value in values[name]}
            chosen[name] = _first_unless_beaten(tried[name])
    rows = [{"setting": name, "value": chosen[name], "given": getattr(learner, name) != AUTO,
             "candidates": {} if getattr(learner, name) != AUTO else
             {v: round(float(r), 4) for v, r in tried[name].items()}} for name in CANDIDATES]
    return chosen, rows


def select_features(learner, candidates: dict[str, list[Recording]], sets: list[set[str]]) -> tuple[str, dict]:
    """The kind of features, of ``candidates`` (kind: the training recordings as that kind of features, in the order
    of preference), whose held-out set risk (:func:`held_out_risk`) is the lowest, with ``learner``'s settings as
    given or, where not given, at their first candidates; a later kind wins only when lower by more than
    :data:`TOLERANCE`. Returns the kind and each kind's risk (None where nothing could be held out)."""
    values = _candidate_values(learner, float(next(iter(candidates.values()))[0].rate))
    fixed = clone(learner).set_params(**{name: v[0] for name, v in values.items()})
    risks = {kind: held_out_risk(fixed, recordings, sets) for kind, recordings in candidates.items()}
    known = {kind: risk for kind, risk in risks.items() if risk is not None}
    return (_first_unless_beaten(known) if next(iter(candidates)) in known else next(iter(candidates))), risks


def held_out_risk(learner, recordings: list[Recording], sets: list[set[str]]) -> float | None:
    """The set risk of ``learner``'s settings as they stand (every one of
    :data:`~spotfree.learner.SELECTED` given) on the folds of :func:`held_out_folds`; None where nothing can be held
    out."""
    fixed = {name: getattr(learner, name) for name in CANDIDATES}
    if any(v == AUTO for v in fixed.values()):
        raise ValueError("held_out_risk needs every selected setting given")
    folds = held_out_folds(recordings, sets, np.random.default_rng(learner.seed), fixed["window"])
    return _Search(learner, folds, fixed["window"]).risk(fixed) if folds else None


def held_out_folds(recordings: list[Recording], sets: list[set[str]], rng: np.random.Generator,
                   window: int) -> list[Fold]:
    """Two folds (module docstring): whole logs (:func:`log_of`) where both sides then declare the same classes,
    else whole recordings dealt alternately within each declared set where that does, or, with fewer than
    :data:`FEWEST_RECORDINGS` recordings, the halves of each recording at least two ``window`` long; empty where a
    fold would have nothing to fit or to score."""
    if len(recordings) >= FEWEST_RECORDINGS:
        for fold in (_by_log(recordings, rng), _within_sets(sets, rng)):
            parts = [[r for r in range(len(recordings)) if fold[r] == f] for f in (0, 1)]
            classes = [set().union(*(sets[r] for r in part)) if part else set() for part in parts]
            if all(parts) and classes[0] == classes[1]:  # each side's model can name what the other side declares
                return [Fold([recordings[r] for r in parts[1 - f]], [sets[r] for r in parts[1 - f]],
                             [recordings[r] for r in parts[f]], [sets[r] for r in parts[f]], whole=True)
                        for f in (0, 1)]
    halves = [(rec.take(slice(0, len(rec) // 2)), rec.take(slice(len(rec) // 2, len(rec))), s)
              for rec, s in zip(recordings, sets) if len(rec) // 2 >= 2 * window]
    if not halves:
        return []
    return [Fold([h[f] for h in halves], [h[2] for h in halves], [h[1 - f] for h in halves],
                 [h[2] for h in halves], whole=False) for f in (0, 1)]


def _by_log(recordings: list[Recording], rng: np.random.Generator) -> np.ndarray:
    """Fold of each recording, whole logs (:func:`log_of`) dealt in a random order to the smaller side."""
    logs = [log_of(rec) for rec in recordings]
    fold, size = np.zeros(len(recordings), dtype=int), [0, 0]
    for log in rng.permutation(list(dict.fromkeys(logs))):
        members = [r for r, name in enumerate(logs) if name == log]
        side = int(size[1] < size[0])
        fold[members], size[side] = side, size[side] + len(members)
    return fold


def _within_sets(sets: list[set[str]], rng: np.random.Generator) -> np.ndarray:
    """Fold of each recording, the recordings of each declared set dealt alternately in a random order."""
    fold, turn = np.zeros(len(sets), dtype=int), 0
    for members in _by_set(sets).values():
        for r in rng.permutation(members):
            fold[r], turn = turn, 1 - turn
    return fold


def log_of(rec: Recording) -> str:
    """The log a training recording comes from: ``meta["log"]`` (a span's log), else its source."""
    return str(rec.meta.get("log", rec.source))


def set_risk(labels: list[np.ndarray], sets: list[set[str]], groups: list[str] | None,
             classes: list[str]) -> float:
    """``R`` of the module docstring for the per-sample ``labels`` (``""``: unlabelled) of held-out recordings that
    declare ``sets``; ``MISS`` is counted per group of recordings (``groups``: the log each comes from: a class
    declared by one of a log's recordings must be named in one of them), not at all for None."""
    index = {c: k for k, c in enumerate(classes)}
    fp = np.zeros((2, len(classes)))  # samples named c / samples, over the recordings without c
    declared: dict[str, np.ndarray] = {}  # per group: classes declared, classes named
    named_in: dict[str, np.ndarray] = {}
    for r, (lab, inside_set) in enumerate(zip(labels, sets)):
        named = lab[lab != ""]
        counts = np.zeros(len(classes))
        found, k = np.unique(named, return_counts=True)
        for c, n in zip(found, k):
            if c in index:
                counts[index[c]] = n
        inside = np.array([c in inside_set for c in classes])
        fp[0, ~inside] += counts[~inside]
        fp[1, ~inside] += len(named)
        if groups is not None:
            g = groups[r]
            declared[g] = declared.get(g, np.zeros(len(classes), bool)) | inside
            named_in[g] = named_in.get(g, np.zeros(len(classes), bool)) | (counts > 0)
    miss = np.zeros((2, len(classes)))  # groups declaring c that name no sample c / groups declaring c
    for g, inside in declared.items():
        miss[0, inside] += ~named_in[g][inside]
        miss[1, inside] += 1
    rates = [np.divide(a, b, out=np.zeros_like(a), where=b > 0) for a, b in (fp, miss)]
    return float(np.mean(rates[0] + rates[1]))


class _Search:
    """Set risks of settings on fixed folds, each naming (window and share power: the rounds, the learner's cost)
    fitted once per fold and kept, with forests of half the learner's trees; every column share and smoothing then
    costs one dictionary and one classification of the held-out recordings."""

    def __init__(self, learner, folds: list[Fold], margin: int):
        self.learner, self.folds, self.margin = learner, folds, margin
        self.classes = sorted(set().union(*(s for f in folds for s in f.train_sets + f.test_sets)))
        self.sets = [s for f in folds for s in f.test_sets]
        self.groups = [log_of(rec) for f in folds for rec in f.test] if all(f.whole for f in folds) else None
        self.joined = [(_joined(f.test), np.cumsum([len(rec) for rec in f.test])[:-1]) for f in folds]
        self.named: dict[tuple, list] = {}
        self.risks: dict[tuple, float] = {}

    def risk(self, settings: dict) -> float:
        """``R`` (module docstring) of ``settings``: the mean of the offline and the live labels' risks."""
        key = tuple(settings[name] for name in CANDIDATES)
        if key not in self.risks:
            labels = {True: [], False: []}
            for sub, (joined, parts) in zip(self._named(settings), self.joined):
                sub.settings_ = dict(settings)
                sub._build()
                for centred in (True, False):
                    labels[centred] += [_inner(lab, self.margin)
                                        for lab in np.split(sub.predict(joined, centred=centred), parts)]
            self.risks[key] = 0.5 * sum(set_risk(labels[c], self.sets, self.groups, self.classes) for c in labels)
        return self.risks[key]

    def _named(self, settings: dict) -> list:
        """The learners of each fold named with ``settings``' window and share power."""
        key = (settings["window"], settings["share_power"])
        if key not in self.named:
            self.named[key] = []
            for fold in self.folds:
                sub = clone(self.learner).set_params(trees=max(1, self.learner.trees // 2))
                sub.settings_, sub.selection_ = dict(settings), []
                sub._name(fold.train, fold.train_sets)
                self.named[key].append(sub)
        return self.named[key]


def _by_set(sets: list[set[str]]) -> dict[frozenset, list[int]]:
    """The recordings' indices grouped by declared set, in the order the sets first occur."""
    groups: dict[frozenset, list[int]] = {}
    for r, s in enumerate(sets):
        groups.setdefault(frozenset(s), []).append(r)
    return groups


def _inner(labels: np.ndarray, window: int) -> np.ndarray:
    """``labels`` of one recording with its first ``window`` and last ``window // 2`` samples blanked: the samples
    that every candidate window labels, live and offline, so that a longer window is not scored on fewer of them."""
    out = labels.copy()
    out[:window] = ""
    out[max(window, len(out) - window // 2):] = ""
    return out


def _fitting_windows(windows: list[int], recordings: list[Recording], given: bool) -> list[int]:
    """The candidate ``windows`` (samples, each once) that leave at least :data:`SCORED_WINDOWS` windows' worth of
    scored samples in the median recording once halved (the first always kept; a given window as it is)."""
    windows = list(dict.fromkeys(windows))  # two seconds may round to the same samples
    if given:
        return windows
    length = float(np.median([len(rec) for rec in recordings])) / 2
    return windows[:1] + [w for w in windows[1:] if length - 1.5 * w >= SCORED_WINDOWS * w]


def _candidate_values(learner, rate: float) -> dict[str, list]:
    """Per setting of :data:`CANDIDATES`, ``learner``'s value alone where given, else the candidates (the window in
    samples at ``rate``)."""
    return {name: [getattr(learner, name)] if getattr(learner, name) != AUTO else
            [_in_samples(v, rate) if name == "window" else v for v in values] for name, values in CANDIDATES.items()}


def _first_unless_beaten(risks: dict):
    """The first key of ``risks`` (the default), replaced in order by any whose risk is lower than the one in hand's by
    more than :data:`TOLERANCE`."""
    keys = list(risks)
    best = keys[0]
    for key in keys[1:]:
        if risks[key] < risks[best] - TOLERANCE:
            best = key
    return best


def _joined(recordings: list[Recording]) -> Recording:
    """``recordings`` (of the same channels and rate) as one Recording, each an experiment of its own, so that they
    are classified in one call and no window spans two of them."""
    first = recordings[0]
    return Recording(time=np.concatenate([rec.time for rec in recordings]),
                     channels={c: np.concatenate([rec.channels[c] for rec in recordings]) for c in first.names},
                     rate=first.rate, source="held-out recordings",
                     experiment=np.concatenate([np.full(len(rec), k + 1) for k, rec in enumerate(recordings)]),
                     meta=dict(first.meta))


def _in_samples(seconds: float, rate: float) -> int:
    """``seconds`` as a window of at least two samples at ``rate``."""
    return max(2, int(round(seconds * rate)))
