"""Naming clusters by evidence across training recordings.

Each training recording ``r`` declares only the set ``D_r`` of classes that occur somewhere in it. Clustering gives
every window a cluster ``j``; ``N[j, r]`` counts the windows of cluster ``j`` in recording ``r`` and
``S[j, r] = N[j, r] / |r|`` is its share of that recording. Names follow from three rules, most specific first:

1. **Presence.** Cluster ``j`` is present in ``r`` when ``N[j, r] >= max(min_count, presence * max_r N[j, r])``.
   Its candidates are the classes declared in every recording where it is present,
   ``C_j = ∩_{r present} D_r``. A candidate declared in fewer recordings than the background is *specific*; the
   most specific candidate (declared in the fewest recordings) names the cluster: a group present only where
   ``sudden-braking`` is declared is ``sudden-braking``. Confidence: the share of the cluster's windows that lie
   in recordings declaring that class.
2. **Enrichment.** A cluster present where only classes declared in every recording are candidates (for instance
   cruising and normal braking, both in every ride) is a *common manoeuvre* ``X`` when it is over-represented in
   the recordings made for ``X`` (the recordings where ``X`` is the most specific declared class), by the factor
   ``E = mean_home S[j, r] / mean_other S[j, r] >= enrichment``; otherwise it is background. A turn, a bump or a
   change of speed occurs in every ride alike and so stays with the background: no confounder is forced into a
   manoeuvre class. Confidence: ``1 - 1 / E``.
3. **Background.** Everything else is the background class: the class declared in every recording (the first such
   class in declaration order unless the caller names it).

A cluster present in recordings that share no declared class cannot be any one class and goes to the background.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from spotfree.errors import InputError


@dataclass
class ClusterName:
    """The name of one cluster and the evidence for it."""

    cluster: int
    name: str
    rule: str
    confidence: float
    counts: list[int] = field(default_factory=list)


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


def name_clusters(
    counts: np.ndarray,
    declared: list[list[str]],
    background: str,
    presence: float = 0.1,
    min_count: int = 3,
    enrichment: float = 2.0,
) -> list[ClusterName]:
    """Name every cluster from its counts per recording (rules in the module docstring)."""
    n_clusters, n_recordings = counts.shape
    sizes = counts.sum(axis=0).clip(min=1)
    share = counts / sizes
    n_declaring = {c: sum(c in d for d in declared) for d in declared for c in d}
    home = {
        c: [r for r, d in enumerate(declared) if c in d and n_declaring[c] == min(n_declaring[k] for k in d)]
        for c in n_declaring
    }
    names = []
    for j in range(n_clusters):
        row = counts[j]
        if row.sum() == 0:
            names.append(ClusterName(j, background, "empty", 0.0, row.tolist()))
            continue
        present = row >= max(min_count, presence * row.max())
        candidates = set.intersection(*(set(declared[r]) for r in np.flatnonzero(present)))
        specific = [c for c in candidates if n_declaring[c] < n_declaring[background]]
        if not candidates:
            names.append(ClusterName(j, background, "present in recordings that share no declared class", 0.5,
                                     row.tolist()))
        elif specific:
            best = min(specific, key=lambda c: (n_declaring[c], c))
            inside = sum(row[r] for r, d in enumerate(declared) if best in d) / row.sum()
            where = f"{int(present.sum())} of {n_recordings} recordings"
            names.append(ClusterName(j, best, f"present only where {best} is declared ({where})", float(inside),
                                     row.tolist()))
        else:
            names.append(_by_enrichment(j, row, share[j], candidates, background, home, n_recordings, enrichment))
    return names


def _by_enrichment(j, row, share, candidates, background, home, n_recordings, enrichment) -> ClusterName:
    best, best_ratio = background, 0.0
    for c in sorted(candidates - {background}):
        inside = home[c]
        outside = [r for r in range(n_recordings) if r not in inside]
        if not inside or not outside:
            continue
        ratio = share[inside].mean() / max(share[outside].mean(), 1e-9)
        if ratio > best_ratio:
            best, best_ratio = c, ratio
    if best != background and best_ratio >= enrichment:
        return ClusterName(j, best, f"enriched x{best_ratio:.1f} in the recordings made for {best}",
                           float(1 - 1 / best_ratio), row.tolist())
    note = f" (at most x{best_ratio:.1f} where {best} is the manoeuvre)" if best != background else ""
    return ClusterName(j, background, f"shared by the recordings, not a declared manoeuvre{note}",
                       float(min(1.0, 1 - best_ratio / enrichment)) if best != background else 1.0, row.tolist())
