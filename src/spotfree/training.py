"""Spotting-free dictionary building (the paper's section IV-B, made to survive real recordings).

Input: training recordings, each with the set of classes that occur somewhere in it (nothing is labelled).
Output: a :class:`~spotfree.model.DictionaryModel` whose columns are windows kept as pure class representatives.

``recipe="evidence"`` (default):

1. Feature channels of every recording (default ``acc_long`` and ``pitch_rate``: the speed-aided longitudinal
   acceleration shows a sustained braking that the accelerometer alone does not on a self-balancing vehicle, and
   the handlebar's pitch rate shows the rider leaning into and out of it, sooner and sharper for a hard stop;
   chosen on development seeds 10-14 of the evaluation's protocol, causal kernel CRC_RLS 79.0 % with ``acc_long``
   and ``acc_x``, 90.8 % with ``acc_long`` and ``pitch_rate``: ``benchmarks/evaluation_seeds.py``, BENCHMARKS.md),
   per-channel scale learned over all of them
   (amplitude kept), and a constant row ``affine`` appended to every window for clustering, nesting and
   purification (:func:`~spotfree.windows.with_affine_row`: a window and its negative are no longer one subspace).
   The dictionary stores the windows without that row; ``parameters["affine"]`` tells classification to append it.
2. Windows of all recordings pooled and clustered into ``n_classes + extra_clusters`` groups, more groups than
   declared classes, so that a confounder (a turn, a bump, a change of speed) gets a group of its own instead of
   being merged with a manoeuvre. Default k-means (10 restarts); ``clustering="osc"`` is the paper's Ordered
   Subspace Clustering. Measured (``benchmarks/training_purity.py``, BENCHMARKS.md): on these features a braking
   differs from cruising mostly in level, and windows of different constant levels span one subspace (with the
   affine row, two dimensions), so OSC mixes them where k-means does not.
3. Groups named by evidence across recordings (:mod:`spotfree.naming`): enrichment, then novelty (a group named a
   class must lie away from the recordings without that class, or it is one rider's habit and goes to the
   background), then the lean (a group named a braking class must lean towards the stop where that class is
   recorded, ``upright``, :func:`~spotfree.naming.rename_upright`), then nesting (a class that evidence left
   without a group and that a more specific class passes through, by the caller's ``nesting`` pairs, takes the
   shared group nearest to that class: normal braking around sudden braking, among the groups that lose speed
   where the recordings carry GPS; failing that, a background group
   whose windows lean three times the usual depth towards the hardest stop in the outer class's home recordings,
   ``outer_depth``, :func:`~spotfree.naming.name_deep_outer`; failing that, with GPS speed, the background group that
   loses speed fastest there, :func:`~spotfree.naming.name_slowing_outer`); the user may override any name.
4. Nesting: every group named a manoeuvre is checked against the known, less specific classes (background first):
   its windows are classified by CRC against those classes' windows and its own windows outside the run being
   tested; a group that a known class explains takes that name, unless that class is the background and the group
   loses speed by the GPS (``slowing``, :func:`_speed_loss`). Groups that stay are split in two by OSC again and
   each half is checked the same way (the paper's second clustering of the sudden-stop experiment, which
   separates the normal braking hidden around each sudden stop); of a group that nesting named, a half that
   evidence calls the background, beside a half enriched for the group's class, goes to the background
   (:func:`_shared_half`). On request (``single_manoeuvre``), a group absent from the recordings that declare
   only the background takes, recording by recording, the one manoeuvre its recording declares
   (:func:`spotfree.naming.single_manoeuvre_names`; one recording per manoeuvre, as the paper trains, and some
   without any: the turning windows of gentle turns, sharp turns and slaloms share groups that evidence alone calls
   the background). A declared class that no window was named by then is looked for again among the windows named
   the background, clustered anew and named by the same evidence (``recluster``, :func:`_recluster_background`).
   Then the names are moved to the timing of the
   channel that defines the classes (``timing``, default the measured ``lean``; :func:`_align_names`): a window's
   content shows the vehicle's answer, which follows the rider's lean. The windows at a recording's deepest lean
   take the inner class of a nesting pair when they go beyond every recording without it (``deepest_inner``,
   :func:`_deepest_inner`).
5. Purification: a window named a class that its recording does not declare is dropped (the group it belongs to
   is mixed there); windows within ``margin`` windows of a change of name straddle two states and are dropped, and so
   are windows that lie nearer to another name than to their own (leave-run-out: a run of windows is compared with
   the kept windows outside it; :func:`_run_margins`, mean distance to the 5 nearest windows of each name, which
   keeps amplitude where a linear representation would scale it away; a class's only run has nothing of its class to
   be compared with and is kept untested). The checks of steps 4 and 5 give each class
   the same number of windows, chosen evenly over time (:func:`_balanced`): with hundreds of background atoms in a
   window space of a few dozen dimensions, the background would represent anything. A column must have a margin of
   at least ``min_margin``; of those, at most ``max_columns`` per class are kept, evenly spread over time, so that
   the dictionary covers all of a class (steady cruising as well as acceleration) instead of only its windows
   farthest from the other classes. Measured (``benchmarks/evaluation_seeds.py``, BENCHMARKS.md): keeping the
   largest margins left steady cruising out of the dictionary on two of five seeds. ``max_columns`` 600 (chosen on
   development seeds 10-14 of the evaluation's protocol among 100-1000: causal kernel CRC_RLS 75.6 % with 100
   columns, 79.0 % with 600, the same with 1000; CRC_RLS 71.9 % -> 78.8 %).
   Before that, a few windows named the background inside a manoeuvre's run take its name (``close_gaps``,
   :func:`_close_gaps`). A manoeuvre class takes its columns only from its home recordings (those made for it,
   :func:`spotfree.naming.class_homes`; :func:`_away_from_home`); the inner class of a nesting pair (the sudden
   stop) only from windows centred where the lean is deepest in their run and in their recording, and was one step
   earlier (``inner_depth``, ``inner_floor``, :func:`_shallow_inner`)
   and of those only its most confident quarter (``inner_quantile``, :func:`_cap`): the causal columns of step 6
   keep all of its windows, so causal labels do not depend on either. The background takes no column from a window
   that leans towards the stop (``background_lean``, :func:`_leaning_background`): the gentlest braking. Where the
   recordings carry the GPS ``speed``, a braking class takes no column from a window that does not lose speed, nor
   the background from one that does (``slowing``, :func:`_speed_disagrees`).
6. Causal columns (:func:`_causal_columns`): a window's name describes its centre, but a causal window labels its
   last sample, half a window later. The model also carries the training windows named by the window centred on
   their end, for causal classification (batch, streaming, the page); centred classification uses the others.
   These include, unless ``causal_onsets`` is off, the windows that end in the first moments of a manoeuvre, where
   purification drops the centred window.

``recipe="paper"`` is the paper's procedure taken literally, kept to measure the gain: each recording alone, unit-
norm windows, split in two, the larger cluster named the background and the smaller the recording's most specific
class; a recording declaring a third class has that cluster split once more, the larger half kept.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np
from sklearn.cluster import KMeans

from spotfree.classify.crc import CRCClassifier
from spotfree.classify.neighbours import NearestColumnsClassifier
from spotfree.cluster.osc import OrderedSubspaceClustering
from spotfree.errors import InputError
from spotfree.io.checks import true_runs
from spotfree.io.recording import Recording
from spotfree.model import DictionaryModel
from spotfree.ride_prior import speed_trend as speed_slope
from spotfree.naming import (DEPTH_RATIO, ENRICHMENT, UPRIGHT, ClusterName, background_class, class_enrichment,
                             class_homes, median_trend, name_clusters, name_deep_outer, name_nested,
                             name_slowing_outer, presence_matrix, rename_habits, rename_upright,
                             single_manoeuvre_names)
from spotfree.windows import ChannelScaling, WindowedRecording, recording_windows, with_affine_row

RECIPES = ("evidence", "paper")
DEFAULT_CHANNELS = ("acc_long", "pitch_rate")
NESTING = (("sudden-braking", "normal-braking"),)
"""Default ``(inner, outer)`` pairs: a manoeuvre of class ``inner`` passes through class ``outer``
(:func:`spotfree.naming.name_nested`); the paper's sudden stop, which passes through normal braking."""

Progress = Callable[[str], None]


@dataclass
class TrainingExperiment:
    """One ``--experiment PATH=CLASS,...``: a feature Recording and the classes that occur somewhere in it."""

    recording: Recording
    classes: list[str]


@dataclass
class TrainingConfig:
    """Training parameters; window and step in samples, ``train_step`` is the stride of the training windows.
    ``landmarks`` is stored in the model for the kernel CRC_RLS that labels with it
    (:class:`~spotfree.classify.kcrc.KernelCRCClassifier`; None: every atom). ``timing``: the channel whose timing
    defines the classes, which names are aligned to (:func:`_align_names`; None: names as clustered).
    ``votes``: the clustering and naming are run with this many seeds (``seed``, ``seed + 1``, ...) and each window
    takes its most frequent name (:func:`_voted_names`). ``inner_quantile``, ``outer_quantile``: the inner / outer
    class of a ``nesting`` pair keeps its columns at or above this quantile of their margins (:func:`_cap`; 0: every
    confident column). ``inner_depth``: the inner class takes no column from a window centred where ``timing`` is
    shallower than this share of its run's deepest, ``inner_floor``: of the recording's deepest window named the
    inner class, nor from the window after such a one (:func:`_shallow_inner`; 0: off). ``background_lean``: the
    background takes no column from a window leaning towards the hardest stop by more than this many times its
    recording's usual depth (:func:`_leaning_background`; 0: off). ``slowing`` (m/s^2): a class of a nesting pair
    (braking) takes no column from a window around whose centre the recording's GPS ``speed`` falls more slowly than
    this, nor the background from one where it falls at least this fast (:func:`_speed_disagrees`; 0: off); a group
    must lose speed at least this fast to be named the outer class by nesting
    (:func:`~spotfree.naming.name_nested`) or, as a last resort, as the fastest to lose speed
    (:func:`~spotfree.naming.name_slowing_outer`), and it keeps a braking group that the nesting check would give to the
    background when the group loses speed at least this fast (:func:`_speed_loss`). ``deepest_inner``: in a
    recording declaring the inner class, the windows at its deepest ``timing`` take that class when they go beyond
    every window of the recordings without it (:func:`_deepest_inner`). ``outer_depth``: a background group that
    leans this many times the usual depth towards the inner class's deepest, in the outer class's home recordings,
    takes the outer class when evidence gave it no group (:func:`~spotfree.naming.name_deep_outer`; 0: off).
    ``upright``: a group named a class of a nesting pair by evidence whose median lean, in that class's home
    recordings and in the same units, is below this goes to the background (:func:`~spotfree.naming.rename_upright`;
    0: off). ``close_gaps``: a run of at most this many training windows named the background between two runs of
    one manoeuvre takes the manoeuvre's name (:func:`_close_gaps`; 0: none). ``recluster``: a declared class that no
    window was named after nesting is looked for again among the background's windows, clustered anew
    (:func:`_recluster_background`).
    ``single_manoeuvre``: a group absent from the recordings that declare only the background takes, in a recording
    declaring one manoeuvre, that manoeuvre's name (:func:`~spotfree.naming.single_manoeuvre_names`)."""

    channels: tuple[str, ...] = DEFAULT_CHANNELS
    window: int = 20
    step: int = 1
    train_step: int = 2
    normalisation: str = "scale"
    recipe: str = "evidence"
    extra_clusters: int = 7
    background: str | None = None
    affine: float = 6.0
    clustering: str = "kmeans"
    overrides: dict[int, str] = field(default_factory=dict)
    nesting: tuple[tuple[str, str], ...] = NESTING
    max_columns: int = 600
    min_margin: float = 0.15
    inner_quantile: float = 0.75
    outer_quantile: float = 0.5
    inner_depth: float = 0.8
    inner_floor: float = 0.9
    background_lean: float = 0.6
    slowing: float = 0.4
    deepest_inner: bool = True
    outer_depth: float = DEPTH_RATIO
    upright: float = UPRIGHT
    single_manoeuvre: bool = False
    close_gaps: int = 5
    recluster: bool = True
    votes: int = 1
    margin: int | None = None
    causal_onsets: bool = True
    landmarks: int | None = 64
    timing: str | None = "lean"
    seed: int = 0


@dataclass
class TrainingResult:
    """The model, the names with their evidence, and per-window cluster labels for the diagnostic figure."""

    model: DictionaryModel
    names: list[ClusterName]
    levels: list[list[np.ndarray]]
    window_names: list[np.ndarray]
    ends: list[np.ndarray]
    kept: list[np.ndarray]
    column_source: list[tuple[int, int]]
    warnings: list[str]


def train(experiments: list[TrainingExperiment], config: TrainingConfig | None = None,
          progress: Progress | None = None) -> TrainingResult:
    """Build a dictionary from whole recordings (see the module docstring)."""
    config = config or TrainingConfig()
    say = progress or (lambda message: None)
    _validate(experiments, config)
    scaling = ChannelScaling(tuple(config.channels)).fit([e.recording for e in experiments])
    normalisation = "unit" if config.recipe == "paper" else config.normalisation
    windows = [
        recording_windows(e.recording, tuple(config.channels), config.window, config.train_step, scaling,
                          normalisation)
        for e in experiments
    ]
    depth = windows[0].matrix.shape[0]
    windows = [WindowedRecording(with_affine_row(w.matrix, config.affine), w.ends, w.experiment) for w in windows]
    declared = [list(e.classes) for e in experiments]
    say(f"{sum(w.matrix.shape[1] for w in windows)} windows from {len(experiments)} recordings")
    refined = config.recipe != "paper"  # the paper's recipe, kept to measure the gain, is taken literally
    if refined:
        background = background_class(declared, config.background)
        offset = _timing_offset(experiments, windows, config)
        lean = _lean_towards_inner(offset, declared, config.nesting)
        slopes = _window_slopes(experiments, windows, config)
        names_per_window, levels, names, warnings = _voted_names(windows, declared, background, lean, slopes, config,
                                                                 say)
        names_per_window, lag = _align_names(names_per_window, experiments, windows, background, config, say)
        names_per_window = _deepest_inner(names_per_window, offset, declared, config)
        names_per_window = _close_gaps(names_per_window, background, config.close_gaps)
    else:
        names_per_window, levels, names, warnings = _paper_recipe(windows, declared, config, say)
        lag, background = None, None
    kept, margins = _purify(windows, names_per_window, background, config, say)
    if refined:
        away = _away_from_home(names_per_window, declared, background)
        shallow = _shallow_inner([np.where(k, per, "") for per, k in zip(names_per_window, kept)], offset, config)
        leaning = _leaning_background(names_per_window, lean, background, config)
        steady = _speed_disagrees(names_per_window, slopes, background, declared, config)
        left_out = [a | s | b | v for a, s, b, v in zip(away, shallow, leaning, steady)]
    else:
        left_out = [np.zeros(len(per), dtype=bool) for per in names_per_window]
    classes = sorted({n for per in names_per_window for n in per[per != ""]})
    missing = sorted({c for d in declared for c in d} - set(classes))
    warnings += [_missing_class(c, declared) for c in missing]
    columns, column_class, column_source, column_margin = [], [], [], []
    for r, (w, per, keep, margin) in enumerate(zip(windows, names_per_window, kept, margins)):
        for k in np.flatnonzero(keep & ~left_out[r]):
            columns.append(w.matrix[:depth, k])
            column_class.append(classes.index(per[k]))
            column_source.append((r, int(w.ends[k])))
            column_margin.append(margin[k])
    if not columns:
        raise InputError("training kept no window; the recordings may be too short or the classes inseparable")
    inner, outer = ({i for i, _ in config.nesting}, {o for _, o in config.nesting}) if refined else (set(), set())
    quantile = [max(config.inner_quantile * (c in inner), config.outer_quantile * (c in outer)) for c in classes]
    chosen, capped = _cap(np.array(column_class), np.array(column_margin), len(classes), config.max_columns,
                          config.min_margin, quantile)
    columns, column_class = np.array(columns).T[:, chosen], np.array(column_class)[chosen]
    column_source = [column_source[k] for k in chosen]
    warnings += [f"class '{classes[i]}': no column reached the margin {config.min_margin:g}; its {n} columns are "
                 "less confident" for i, n in capped]
    warnings += [f"class '{c}' was named but none of its windows was kept (each lay near a change of name, nearer to "
                 "another class, outside its deepest part, or, braking, did not lose speed); centred labels cannot "
                 "give it: see the figure, or "
                 "add a recording" for i, c in enumerate(classes) if not (column_class == i).any()]
    causal_names = _causal_names(names_per_window, declared, classes, config)
    causal = _causal_columns(windows, causal_names, kept, classes, depth, config)
    model = DictionaryModel(
        classes=classes,
        channels=list(config.channels),
        rate=experiments[0].recording.rate,
        window=config.window,
        step=config.step,
        normalisation=normalisation,
        scale=scaling.scale,
        dictionary=columns,
        column_class=column_class,
        features="ride" if experiments[0].recording.meta.get("features") == "ride" else "channels",
        orientation=experiments[0].recording.meta.get("orientation", "default"),
        parameters={"recipe": config.recipe, "extra_clusters": config.extra_clusters, "seed": config.seed,
                    "clustering": "osc" if config.recipe == "paper" else config.clustering,
                    "affine": config.affine,
                    "train_step": config.train_step, "max_columns": config.max_columns,
                    "min_margin": config.min_margin, "inner_quantile": config.inner_quantile,
                    "outer_quantile": config.outer_quantile,
                    "inner_depth": config.inner_depth, "inner_floor": config.inner_floor,
                    "background_lean": config.background_lean, "slowing": config.slowing,
                    "deepest_inner": config.deepest_inner, "recluster": config.recluster,
                    "outer_depth": config.outer_depth, "upright": config.upright,
                    "single_manoeuvre": config.single_manoeuvre, "close_gaps": config.close_gaps,
                    "nesting": [list(p) for p in config.nesting],
                    "causal_onsets": config.causal_onsets, "landmarks": config.landmarks,
                    "timing": config.timing, "votes": config.votes},
        causal_dictionary=None if causal is None else causal[0],
        causal_column_class=None if causal is None else causal[1],
        summary={
            "clusters": [vars(n) for n in names],
            "columns_per_class": {c: int((column_class == i).sum()) for i, c in enumerate(classes)},
            "aligned": None if lag is None else {
                "channel": config.timing, "windows": lag,
                "seconds": [k * config.train_step / experiments[0].recording.rate for k in lag]},
            "warnings": warnings,
        },
    )
    return TrainingResult(model, names, levels, names_per_window, [w.ends for w in windows], kept, column_source,
                          warnings)


def _missing_class(name: str, declared: list[list[str]]) -> str:
    """The warning for a declared class that no cluster took, with why when every recording declares it."""
    warning = f"declared class '{name}' was given no cluster; the model cannot recognise it"
    if all(name in d for d in declared):
        warning += (": every recording declares it, so no recording can show what it is not; add a recording "
                    f"without {name}, or name its cluster from the summary and the figure with --name CLUSTER={name}")
    return warning


def _validate(experiments: list[TrainingExperiment], config: TrainingConfig) -> None:
    if not experiments:
        raise InputError("no training recording given; add --experiment PATH=CLASS[,CLASS...]")
    if config.recipe not in RECIPES:
        raise InputError(f"unknown training recipe '{config.recipe}'; use one of {', '.join(RECIPES)}")
    rates = {e.recording.rate for e in experiments}
    if max(rates) - min(rates) > 1e-6 * max(rates):
        raise InputError(f"training recordings have different rates {sorted(rates)} Hz; resample them to one rate")
    for e in experiments:
        if not e.classes:
            raise InputError(f"{e.recording.source}: declare the classes that occur in it (PATH=CLASS[,CLASS...])")
        if not np.isfinite(e.recording.array(config.channels)).any():
            raise InputError(f"{e.recording.source}: channels {', '.join(config.channels)} hold no finite sample")
    if config.window < 2:
        raise InputError(f"window must be at least 2 samples, got {config.window}")
    if config.votes < 1:
        raise InputError(f"votes (--votes) must be at least 1, got {config.votes}")
    if config.close_gaps < 0:
        raise InputError(f"close_gaps (--close-gaps) must be 0 or more training windows, got {config.close_gaps}")
    for name in ("inner_depth", "inner_floor"):
        if not 0.0 <= getattr(config, name) <= 1.0:
            raise InputError(f"{name} (--{name.replace('_', '-')}) must be between 0 and 1, "
                             f"got {getattr(config, name)}")
    if not (config.outer_depth == 0 or config.outer_depth >= 1):
        raise InputError(f"outer_depth (--outer-depth) must be 0 (off) or at least 1 (the usual depth), got "
                         f"{config.outer_depth}")
    if config.background_lean < 0:
        raise InputError(f"background_lean (--background-lean) must be 0 (off) or more, in units of the usual lean, "
                         f"got {config.background_lean}")
    if config.slowing < 0:
        raise InputError(f"slowing (--slowing) must be 0 (off) or more, in m/s^2 of lost speed, got {config.slowing}")
    if config.upright < 0:
        raise InputError(f"upright (--upright) must be 0 (off) or more, in units of the usual lean, got "
                         f"{config.upright}")
    for name in ("inner_quantile", "outer_quantile"):
        if not 0.0 <= getattr(config, name) < 1.0:
            raise InputError(f"{name} (--{name.replace('_', '-')}) must be at least 0 and below 1, "
                             f"got {getattr(config, name)}")


def _cluster(matrix: np.ndarray, n_clusters: int, seed: int, method: str = "osc") -> np.ndarray:
    """Cluster labels of the columns of a block-Hankel ``matrix`` (windows as columns): Ordered Subspace Clustering
    (``"osc"``) or k-means (``"kmeans"``, 10 restarts)."""
    n_clusters = max(1, min(n_clusters, matrix.shape[1]))
    if n_clusters == 1:
        return np.zeros(matrix.shape[1], dtype=int)
    if method == "kmeans":
        return KMeans(n_clusters, n_init=10, random_state=seed).fit_predict(matrix.T)
    return OrderedSubspaceClustering(n_clusters=n_clusters, random_state=seed).fit(matrix.T).labels_


def _voted_names(windows, declared, background, lean, slopes, config, say):
    """:func:`_evidence_recipe` run with ``config.votes`` clustering seeds; each window takes the name most of the
    runs gave it (a tie: the first run's name). Levels, cluster names and warnings are the first run's, for the
    summary and the figure. With ``config.overrides`` (names given to clusters by number) only the first run is made.

    The k-means partition, and so which groups evidence can name, moves with the clustering seed, and one seed's
    training fails where another's does not. Measured (``benchmarks/training_purity.py``, BENCHMARKS.md), every class
    pure on 80 seeds of the training test's protocol: one run with seed 0 / 1 / 2 / 5 / 10: 57 / 48 / 49 / 56 / 51;
    a vote of 5 runs from seed 0 / 5 / 10: 57 / 57 / 54. Not the default (1): the lateral model lost slalom samples
    with it (0.95 on one test seed) and it costs as many trainings as votes.
    """
    votes = 1 if config.overrides else config.votes  # a user's name is for a cluster of the first clustering
    runs = [_evidence_recipe(windows, declared, background, lean, slopes, replace(config, seed=config.seed + i), say)
            for i in range(votes)]
    if len(runs) == 1:
        return runs[0]
    voted = []
    for r in range(len(windows)):
        stack = np.array([run[0][r] for run in runs])  # runs x windows
        names, index = np.unique(stack, return_inverse=True)
        counts = (index.reshape(stack.shape)[None] == np.arange(len(names))[:, None, None]).sum(axis=1)
        first_is_best = counts.max(axis=0) == counts[index.reshape(stack.shape)[0], np.arange(stack.shape[1])]
        voted.append(np.where(first_is_best, stack[0], names[counts.argmax(axis=0)]))
    return voted, *runs[0][1:]


def _evidence_recipe(windows, declared, background, lean, slopes, config, say):
    """Cluster the pooled windows, name the groups by evidence (``lean``: :func:`_lean_towards_inner`, for
    :func:`~spotfree.naming.rename_upright` and :func:`~spotfree.naming.name_deep_outer`, off when None or their
    ``config`` value is 0) and nest (``slopes``: :func:`_window_slopes`, for :func:`_speed_loss`); return the
    names per recording, the two levels of cluster labels, the cluster names and no warnings."""
    n_classes = len({c for d in declared for c in d})
    pooled = np.hstack([w.matrix for w in windows])
    recording = np.concatenate([np.full(w.matrix.shape[1], r) for r, w in enumerate(windows)])
    slope = None if slopes is None else np.concatenate(slopes)
    say(f"clustering {pooled.shape[1]} windows into {n_classes + config.extra_clusters} groups")
    labels, names = _named_groups(pooled, recording, lean, n_classes + config.extra_clusters, declared, background,
                                  config)
    names = name_nested(pooled, recording, labels, names, declared, background, config.nesting, slope,
                        config.slowing)
    if lean is not None and config.outer_depth:
        names = name_deep_outer(labels, recording, names, declared, background, config.nesting, lean,
                                config.outer_depth)
    names = name_slowing_outer(labels, recording, names, declared, background, config.nesting, slope, config.slowing)
    for cluster, name in config.overrides.items():
        if not 0 <= cluster < len(names):
            raise InputError(f"--name {cluster}={name}: there are only clusters 0..{len(names) - 1}")
        names[cluster] = ClusterName(cluster, name, "named by the user", 1.0, names[cluster].counts)
    per_window = np.array([names[j].name for j in labels], dtype=object)
    level2 = labels.copy()
    specificity = {c: sum(c in d for d in declared) for d in declared for c in d}
    manoeuvres = sorted({n.name for n in names} - {background}, key=lambda c: (-specificity.get(c, 0), c))
    next_label = labels.max() + 1
    for cls in manoeuvres:
        known = [c for c in manoeuvres if specificity.get(c, 0) > specificity.get(cls, 0)] + [background]
        for j in [n.cluster for n in names if n.name == cls and n.rule != "named by the user"]:
            members = np.flatnonzero(labels == j)
            say(f"nesting: checking group {j} ({cls}, {len(members)} windows) against {', '.join(known)}")
            halves = (_cluster(pooled[:, members], 2, config.seed, config.clustering)
                      if len(members) >= 4 * config.window else None)
            parts = [members] if halves is None else [members[halves == 0], members[halves == 1]]
            if halves is not None:
                level2[members[halves == 1]] = next_label
                next_label += 1
            for part in parts:
                explained = _explained_by(pooled, recording, per_window, part, cls, known, config)
                loss = _speed_loss(slope, part, cls, config)
                if explained is not None and explained[0] == background and loss is not None:
                    names.append(ClusterName(int(level2[part[0]]), cls, f"nested: part of group {j}, which "
                                             f"{background} explains ({explained[1]:.0%} of its windows), keeps {cls}: "
                                             f"it loses speed (median GPS trend {loss:+.2f} m/s^2)", 1.0 - explained[1],
                                             []))
                    explained = None
                if explained is not None:
                    per_window[part] = explained[0]
                    names.append(ClusterName(int(level2[part[0]]), explained[0],
                                             f"nested: part of group {j} explained by known class "
                                             f"{explained[0]} ({explained[1]:.0%} of its windows)",
                                             explained[1], []))
                elif halves is not None and names[j].nested:
                    other = np.setdiff1d(members, part)
                    shared = _shared_half(recording, part, other, declared, background, cls)
                    if shared is not None:
                        per_window[part] = background
                        names.append(ClusterName(int(level2[part[0]]), background,
                                                 f"nested: part of group {j} {shared.rule}; the other part keeps "
                                                 f"{cls}", shared.confidence, shared.counts))
    if config.single_manoeuvre:
        per_window, names = single_manoeuvre_names(labels, recording, per_window, declared, background, names)
    split = np.cumsum([0] + [w.matrix.shape[1] for w in windows])
    for r, classes in enumerate(declared):  # a recording holds only the classes it declares
        here = per_window[split[r]:split[r + 1]]
        here[~np.isin(here.astype(str), classes)] = ""
    if config.recluster:
        per_window, level2 = _recluster_background(pooled, recording, per_window, level2, names, declared, background,
                                                   lean, config, say)
    per_recording = [per_window[split[r]:split[r + 1]].astype(str) for r in range(len(windows))]
    levels = [[labels[split[r]:split[r + 1]] for r in range(len(windows))],
              [level2[split[r]:split[r + 1]] for r in range(len(windows))]]
    return per_recording, levels, names, []


def _named_groups(pooled, recording, lean, n_clusters, declared, background, config):
    """``(labels, names)``: the windows ``pooled`` (columns; ``recording``: each one's recording) clustered into
    ``n_clusters`` groups and the groups named by evidence (:func:`~spotfree.naming.name_clusters`), novelty
    (:func:`~spotfree.naming.rename_habits`) and, with a ``lean`` and ``config.upright``, the lean
    (:func:`~spotfree.naming.rename_upright`)."""
    labels = _cluster(pooled, n_clusters, config.seed, config.clustering)
    counts = presence_matrix(labels, recording, labels.max() + 1, len(declared))
    names = name_clusters(counts, declared, background)
    names = rename_habits(pooled, recording, labels, names, declared, background)
    if lean is not None and config.upright:
        names = rename_upright(labels, recording, names, declared, background, config.nesting, lean, config.upright)
    return labels, names


def _recluster_background(pooled, recording, per_window, level2, names, declared, background, lean, config, say):
    """``(per_window, level2)`` with the declared classes that no window was named looked for again among the
    windows named ``background``: those are clustered anew into ``1 + missing + extra_clusters`` groups and named by
    the same evidence (:func:`_named_groups`), and a group named a missing class takes it; its name is appended to
    ``names``. Unchanged when no class is missing.

    The paper's nesting re-clusters what the known classes do not explain; here what the background holds. The hard
    stops are the farthest windows from the rest and k-means can spend most of its groups on them, leaving normal
    braking inside a group of cruising too mixed for its enrichment to show (x2.2 on seed 82 of the training test's
    protocol, whose six sudden-braking groups held 84 windows). Measured (``benchmarks/training_purity.py``,
    BENCHMARKS.md, "A floor under the sudden stop's lean"): every class pure on 438 of seeds 0-479 with it, 432
    without it, and on no block of 160 seeds fewer.
    """
    named = {n for n in per_window if n}
    missing = sorted({c for d in declared for c in d} - named)
    index = np.flatnonzero(per_window == background)
    if not missing or len(index) < 2:
        return per_window, level2
    say(f"re-clustering the {len(index)} background windows for {', '.join(missing)}")
    labels, found = _named_groups(pooled[:, index], recording[index], None if lean is None else lean[index],
                                  1 + len(missing) + config.extra_clusters, declared, background, config)
    per_window, level2 = per_window.copy(), level2.copy()
    first = int(level2.max()) + 1
    for n in found:
        if n.name in missing:
            per_window[index[labels == n.cluster]] = n.name
            level2[index[labels == n.cluster]] = first + n.cluster
            names.append(ClusterName(first + int(n.cluster), n.name, f"re-clustered background: {n.rule}",
                                     n.confidence, n.counts))
    return per_window, level2


def _align_names(names_per_window, experiments, windows, background, config, say) -> tuple[list[np.ndarray],
                                                                                           list[int] | None]:
    """``names_per_window``, each recording's moved earlier by its lag (returned, in windows), 0 to half a window, at
    which its windows named a manoeuvre best follow the channel ``config.timing``; unchanged, and None, when that is
    None or a recording lacks it.

    The braking classes are what the rider does, the lean (the simulator's labels threshold the deceleration the
    lean asks for); the windows that are clustered show mostly the vehicle's answer, which follows the lean by the
    vehicle's response time (the speed-aided acceleration lags the measured ``lean`` by 0.4-0.7 s on the training
    rides of the evaluation's seeds 0-4 and 10-11), so a name given by a window's content comes late. A recording's
    lag maximises the magnitude of the correlation between its windows' manoeuvre indicator (named anything but the
    background) and the channel at their centres; each recording has its own rider. Measured
    (``benchmarks/evaluation_seeds.py``, ``benchmarks/training_purity.py``, BENCHMARKS.md), causal kernel CRC_RLS on
    development / evaluation seeds: 92.36 / 93.62 % without, 93.38 / 93.55 % with one lag pooled over the
    recordings, 93.59 / 93.75 % with a lag per recording; sudden-braking purity of the training test's protocol 1.00
    on 4 of 8 seeds where it was on none.
    """
    channel = config.timing
    if channel is None or any(channel not in e.recording.channels for e in experiments):
        return names_per_window, None
    half = (config.window // 2) // config.train_step
    aligned, lags = [], []
    for per, w, e in zip(names_per_window, windows, experiments):
        reference = np.nan_to_num(e.recording.channels[channel][w.ends - config.window // 2])
        manoeuvre = ((per != background) & (per != "")).astype(float)
        lag = 0
        if reference.std() > 0 and manoeuvre.std() > 0:
            reference = (reference - reference.mean()) / reference.std()
            manoeuvre = (manoeuvre - manoeuvre.mean()) / manoeuvre.std()
            lag = int(np.argmax([abs(np.dot(manoeuvre[k:], reference[:len(reference) - k])) / (len(reference) - k)
                                 for k in range(half + 1)]))
        lags.append(lag)
        aligned.append(np.r_[per[lag:], np.full(lag, "", dtype=per.dtype)])
    say(f"names aligned to {channel}: {', '.join(map(str, lags))} windows earlier")
    return aligned, lags


def _explained_by(pooled, recording, per_window, part, cls, known, config):
    """``(class, fraction)`` when a known class explains most windows of ``part`` under leave-run-out CRC."""
    dictionary_mask = np.isin(per_window, known)
    if not dictionary_mask.any() or len(part) < 2:
        return None
    votes = []
    runs = np.split(part, np.flatnonzero((np.diff(part) > 1) | (np.diff(recording[part]) != 0)) + 1)
    for run in runs:
        own = np.setdiff1d(part, np.arange(run[0] - config.window, run[-1] + config.window + 1))
        if len(own) == 0:
            continue
        atoms = np.r_[own, _balanced(np.flatnonzero(dictionary_mask), per_window, len(own))]
        atom_class = np.r_[np.full(len(own), cls, dtype=object), per_window[atoms[len(own):]]].astype(str)
        votes.append(CRCClassifier().fit(pooled[:, atoms].T, atom_class).predict(pooled[:, run].T))
    if not votes:
        return None
    values, counts = np.unique(np.concatenate(votes), return_counts=True)
    best = int(np.argmax(counts))
    fraction = counts[best] / counts.sum()
    if values[best] != cls and fraction > 0.5:
        return str(values[best]), float(fraction)
    return None


def _shared_half(recording, part, other, declared, background, cls) -> ClusterName | None:
    """The evidence name of ``part``, one half of a group that nesting named ``cls`` (``other`` the other half), when
    it is the background while the other half is enriched for ``cls`` (:data:`~spotfree.naming.ENRICHMENT`), else
    None.

    The paper's second clustering, named by the same evidence as the first. Nesting names the shared group nearest to
    the more specific class; that group may also hold a mode of riding shared by every recording (a vibration, a slow
    stretch), which the split isolates. When neither half is enriched (normal braking as frequent in both rides), the
    split shows nothing and the group keeps its name. Groups named by enrichment are not tested: normal braking also
    occurs in the sudden-braking ride, so a half shared by both rides may be normal braking (tried: normal-braking
    purity 1.00 -> 0.80 on seed 3 of the training test's protocol). Measured (``benchmarks/training_purity.py``,
    BENCHMARKS.md): normal-braking purity 0.67 -> 0.99 and 0.75 -> 1.00 on seeds 0 and 4 of that protocol, the
    evaluation's accuracy unchanged.
    """
    sizes = np.bincount(recording, minlength=len(declared)).clip(min=1)
    other_share = np.bincount(recording[other], minlength=len(declared)) / sizes
    if class_enrichment(other_share, declared, cls) < ENRICHMENT:
        return None
    counts = np.bincount(recording[part], minlength=len(declared))
    named = name_clusters(np.vstack([counts, sizes - counts]), declared, background)[0]
    return named if named.name == background else None


def _balanced(index: np.ndarray, names: np.ndarray, cap: int) -> np.ndarray:
    """At most ``cap`` of the windows ``index`` per name, evenly over time.

    Collaborative representation lets the class with the most atoms represent almost anything (a few hundred
    atoms span the whole window space), so a consistency check compares classes with equal numbers of atoms.
    """
    chosen = []
    for name in np.unique(names[index]):
        own = index[names[index] == name]
        if len(own) > cap:
            own = own[np.linspace(0, len(own) - 1, cap).round().astype(int)]
        chosen.append(own)
    return np.sort(np.concatenate(chosen))


def _paper_recipe(windows, declared, config, say):
    per_recording, level1, level2, names = [], [], [], []
    for r, (w, classes) in enumerate(zip(windows, declared)):
        say(f"paper recipe: recording {r + 1}, two-way split")
        labels = _cluster(w.matrix, 2, config.seed)
        larger = int(np.bincount(labels, minlength=2).argmax())
        per = np.where(labels == larger, classes[0], classes[min(1, len(classes) - 1)]).astype(object)
        second = labels.copy()
        if len(classes) > 2:
            members = np.flatnonzero(labels != larger)
            halves = _cluster(w.matrix[:, members], 2, config.seed)
            keep_half = int(np.bincount(halves, minlength=2).argmax())
            per[members] = np.where(halves == keep_half, classes[-1], "")
            second[members] = 2 + halves
        per_recording.append(per.astype(str))
        level1.append(labels)
        level2.append(second)
        names.append(ClusterName(r, classes[0], "paper: larger cluster of the two-way split", 1.0, []))
    return per_recording, [level1, level2], names, []


def _close_gaps(names_per_window, background, longest: int) -> list[np.ndarray]:
    """Per recording, a run of at most ``longest`` windows named ``background`` between two runs of one manoeuvre
    name takes that name: a stop clustered in pieces, split by a few windows of a group it shares with the
    background, becomes one run, whose centre purification then keeps (windows near a change of name are dropped).
    Measured (``benchmarks/training_purity.py``, BENCHMARKS.md): with ``longest`` 5 and ``inner_quantile`` 0.75, every
    class is pure on 7 of 8 seeds of the training test's protocol, against 6 with the quantile alone (seed 4 had no
    sudden-braking column) and 3 with the gaps closed alone."""
    out = []
    for per in names_per_window:
        per = per.copy()
        starts = np.flatnonzero(np.r_[True, per[1:] != per[:-1]])
        ends = np.r_[starts[1:], len(per)]
        for i in range(1, len(starts) - 1):
            around = per[starts[i - 1]]
            if (ends[i] - starts[i] <= longest and per[starts[i]] == background and around not in ("", background)
                    and per[starts[i + 1]] == around):
                per[starts[i]:ends[i]] = around
        out.append(per)
    return out


def _away_from_home(names_per_window, declared, background) -> list[np.ndarray]:
    """Per recording, its windows named a manoeuvre class of which it is not a home recording (the recordings made
    for the class, :func:`spotfree.naming.class_homes`): there the class is passed through on the way to a more
    specific one, or is a look-alike the clustering grouped with it, so these windows are not its columns (they still
    train the causal columns). Measured on the training test's protocol (``benchmarks/training_purity.py``, seeds
    0-7): the normal-braking columns of the sudden-braking ride were the start of the ride at rest and a stretch of
    cruising on three seeds; without them normal braking is pure (>= 0.98) on seven seeds instead of four."""
    _, home, _ = class_homes(declared)
    away = []
    for r, per in enumerate(names_per_window):
        foreign = [c for c, h in home.items() if c != background and h and r not in h]
        away.append(np.isin(per, foreign))
    return away


def _timing_offset(experiments, windows, config) -> list[np.ndarray] | None:
    """Per recording, ``x_k - m`` at its window centres, ``x`` the timing channel ``config.timing`` and ``m`` its
    median over the recording (for the lean: radians from the rider's usual stance); None when ``timing`` is None or
    a recording lacks it. Its magnitude is the window's depth."""
    channel = config.timing
    if channel is None or any(channel not in e.recording.channels for e in experiments):
        return None
    traces = [np.asarray(e.recording.channels[channel], dtype=float) for e in experiments]
    return [np.nan_to_num(t[w.ends - config.window // 2] - np.nanmedian(t)) for t, w in zip(traces, windows)]


def _lean_towards_inner(offset, declared, nesting) -> np.ndarray | None:
    """Every window's timing offset (:func:`_timing_offset`), pooled over the recordings, signed so that the deepest
    window of the recordings declaring an inner class of ``nesting`` is positive, in units of its recording's median
    ``|offset|``: the depth :func:`spotfree.naming.rename_upright` and :func:`spotfree.naming.name_deep_outer` read.
    None without an offset or such a recording."""
    inner = {i for i, _ in nesting}
    homes = [x for x, classes in zip(offset or [], declared) if inner & set(classes) and len(x)]
    if not homes:
        return None
    deepest = max(homes, key=lambda x: np.abs(x).max())
    sign = np.sign(deepest[np.argmax(np.abs(deepest))]) or 1.0
    return np.concatenate([sign * x / max(np.median(np.abs(x)), 1e-12) if len(x) else x for x in offset])


def _deepest_inner(names_per_window, offset, declared, config) -> list[np.ndarray]:
    """``names_per_window`` with, in each recording that declares the inner class of a nesting pair, the windows at
    its deepest named that class, when the deepest goes beyond every window of the recordings that do not declare it:
    with ``d`` the timing depth (:func:`_timing_offset`) and ``L`` its maximum over those other recordings, window
    ``k`` is renamed when ``d_k > L`` and ``d_k >= inner_depth * max d``, and so are the purification margin's
    windows on each side of them (:func:`_change_margin`), which purification drops, so that the deepest windows
    are kept. Unchanged when ``deepest_inner`` is off, the timing channel is missing, or every recording declares
    the inner class.

    The inner class is the extreme of the outer one (a hard stop is a deeper lean than any normal stop), yet it
    fills a second or two of a ride, and the clustering may leave it no group of its own or name its group after the
    lean-in shared with normal braking (no sudden-braking column on 10 of 80 seeds of the training test's protocol).
    Measured (``benchmarks/training_purity.py``, BENCHMARKS.md) before :func:`~spotfree.naming.rename_upright`, every
    class pure on seeds 0-79 / 80-159 of the training test's protocol: 65 / 62 with it, 60 / 58 without it, 57 / 56
    without it and without :func:`~spotfree.naming.name_deep_outer`; on seeds 160-239, which played no part in
    designing either rule, 69 with both and 57 with neither. Without the margin's windows (scratch): 60 / 59 with
    this rule alone; renaming every window beyond ``L`` (scratch): 66 / 54.
    """
    if not config.deepest_inner or offset is None:
        return names_per_window
    depth = [np.abs(x) for x in offset]
    out = [per.astype(object) for per in names_per_window]  # a fixed-width str array would cut a longer name
    for inner, _ in config.nesting:
        others = [d for d, classes in zip(depth, declared) if inner not in classes and len(d)]
        if not others:
            continue
        limit = max(d.max() for d in others)
        for per, d, classes in zip(out, depth, declared):
            if inner in classes and len(d):
                deepest = (d > limit) & (d >= config.inner_depth * d.max())
                per[np.convolve(deepest, np.ones(2 * _change_margin(config) + 1), "same") > 0] = inner
    return [per.astype(str) for per in out]


def _shallow_inner(names_per_window, offset, config) -> list[np.ndarray]:
    """Per recording, the windows named the inner class of a nesting pair whose centre lies where the timing depth
    (:func:`_timing_offset`) is shallow: window ``k`` of a run is shallow when ``d_k < inner_depth * max_run d`` or
    ``d_k < inner_floor * max_inner d``, the latter the deepest window of the recording named the inner class. Called
    with the names of the windows purification kept, so that the deepest kept window always passes. All False when
    both shares are 0 or a recording lacks the timing channel.

    The inner class is the extreme of the outer one (the hard plateau of a stop that passes through normal braking),
    and its run of names spans every window holding part of it, half a window on each side of the plateau; the
    windows centred on those sides hold mostly the outer class, yet look as unlike the other recordings as the
    plateau does, so neither the margin nor the novelty against the other recordings tells them apart. The rider's
    lean does: it is deepest on the plateau. Designed on seed 8 of the training test's protocol (its sudden-braking
    columns began 10 samples before the plateau); measured on 80 seeds of it (``benchmarks/training_purity.py``,
    BENCHMARKS.md): every class pure on 57 instead of 49 without it (seeds 40-79, which played no part in designing
    it: 28 instead of 26), and on 57 for depths 0.7 and 0.9 as well; centred and causal accuracy on the evaluation's
    seeds unchanged.

    The floor is for the stops that only just reach the inner class, and for a normal stop close to it in the same
    ride (the paper's near-sudden stop): the lean's deepest window of such a run is still the outer class's lean-in,
    since the measured lean runs a few samples ahead of the lean the classes are defined by. Measured on the training
    test's protocol (BENCHMARKS.md, "A floor under the sudden stop's lean"): every class pure on 438 of seeds 0-479
    with 0.9, 429 with 0.8, 406 without the floor; 0.9 chosen on seeds 0-319. Taken over the kept windows instead of
    every named one: sudden braking kept a column on 3 more seeds, where purification had dropped the deepest windows
    of the ride.

    A window is also shallow when the window before it (``train_step`` samples earlier, named or not) is shallow by
    its run's thresholds, unless that leaves the recording no window of the class: the lean leads, so at a stop's
    onset the first deep window can still be centred on the outer class (seeds 320, 383 and 476 of the training
    test's protocol: a sudden-braking column one sample before the plateau). Measured with :func:`_purify`'s keep of
    the inner class's windows (``benchmarks/training_purity.py``, BENCHMARKS.md, "The sudden stop's onset"): every
    class pure on 469 of seeds 0-479 and 307 of seeds 480-799, against 464 and 301 without either, 466 and 306 with
    the keep alone, 466 and 303 with this rule alone; without the fallback it lost the only sudden-braking column of
    9 seeds.
    """
    shallow = [np.zeros(len(per), dtype=bool) for per in names_per_window]
    if offset is None or config.inner_depth == config.inner_floor == 0:
        return shallow
    for per, d, out in zip(names_per_window, map(np.abs, offset), shallow):
        for inner in {i for i, _ in config.nesting}:
            named = per == inner
            if not named.any():
                continue
            floor = config.inner_floor * d[named].max()
            plain, onset = np.zeros(len(per), dtype=bool), np.zeros(len(per), dtype=bool)
            for start, stop in true_runs(named):
                low = d < max(config.inner_depth * d[start:stop].max(), floor)
                plain[start:stop] = low[start:stop]
                onset[start:stop] = low[start:stop] | np.r_[False, low[:-1]][start:stop]
            out |= onset if (named & ~onset).any() else plain
    return shallow


def _leaning_background(names_per_window, lean, background, config) -> list[np.ndarray]:
    """Per recording, the windows named ``background`` that lean towards the hardest stop by more than
    ``config.background_lean`` times the recording's usual depth (``lean``: :func:`_lean_towards_inner`, pooled over
    the recordings in order); all False when the share is 0 or there is no lean.

    The background's groups also hold the gentlest braking, which no group of its own separated from cruising; its
    windows are a few percent of the background's, yet they are among the 600 evenly spread columns, and a
    background class is represented as well without them. Measured (``benchmarks/training_purity.py``, BENCHMARKS.md,
    "A floor under the sudden stop's lean"): the impure background columns of seed 225 of the training test's
    protocol lean x1.06-x1.79 of the usual depth; every class pure on 445 of seeds 0-479 with 0.6, 444 with 1.0, 438
    without, none made impure; on held-out seeds 480-639 the background's purity rose on each of the 4 seeds where it
    was below 0.98 (0.840-0.953 -> 0.948-0.992), none of which another class left pure.
    """
    if lean is None or config.background_lean == 0:
        return [np.zeros(len(per), dtype=bool) for per in names_per_window]
    split = np.cumsum([0] + [len(per) for per in names_per_window])
    return [(per == background) & (lean[split[r]:split[r + 1]] > config.background_lean)
            for r, per in enumerate(names_per_window)]



def _window_slopes(experiments, windows, config) -> list[np.ndarray] | None:
    """Per recording, the GPS speed's trend (m/s^2, :func:`speed_slope`) around each window's centre, NaN throughout
    a recording without a ``speed`` channel; None when no recording has one or ``config.slowing`` is 0."""
    if config.slowing == 0 or all("speed" not in e.recording.channels for e in experiments):
        return None
    unknown = np.full(0, np.nan)
    return [speed_slope(np.asarray(e.recording.channels.get("speed", unknown), dtype=float), e.recording.rate,
                        w.ends - config.window // 2) for e, w in zip(experiments, windows)]


def _speed_loss(slope, part, cls, config) -> float | None:
    """The median GPS trend (m/s^2) of the windows ``part`` when ``cls`` is a class of a nesting pair (braking) and
    they lose speed (median at most ``-config.slowing``), else None; ``slope`` pooled :func:`_window_slopes` or None.

    The nesting check gives a group named braking to the background when a linear representation by the background's
    windows explains it, yet such a group can still be braking (normal braking was left with no column on seeds 246
    and 456 of the training test's protocol). Measured (``benchmarks/training_purity.py``, BENCHMARKS.md, "A braking
    must lose speed"): every class pure on 464 of seeds 0-479 of the training test's protocol with it, 461 without;
    301 of seeds 480-799, held out while it was designed, against 298; none made impure."""
    if slope is None or cls not in _braking(config):
        return None
    median = median_trend(slope, part)
    return median if median <= -config.slowing else None


def _speed_disagrees(names_per_window, slopes, background, declared, config) -> list[np.ndarray]:
    """Per recording, the windows whose GPS trend (``slopes``: :func:`_window_slopes`, m/s^2; a window whose trend is
    unknown passes) contradicts their name: named a class of a nesting pair (braking) where the speed falls by less
    than ``config.slowing``, or named ``background`` where it falls by that much or more and a braking class is
    declared; all False when ``slopes`` is None.

    A braking loses speed. The groups named braking also hold steady cruising that the speed-aided ``acc_long``
    reads as braking (-0.5 to -1.4 m/s^2) and the rider's gentle speed changes (0.15-0.35 m/s^2 in the simulator),
    and neither the lean nor the margins tell them apart; the GPS speed does. Measured on the normal-braking columns
    of seeds 0-399 of the training test's protocol without this rule (``benchmarks/training_purity.py --trend``,
    BENCHMARKS.md, "A braking must lose speed"): the trend was -0.44 m/s^2 or steeper at 95 % of the 16165 right ones,
    and none of the 184 wrong ones was below -0.47 (median -0.07).

    The background, in turn, holds braking that no group separated from cruising, or that the naming gave it with a
    mixed group (seed 409: 41 normal-braking windows in a group of 168 that stays upright). Cruising loses speed that
    fast at under 1 % of its windows (the 1 % quantile of the trend under right cruising columns was -0.37 m/s^2),
    so it loses little. Measured (``benchmarks/training_purity.py``, BENCHMARKS.md, "The GPS speed in the naming and
    in the background"), with :func:`~spotfree.naming.name_nested`'s own GPS check: every class pure on 475 of seeds
    0-479 of the training test's protocol and 314 of seeds 480-799, against 473 and 310 without this part; with this
    part alone 470 and 309."""
    if slopes is None:
        return [np.zeros(len(per), dtype=bool) for per in names_per_window]
    braking = _braking(config)
    slowing_background = any(c in braking for classes in declared for c in classes)
    return [(np.isin(per, list(braking)) & (slope > -config.slowing))
            | (slowing_background & (per == background) & (slope <= -config.slowing))
            for per, slope in zip(names_per_window, slopes)]


def _braking(config) -> set[str]:
    """The classes of ``config.nesting`` pairs, inner and outer: the braking classes, which must lose speed."""
    return {c for pair in config.nesting for c in pair}


def _change_margin(config) -> int:
    """Windows on each side of a change of name that purification drops (``config.margin``; default half a window)."""
    return config.margin if config.margin is not None else max(1, config.window // (2 * config.train_step))


def _purify(windows, names_per_window, background, config, say) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Keep windows away from a change of name (a manoeuvre class that would keep none keeps the centres of its runs,
    :func:`_short_run_centres`; not with ``background`` None, the paper's recipe) and consistent with the rest of the
    dictionary; return the kept masks and every window's margin (:func:`_run_margins`; 1 where no other name exists
    to test against, and for a class's only run, which leave-run-out would otherwise drop whole, the class then having
    no atom to be nearest to: keeping it made 9 more of seeds 0-479 of the training test's protocol pure, 6 by a
    normal-braking run that nesting, the lean or a second clustering named, 3 by a sudden stop; BENCHMARKS.md).

    The inner class of a nesting pair keeps its windows whatever their margin (which still ranks them for
    ``inner_quantile``): a ride's hard stops differ in depth, and with one or two other stops to be tested against,
    the plateau of the hardest lies nearer to normal braking (seed 320 of the training test's protocol: margins down
    to -0.5 on the plateau, so that only the stop's onset was kept); its depth (:func:`_shallow_inner`) chooses its
    columns instead (not in the paper's recipe, ``background`` None). Measured with the onset rule: see
    :func:`_shallow_inner`."""
    margin = _change_margin(config)
    kept = []
    for per in names_per_window:
        named = per != ""
        change = np.flatnonzero(per[1:] != per[:-1]) + 1
        near = np.zeros(len(per), dtype=bool)
        for c in change:
            near[max(0, c - margin):c + margin] = True
        kept.append(named & ~near)
    if background is not None:
        kept = _short_run_centres(names_per_window, kept, background)
    say("purifying: leave-run-out consistency of the kept windows")
    pooled = np.hstack([w.matrix for w in windows])
    names = np.concatenate(names_per_window)
    keep = np.concatenate(kept)
    margins = np.zeros(len(names))
    tested = np.zeros(len(names), dtype=bool)
    recording = np.concatenate([np.full(w.matrix.shape[1], r) for r, w in enumerate(windows)])
    index = np.flatnonzero(keep)
    if len(np.unique(names[index])) > 1:
        runs = np.split(index, np.flatnonzero((np.diff(index) > 1) | (np.diff(recording[index]) != 0)
                                              | (names[index][1:] != names[index][:-1])) + 1)
        for run in runs:
            others = np.setdiff1d(index, np.arange(run[0] - config.window, run[-1] + config.window + 1))
            if len(np.unique(names[others])) < 2 or names[run[0]] not in names[others]:
                continue  # nothing to test against, or the class's only run: it cannot be left out
            others = _balanced(others, names, np.unique(names[others], return_counts=True)[1].min())
            margins[run] = _run_margins(pooled, others, names, run)
            tested[run] = True
    hard = [inner for inner, _ in config.nesting] if background is not None else []
    keep &= ~tested | (margins > 0) | np.isin(names, hard)
    margins[~tested] = 1.0
    split = np.cumsum([0] + [w.matrix.shape[1] for w in windows])
    return ([keep[split[r]:split[r + 1]] for r in range(len(windows))],
            [margins[split[r]:split[r + 1]] for r in range(len(windows))])


def _short_run_centres(names_per_window, kept, background) -> list[np.ndarray]:
    """``kept`` with the centre window of every run of a manoeuvre class that keeps no window at all: each of its runs
    is shorter than the windows dropped on both sides of a change of name, so every window was dropped.

    A group can hold only the deepest seconds of each stop (the rest of the stop clustered with cruising), in runs of
    2-6 training windows; their centres lie well inside the stop. Measured (``benchmarks/training_purity.py``,
    BENCHMARKS.md, "A floor under the sudden stop's lean"): every class pure on 448 of seeds 0-479 of the training
    test's protocol with it, 445 without (normal braking given columns on seeds 103, 173 and 198), none made impure;
    on seeds 480-639, 148 against 145, none made impure.
    """
    have = {n for per, keep in zip(names_per_window, kept) for n in per[keep]}
    out = []
    for per, keep in zip(names_per_window, kept):
        keep = keep.copy()
        change = np.flatnonzero(per[1:] != per[:-1]) + 1
        for start, stop in zip(np.r_[0, change], np.r_[change, len(per)]):
            if per[start] not in ("", background) and per[start] not in have:
                keep[(start + stop) // 2] = True
        out.append(keep)
    return out


def _run_margins(pooled, atoms, names, run, k: int = 5) -> np.ndarray:
    """Margin of each window ``y`` of ``run`` against the ``atoms``: with ``d_c`` the mean distance from ``y`` to its
    ``k`` nearest atoms of class ``c`` (:class:`~spotfree.classify.neighbours.NearestColumnsClassifier`),
    ``(min_{other} d_c - d_own) / (min_{other} d_c + d_own)`` in [-1, 1], positive when the window's own name lies
    nearest; ``-1`` when its name is not among the atoms' names."""
    clf = NearestColumnsClassifier(n_neighbors=k).fit(pooled[:, atoms].T, names[atoms])
    own = np.flatnonzero(clf.classes_ == names[run[0]])
    if len(own) == 0:
        return np.full(len(run), -1.0)
    distance = clf.decision_function(pooled[:, run].T)
    other = np.delete(distance, own[0], axis=1).min(axis=1)
    return (other - distance[:, own[0]]) / np.maximum(other + distance[:, own[0]], 1e-12)


def _causal_columns(windows, names_per_window, kept, classes, depth, config):
    """``(dictionary, column_class)`` for causal classification, or None: every named training window, named by the
    window centred on its last sample (a window's name describes its centre; a causal window labels its end), at
    most ``max_columns`` per class evenly over time. Windows that straddle a change of name come in, named by the
    state they end in. With ``config.causal_onsets`` so do those ending where purification dropped the centred window
    (``kept``; near a change of name): the first moments of each manoeuvre, which a causal window must learn to call.
    Measured (``benchmarks/evaluation_seeds.py``, BENCHMARKS.md), causal kernel CRC_RLS (32 landmarks) over all
    tests: without them 90.80 % on development seeds 10-14 and 91.44 % on evaluation seeds 0-4, with them 91.53 % and
    92.57 %. Against centre-named columns (``benchmarks/causal_relabel.py``): sudden braking labelled 0.15 to 0.45 s
    sooner."""
    shift = (config.window // 2) // config.train_step
    if shift == 0:
        return None
    columns, column_class = [], []
    for w, per, keep in zip(windows, names_per_window, kept):
        ends_kept = np.ones(len(per) - shift, dtype=bool) if config.causal_onsets else keep[shift:]
        for k in np.flatnonzero((per[:len(per) - shift] != "") & (per[shift:] != "") & ends_kept):
            columns.append(w.matrix[:depth, k])
            column_class.append(classes.index(per[k + shift]))
    if not columns:
        return None
    chosen, _ = _cap(np.array(column_class), np.ones(len(columns)), len(classes), config.max_columns, 0.0)
    return np.array(columns).T[:, chosen], np.array(column_class)[chosen]


def _causal_names(names_per_window, declared, classes, config) -> list[np.ndarray]:
    """The window names the causal columns take: ``names_per_window`` with, for every nesting pair ``(inner, outer)``
    declared in a recording, the first and last half window of each run named ``inner`` named ``outer``.

    A manoeuvre shorter than a window shows in every window that holds part of it, so the run of windows named for
    it spans it and half a window on each side, and there the manoeuvre passes through the outer class (the lean
    building up and easing off around a hard stop). Runs no longer than a window are left as they are. Measured
    (``benchmarks/evaluation_seeds.py``, BENCHMARKS.md), causal kernel CRC_RLS with 64 landmarks: 91.81 % -> 92.36 %
    on development seeds 10-14, and with cuts of 0.4 / 0.6 of a window 92.16 / 92.48 %; once names are aligned to
    the lean (:func:`_align_names`) the cut is within noise, kept because it names these stretches as the truth
    does. A pair whose outer class is not among ``classes`` (no window was named it) keeps its runs whole."""
    half = (config.window // 2) // config.train_step
    out = []
    for per, here in zip(names_per_window, declared):
        per = per.copy()
        for inner, outer in config.nesting:
            if inner not in here or outer not in here or outer not in classes:
                continue
            for start, stop in true_runs(per == inner):
                if stop - start > 2 * half:
                    per[start:start + half] = outer
                    per[stop - half:stop] = outer
        out.append(per)
    return out


def _cap(column_class, column_margin, n_classes, max_columns, min_margin,
         quantile=None) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """The index of the columns to keep, in the order they were found in (recording, then time): per class ``i``,
    those with a margin of at least ``min_margin`` (all of the class's columns when none has) and of those, when
    ``quantile[i] > 0``, the ones at or above that quantile of their margins; at most ``max_columns`` of them evenly
    spread over that order. Also ``(class, columns kept)`` for the classes that fell back to their less confident
    columns.

    The quantile is for the inner class of a nesting pair (``TrainingConfig.inner_quantile``): a hard stop is
    shorter than a window, so its windows also hold the braking around it, and those nearest that braking are its
    least confident. Measured with columns from home recordings only: on the training test's protocol
    (``benchmarks/training_purity.py``, seeds 0-7) the top quarter (0.75) makes sudden braking pure (1.00) on every
    seed with a column instead of 0.77-0.92 on three; but on the evaluation's protocol the centred labels then find
    fewer sudden-braking samples (recall, development seeds 10-14: kernel CRC_RLS 90.8 -> 75.5 %, CRC_RLS 84.9 ->
    46.6 %). It is on by default for the purity the training is asked for (with :func:`_close_gaps`); causal labels
    use other columns and do not change. The outer class has its own quantile (``TrainingConfig.outer_quantile``):
    normal braking is declared by every recording, so its name rests on enrichment alone and its groups also take
    the normal-braking rider's gentle slow-downs, its least confident columns. Measured on 80 seeds of the training
    test's protocol and 12 of the evaluation's (``benchmarks/training_purity.py``, ``benchmarks/evaluation_seeds.py``,
    BENCHMARKS.md): every class pure on 50 / 57 / 59 seeds with 0 / 0.5 / 0.75, centred CRC_RLS on the evaluation
    seeds with correct names 89.7 / 88.1 / 84.3 % (the fewer normal-braking columns against 600 of cruising, the
    fewer normal-braking labels); 0.5 is the default.
    """
    chosen, fallback = [], []
    for i in range(n_classes):
        index = np.flatnonzero(column_class == i)
        confident = index[column_margin[index] >= min_margin]
        if len(confident) and quantile is not None and quantile[i] > 0:
            confident = confident[column_margin[confident] >= np.quantile(column_margin[confident], quantile[i])]
        if len(confident):
            index = confident
        elif len(index):
            fallback.append(i)
        if len(index) > max_columns:
            index = index[np.linspace(0, len(index) - 1, max_columns).round().astype(int)]
        chosen.append(index)
    chosen = np.sort(np.concatenate(chosen)) if chosen else np.empty(0, dtype=int)
    return chosen, [(i, int((column_class[chosen] == i).sum())) for i in fallback]


def dictionary_purity(result: TrainingResult, experiments: list[TrainingExperiment]) -> dict[str, float]:
    """Per class, the fraction of dictionary columns whose window centre has that class in the hidden ``label``.

    For evaluation only: training itself never reads ``label``.
    """
    model = result.model
    truth = np.array([
        experiments[r].recording.truth["label"][end - model.window // 2] for r, end in result.column_source
    ])
    named = np.array(model.classes)[model.column_class]
    return {c: float(np.mean(truth[named == c] == c)) for c in model.classes if (named == c).any()}
