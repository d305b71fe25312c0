"""Subspace clustering of window matrices: Ordered/Sparse Subspace Clustering and normalized cuts."""

from spotfree.cluster.osc import (
    OrderedSubspaceClustering,
    OSCResult,
    SparseSubspaceClustering,
    affinity,
    osc_admm,
    osc_objective,
    penalty_scale,
)
from spotfree.cluster.spectral import estimate_n_clusters, laplacian_spectrum, normalized_cuts

__all__ = [
    "OSCResult",
    "OrderedSubspaceClustering",
    "SparseSubspaceClustering",
    "affinity",
    "estimate_n_clusters",
    "laplacian_spectrum",
    "normalized_cuts",
    "osc_admm",
    "osc_objective",
    "penalty_scale",
]
