"""Naming clusters by evidence across training recordings.

Each training recording ``r`` declares only the set ``D_r`` of classes that occur somewhere in it. Clustering gives
every window a cluster ``j``; ``N[j, r]`` counts the windows of cluster ``j`` in recording ``r`` and
``S[j, r] = N[j, r] / |r|`` is its share of that recording. The *home* of a class ``X`` is the set of recordings made
for it: those declaring ``X`` where ``X`` is the most specific declared class (declared in the fewest recordings).

1. **Where the cluster lives.** It is substantially present in ``r`` when ``S[j, r] >= max_r S[j, r] / E_min``
   (:data:`ENRICHMENT`); a few windows elsewhere (a near-sudden normal stop in the normal-braking ride, say) do
   not count against a name. Its candidates are the non-background classes declared in every recording where it is
   substantially present.
2. **Enrichment.** For a candidate ``X``, ``E_X = mean_{home(X)} S[j, r] / mean_{outside} S[j, r]`` (infinite when
   the cluster occurs only at home: the "present only where ``X`` is declared" case). Outside are the recordings
   that do not declare ``X``; when every recording declares it, those outside its home (where ``X`` occurs but is
   not the most specific class, so it is expected to take less of the time). The cluster takes the candidate
   with the largest ``E_X`` if ``E_X >= E_min``; confidence ``1 - 1 / E_X``.
3. **Background.** Otherwise the cluster is the background class (the class declared in every recording, the first
   such in declaration order unless the caller names it): a turn, a bump or a change of speed occurs in every ride
   alike, so no confounder is forced into a manoeuvre class. Confidence ``1 - max_X E_X / E_min``.

A cluster present in recordings that share no declared class cannot be any one class and goes to the background.

4. **Novelty** (:func:`rename_habits`, needs the windows). A cluster enriched where ``X`` is declared may be one
   rider's habit (a brisker acceleration) rather than ``X``: its windows then have near neighbours among the
   background's windows (and those of the other classes declared wherever ``X`` is) in the recordings without
   ``X``, which windows of ``X`` cannot have. Such a cluster goes to the background.
5. **Nesting** (:func:`name_nested`, needs the windows and the caller's ``nesting`` pairs). A class declared in
   every recording may take no group by enrichment (normal braking when the normal-braking ride brakes no more
   often than the sudden-braking ride, whose stops pass through it). When the caller says that a more specific
   class passes through it, the shared group nearest to that class's windows takes its name (the paper's nesting:
   its second clustering splits the normal braking off the sudden stops). Measured on the evaluation's protocol,
   seed 4: no normal-braking group before, 77 columns of purity 0.97 after.
6. **One manoeuvre per recording** (:func:`single_manoeuvre_names`, on request). A group that is absent from
   every recording declaring only the background (its share there below ``max_r S[j, r] / E_min``) is not the
   background, even when rule 3 named it so because it lives in recordings that share no manoeuvre (gentle turns,
   sharp turns and slaloms, each from its own rides, in one group of turning windows). In a recording that declares
   one manoeuvre besides the background, its windows take that manoeuvre's name; elsewhere they stay unnamed.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial.distance import cdist

from spotfree.errors import InputError


@dataclass
class ClusterName:
    """The name of one cluster and the evidence for it."""

    cluster: int
    name: str
    rule: str
    confidence: float
    counts: list[int] = field(default_factory=list)
    nested: bool = False
    """Named by :func:`name_nested` (nearness to a more specific class), not by evidence across recordings."""


def background_class(declared: list[list[str]], background: str | None = None) -> str:
    """The background class: ``background`` if given (it must be declared everywhere), else the first class
    declared in every recording."""
    common = [c for c in declared[0] if all(c in d for d in declared)]
    if background is not None:
        if background not in common:
            raise InputError(
                f"background class '{background}' is not declared in every --experiment; add it to each declaration"
            )
        return background
    if not common:
        raise InputError(
            "no class is declared in every --experiment, so nothing can be named the background; declare the "
            "background class (e.g. cruising) in each recording"
        )
    return common[0]


def presence_matrix(labels: np.ndarray, recording: np.ndarray, n_clusters: int, n_recordings: int) -> np.ndarray:
    """``N[j, r]``: windows of cluster ``j`` in recording ``r``."""
    counts = np.zeros((n_clusters, n_recordings), dtype=int)
    np.add.at(counts, (labels, recording), 1)
    return counts


ENRICHMENT = 3.0
"""``E_min``. Measured on simulated braking rides (k-means, 10 groups of 2 s ``acc_long`` windows, seeds 0-4): groups
that were mostly normal braking were enriched x3.5 to x47 in the normal-braking ride, cruising groups at most x2.1."""


def name_clusters(
    counts: np.ndarray,
    declared: list[list[str]],
    background: str,
    enrichment: float = ENRICHMENT,
) -> list[ClusterName]:
    """Name every cluster from its counts per recording (rules in the module docstring)."""
    n_clusters, n_recordings = counts.shape
    share = counts / counts.sum(axis=0).clip(min=1)
    n_declaring, home, lacking = class_homes(declared)
    names = []
    for j in range(n_clusters):
        row = counts[j]
        if row.sum() == 0:
            names.append(ClusterName(j, background, "empty", 0.0, row.tolist()))
            continue
        present = np.flatnonzero(share[j] >= share[j].max() / enrichment)
        common = set.intersection(*(set(declared[r]) for r in present))
        if not common:
            names.append(ClusterName(j, background, "present in recordings that share no declared class", 0.5,
                                     row.tolist()))
            continue
        ratios = {c: _enrichment(share[j], home[c], lacking[c]) for c in sorted(common - {background}) if home[c]}
        best = max(ratios, key=lambda c: (ratios[c], -n_declaring[c]), default=None)
        if best is not None and ratios[best] >= enrichment:
            ratio = ratios[best]
            rule = (f"present only where {best} is declared" if np.isinf(ratio)
                    else f"enriched x{ratio:.1f} in the recordings made for {best}")
            names.append(ClusterName(j, best, rule, 1.0 if np.isinf(ratio) else float(1 - 1 / ratio), row.tolist()))
        else:
            top = ratios.get(best, 0.0)
            note = f" (at most x{top:.1f}, for {best})" if best is not None else ""
            names.append(ClusterName(j, background, f"shared by the recordings, not a declared manoeuvre{note}",
                                     float(max(0.0, 1 - top / enrichment)), row.tolist()))
    return names


def class_homes(declared: list[list[str]]) -> tuple[dict[str, int], dict[str, list[int]], dict[str, list[int]]]:
    """Per class: the number of recordings declaring it, its home recordings and the recordings lacking it."""
    n_declaring = {c: sum(c in d for d in declared) for d in declared for c in d}
    home = {
        c: [r for r, d in enumerate(declared) if c in d and n_declaring[c] == min(n_declaring[k] for k in d)]
        for c in n_declaring
    }
    lacking = {c: [r for r, d in enumerate(declared) if c not in d] for c in n_declaring}
    return n_declaring, home, lacking


def class_enrichment(share: np.ndarray, declared: list[list[str]], name: str) -> float:
    """``E_X`` of the module docstring for class ``name``, from a group's ``share`` of each recording."""
    _, home, lacking = class_homes(declared)
    return _enrichment(np.asarray(share, dtype=float), home[name], lacking[name]) if home[name] else 0.0


def _enrichment(share: np.ndarray, inside: list[int], lacking: list[int]) -> float:
    """``mean share[inside] / mean share[outside]``: outside are the recordings ``lacking`` the class, or when every
    recording declares it, those not ``inside`` (infinite when the outside share is zero, 0 with no outside)."""
    outside = lacking or [r for r in range(len(share)) if r not in inside]
    if not outside:
        return 0.0
    num, den = float(share[inside].mean()), float(share[outside].mean())
    return np.inf if den == 0 else num / den


NOVELTY = 2.0
"""Novelty a group must have to keep a name given by enrichment (:func:`rename_habits`). Measured on the training
rides of the evaluation (seeds 1 and 4, where habits had been named sudden braking) as the median distance of a
group's windows to the nearest window of the other ride, over the same for the background: groups of sudden braking
3.5 to 6, the habit groups 0.9 to 1.0."""


def rename_habits(pooled: np.ndarray, recording: np.ndarray, labels: np.ndarray, names: list[ClusterName],
                  declared: list[list[str]], background: str) -> list[ClusterName]:
    """``names`` (one per cluster, by cluster number) with every group named a class ``X`` by evidence whose windows
    are not novel where ``X`` does not occur renamed to the background. ``pooled``: the windows as columns;
    ``recording`` and ``labels``: each window's recording and cluster.

    A group enriched in the recordings of ``X`` may be one rider's habit (a brisker acceleration) instead of ``X``.
    The reference are the windows, in the recordings without ``X``, of the classes declared wherever ``X`` is (its
    companions: the background, and normal braking for sudden braking): a window of ``X`` has no near neighbour
    among them, a habit does, as close as the background's own windows have. Novelty of a group: the median over its
    windows of the distance to the nearest reference window; the group keeps its name when that is at least
    :data:`NOVELTY` times the same median over the background's windows of the other recordings. Other manoeuvres
    of those recordings are no reference: they may move like ``X`` (a hand moving right to straight and one moving
    straight to left). Classes declared in every recording are not tested (no recording lacks them).
    """
    background_windows = np.isin(labels, [n.cluster for n in names if n.name == background])
    out = list(names)
    for n in names:
        without = [r for r, d in enumerate(declared) if n.name not in d]
        if n.name == background or not without or n.rule in ("empty", "named by the user"):
            continue
        members = labels == n.cluster
        companions = {c for c in set.intersection(*(set(d) for d in declared if n.name in d)) if c != n.name}
        reference = np.isin(recording, without) & np.isin(labels, [m.cluster for m in names if m.name in companions])
        own = _median_nearest(pooled, members & ~reference, reference)
        usual = _median_nearest(pooled, background_windows & ~reference, reference)
        if np.isfinite(own) and np.isfinite(usual) and own < NOVELTY * usual:
            out[n.cluster] = ClusterName(n.cluster, background,
                                         f"{n.rule}, but not novel where {n.name} is absent (nearest-window distance "
                                         f"{own:.2f}, background {usual:.2f}): a habit, not {n.name}",
                                         float(1 - own / (NOVELTY * usual)), n.counts)
    return out


def _median_nearest(pooled, rows, reference) -> float:
    """Median over the windows ``rows`` (mask) of the distance to the nearest window of ``reference`` (mask)."""
    if not rows.any() or not reference.any():
        return np.nan
    return float(np.median(cdist(pooled[:, rows].T, pooled[:, reference].T).min(axis=1)))


UPRIGHT = 0.5
"""Lean a group named a class of a nesting pair must reach, at its median in that class's home recordings and in units
of each recording's median depth, to keep the name (:func:`rename_upright`). Measured on the training test's protocol
(seeds 0-159, the groups enrichment named normal braking): of the 31 with a median below 0.5, 29 were mostly
cruising; of the 128 at 0.5 or more, one was."""


def rename_upright(labels: np.ndarray, recording: np.ndarray, names: list[ClusterName], declared: list[list[str]],
                   background: str, nesting: Sequence[tuple[str, str]], depth: np.ndarray,
                   least: float = UPRIGHT) -> list[ClusterName]:
    """``names`` with every group named a class of ``nesting`` (inner or outer) by evidence renamed to the background
    when it does not lean towards the stop: the median of ``depth`` (as in :func:`name_deep_outer`) over its windows
    in the class's home recordings (:func:`class_homes`) is below ``least``.

    Braking is a lean, a hard stop the deepest; a group of upright windows is a way of riding (one rider's cruising,
    steadier or faster than the other's) that enrichment credited to the recording it is common in. Named sudden
    braking, such a group fills the sudden-braking ride's dictionary with cruising (sudden-braking purity 0.00 on 5
    of 160 seeds of the training test's protocol); named normal braking, it takes that name from the group that
    leans (normal-braking purity 0.00 on 2). Groups named by the user or by nesting are left as they are. Measured
    (``benchmarks/training_purity.py``, BENCHMARKS.md), every class pure on 136 of seeds 0-159 with it, 127 without
    (``least`` 0.3 / 0.75 / 1.0: 136 / 137 / 128; for the inner class only / the outer only: 132 / 131); on seeds
    160-239 69 either way; on seeds 240-319, which played no part in designing it, 74 against 69.
    """
    out = list(names)
    _, home, _ = class_homes(declared)
    classes = {c for pair in nesting for c in pair} - {background}
    for n in names:
        if n.name not in classes or n.nested or n.rule in ("empty", "named by the user") or not home.get(n.name):
            continue
        median = _median_depth(depth, (labels == n.cluster) & np.isin(recording, home[n.name]))
        if median < least:
            out[n.cluster] = ClusterName(
                n.cluster, background, f"{n.rule}, but upright in the recordings made for {n.name} (median lean "
                f"x{median:.2f} of the usual depth, below x{least:g}): a way of riding, not {n.name}",
                float(min(1.0, (least - median) / least)), n.counts)
    return out


def _median_depth(depth: np.ndarray, windows: np.ndarray, least: int = 1) -> float:
    """Median of ``depth`` over the ``windows`` (mask): a group's lean where a class is at home; 0 (the usual stance)
    with fewer than ``least`` windows."""
    return float(np.median(depth[windows])) if windows.sum() >= least else 0.0


def name_nested(pooled: np.ndarray, recording: np.ndarray, labels: np.ndarray, names: list[ClusterName],
                declared: list[list[str]], background: str,
                nesting: Sequence[tuple[str, str]], trend: np.ndarray | None = None,
                slowing: float = 0.0) -> list[ClusterName]:
    """``names`` with a group given to each outer class of ``nesting`` that evidence left without one.

    ``nesting`` pairs ``(inner, outer)`` say that a manoeuvre of class ``inner`` passes through class ``outer``
    (the paper's sudden braking, which passes through normal braking before and after the hard stop); this is
    knowledge of the classes, not something the declarations show (a kerb is declared wherever rough asphalt is,
    and is no part of it). Where ``outer`` took no group, the group named the background that lies nearest to the
    windows of ``inner`` (median over them of the distance to the group's nearest window) becomes ``outer`` if it
    occurs in the recordings of ``inner`` and lies nearer to them than the background's largest group does. A pair
    whose classes are not both declared, or whose ``inner`` is declared where ``outer`` is not, is skipped.

    With ``trend`` (each window's GPS speed trend, m/s^2, NaN where unknown) and ``slowing`` > 0, the group must also
    lose speed: its :func:`median_trend` at or below ``-slowing`` (unknown passes). Braking does; on seed 67 of the
    training test's protocol the nearest group was steady cruising (median trend +0.02 m/s^2), which left normal
    braking no column, and the nearest that loses speed (-0.57 m/s^2) gives it pure ones. Measured (``spotfree
    training``'s ``slowing``, BENCHMARKS.md, "The GPS speed in the naming and in the background"): every class pure
    on 475 of seeds 0-479 of that protocol and 314 of seeds 480-799 with it, 470 and 309 without.
    """
    out = list(names)
    for inner, outer in nesting:
        inner_home = [r for r, d in enumerate(declared) if inner in d]
        if (outer == background or not inner_home or any(outer not in declared[r] for r in inner_home)
                or any(n.name == outer for n in out)):
            continue
        specific = np.isin(labels, [n.cluster for n in out if n.name == inner])
        if not specific.any():
            continue
        home = np.isin(recording, inner_home)
        candidates = [n for n in out if n.name == background and n.rule not in ("empty", "named by the user")
                      and (home & (labels == n.cluster)).any()]
        if len(candidates) < 2:
            continue
        largest = max(candidates, key=lambda n: sum(n.counts))
        distance = {n.cluster: _median_nearest(pooled, specific, labels == n.cluster) for n in candidates}
        speed = {n.cluster: median_trend(trend, labels == n.cluster) for n in candidates}
        braking = [n for n in candidates if not slowing or not speed[n.cluster] > -slowing]  # NaN: unknown, passes
        if not braking:
            continue
        best = min(braking, key=lambda n: distance[n.cluster])
        if best is largest or not distance[best.cluster] < distance[largest.cluster]:
            continue
        loses = "" if np.isnan(speed[best.cluster]) else f"; median GPS trend {speed[best.cluster]:+.2f} m/s^2"
        out[best.cluster] = ClusterName(
            best.cluster, outer, f"{inner} passes through {outer}: the shared group nearest to {inner} "
            f"(distance {distance[best.cluster]:.2f}, background {distance[largest.cluster]:.2f}{loses})",
            float(1 - distance[best.cluster] / distance[largest.cluster]), best.counts, nested=True)
    return out


def median_trend(trend: np.ndarray | None, windows: np.ndarray) -> float:
    """The median (m/s^2) of the known GPS speed trends ``trend`` of the selected ``windows`` (a mask or indices);
    NaN when ``trend`` is None or none of them is known."""
    if trend is None:
        return np.nan
    known = trend[windows]
    known = known[np.isfinite(known)]
    return float(np.median(known)) if len(known) else np.nan


DEPTH_RATIO = 3.0
"""Lean a background group must reach, at its median in the outer class's home recordings and in units of each
recording's median depth, to be named that class by :func:`name_deep_outer`. Measured on the training test's
protocol (seeds 80-99, 174 groups, on the unsigned depth): groups at x3 or more were mostly normal braking in the
normal-braking ride (45 of 48 at least 90 % normal braking), those at x2-3 mixed (15 of 24), those under x1.5 mostly
cruising."""


def name_deep_outer(labels: np.ndarray, recording: np.ndarray, names: list[ClusterName], declared: list[list[str]],
                    background: str, nesting: Sequence[tuple[str, str]], depth: np.ndarray,
                    ratio: float = DEPTH_RATIO) -> list[ClusterName]:
    """``names`` with every background group that leans deep in the home recordings of an outer class of
    ``nesting`` named that class, where evidence and :func:`name_nested` left it without a group.

    ``depth`` is each window's timing channel (the lean) from its recording's median, towards the inner class's
    deepest and in units of the recording's median ``|depth|``; a group takes the outer name when at least 3 of its
    windows lie in the outer class's home recordings (:func:`class_homes`) and their median depth exceeds
    ``ratio``. A normal stop is a lean the same way as a hard one: where both rides hold normal braking in similar
    shares, enrichment cannot name it (no normal-braking group on 6 of 80 seeds of the training test's protocol),
    but its windows lean three or more times deeper than the ride's usual stance. The sign matters: speeding up is a
    lean too, the other way (unsigned, the groups named this way on seeds 85 and 127 were cruising). Measured
    (``benchmarks/training_purity.py``, BENCHMARKS.md), before :func:`rename_upright`, every class pure on seeds 0-79
    / 80-159: 65 / 62 with it, 62 / 59 without it.
    """
    out = list(names)
    for outer, at_home in _outers_without_group(recording, out, declared, background, nesting):
        for n in names:
            median = _median_depth(depth, (labels == n.cluster) & at_home, least=3)
            if n.name == background and median > ratio:
                out[n.cluster] = ClusterName(
                    n.cluster, outer, f"leans x{median:.1f} of the usual depth in the recordings made for {outer}, "
                    "towards the deepest stop (the background group that holds it)", float(1 - ratio / median),
                    n.counts)
    return out


def _outers_without_group(recording, out, declared, background, nesting):
    """``(outer, at_home)`` for each outer class of ``nesting`` that is not the background, has home recordings
    (:func:`class_homes`) and, when its turn comes, no group in ``out`` (which the caller may be filling);
    ``at_home``: which windows (by their ``recording``) lie in those home recordings."""
    _, home, _ = class_homes(declared)
    for _, outer in nesting:
        if outer != background and home.get(outer) and not any(n.name == outer for n in out):
            yield outer, np.isin(recording, home[outer])


def name_slowing_outer(labels: np.ndarray, recording: np.ndarray, names: list[ClusterName],
                       declared: list[list[str]], background: str, nesting: Sequence[tuple[str, str]],
                       trend: np.ndarray | None, slowing: float) -> list[ClusterName]:
    """``names`` with, for each outer class of ``nesting`` still without a group, the background group that loses
    speed fastest in the class's home recordings (:func:`class_homes`) named that class: of the groups with at least
    3 windows there, the one whose :func:`median_trend` ``m`` there is lowest, if at or below ``-slowing`` (m/s^2;
    confidence ``min(1, -m / slowing - 1)``). Unchanged without ``trend`` or with ``slowing`` 0.

    The last resort after evidence, nesting and the lean (:func:`name_deep_outer`): on seed 450 of the training
    test's protocol no group was named at all, and normal braking's windows lay in background groups losing 0.66 to
    1.81 m/s^2 in the normal-braking ride. The fastest, not every such group: the rider's own slow-downs lose speed
    too (a group of 11 cruising windows there, -0.82 m/s^2). Measured (``spotfree training``'s ``slowing``,
    BENCHMARKS.md, "The GPS speed in the naming and in the background"): every class pure on 476 of seeds 0-479 and
    315 of seeds 480-799 with it, 475 and 314 without (450 and 663 gained), none made impure.
    """
    out = list(names)
    if trend is None or not slowing:
        return out
    for outer, at_home in _outers_without_group(recording, out, declared, background, nesting):
        speed = {n.cluster: median_trend(trend, (labels == n.cluster) & at_home) for n in out
                 if n.name == background and n.rule not in ("empty", "named by the user")
                 and ((labels == n.cluster) & at_home).sum() >= 3}
        losing = {cluster: median for cluster, median in speed.items() if median <= -slowing}
        if losing:
            fastest = min(losing, key=losing.get)
            out[fastest] = ClusterName(
                fastest, outer, f"loses speed fastest of the background's groups in the recordings made for {outer} "
                f"(median GPS trend {losing[fastest]:+.2f} m/s^2), where evidence, nesting and the lean named none",
                float(min(1.0, -losing[fastest] / slowing - 1.0)), out[fastest].counts)
    return out


def single_manoeuvre_names(labels: np.ndarray, recording: np.ndarray, per_window: np.ndarray,
                           declared: list[list[str]], background: str, names: list[ClusterName],
                           enrichment: float = ENRICHMENT) -> tuple[np.ndarray, list[ClusterName]]:
    """``per_window`` (one name per window, ``labels`` its group, ``recording`` its recording) with rule 6 of the
    module docstring applied, and ``names`` with the groups it renamed: the windows named ``background`` whose
    group is absent from the background-only recordings (and was not named by the user) take the one manoeuvre
    their recording declares, or ``""`` where it declares several. Unchanged when no recording declares only the
    background."""
    bare = [r for r, d in enumerate(declared) if set(d) == {background}]
    out, names = np.asarray(per_window, dtype=object).copy(), list(names)
    if not bare:
        return out, names
    counts = presence_matrix(labels, recording, int(labels.max()) + 1, len(declared))
    share = counts / counts.sum(axis=0).clip(min=1)
    absent = share[:, bare].max(axis=1) < share.max(axis=1) / enrichment
    absent[[n.cluster for n in names if n.rule == "named by the user"]] = False
    only = np.array([next(iter(set(d) - {background})) if len(set(d) - {background}) == 1 else "" for d in declared],
                    dtype=object)
    moved = absent[labels] & (out == background)
    out[moved] = only[recording[moved]]
    for j in np.unique(labels[moved]):
        taken = sorted({str(c) for c in out[moved & (labels == j)] if c})
        confidence = float(1 - enrichment * share[j, bare].max() / share[j].max())
        names[j] = ClusterName(int(j), "/".join(taken), f"absent from the recordings that declare only "
                               f"{background}: in each recording the one manoeuvre it declares", confidence,
                               counts[j].tolist())
    return out, names
