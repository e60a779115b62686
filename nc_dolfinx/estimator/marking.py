"""Marking: which cells to refine, from the indicators η_K.

Both strategies decide on the global set of indicators, so the marked set does not depend on the number
of ranks. Indicators are compared with a relative tolerance (``TIE_RTOL``): values equal up to
parallel round-off are ties, and ties at the threshold are marked together. Without this a symmetric mesh
(many exactly equal η_K) would be marked differently on different partitions.
"""
import numpy as np
from mpi4py import MPI

TIE_RTOL = 1e-9


def doerfler_threshold(eta_squared, theta):
    """Smallest t such that the cells with η_K² ≥ t carry at least θ Σ η_K² (bulk criterion).

    ``eta_squared`` holds every cell's η_K² (global). The marked set {η_K² ≥ t·(1 − TIE_RTOL)} is the
    minimal Dörfler set up to ties: no set made of strictly larger indicators satisfies the criterion.
    """
    if not 0 < theta <= 1:
        raise ValueError(f"theta must lie in (0, 1], got {theta}")
    values = np.asarray(eta_squared, dtype=float)
    total = values.sum()
    if total == 0:
        return np.inf
    target = theta * total * (1 - 1e-14)
    # The marked set is usually a small part of the mesh: sort only the largest values, more if needed
    # (the running sum over them is the same as over the whole sorted list).
    top = min(len(values), 4096)
    while True:
        largest = np.sort(np.partition(values, len(values) - top)[len(values) - top:])[::-1]
        k = int(np.searchsorted(np.cumsum(largest), target))
        if k < top or top == len(values):
            return largest[min(k, top - 1)]
        top = min(len(values), 8 * top)


def mark(indicators, theta=0.5, strategy="doerfler", comm=None):
    """MARK: the local indices of the owned cells to refine, from an :class:`~nc_dolfinx.Estimate` (the
    η_K of Definition 5), or from an array of the owned cells' η_K² with its communicator ``comm``.

    doerfler: a minimal set with Σ_marked η_K² ≥ θ η² (Dörfler's bulk criterion);
    maximum:  the cells with η_K ≥ θ max η_K.

    Decided on the global set of indicators: the marked cells do not depend on the number of ranks.
    """
    if hasattr(indicators, "squares"):
        indicators, comm = indicators.squares, indicators.comm
    local = np.asarray(indicators, dtype=float)
    if strategy == "doerfler":
        everything = np.concatenate(comm.allgather(local))
        threshold = doerfler_threshold(everything, theta)
    elif strategy == "maximum":
        threshold = theta ** 2 * comm.allreduce(float(local.max()) if len(local) else 0.0, MPI.MAX)
        if threshold == 0:
            threshold = np.inf
    else:
        raise ValueError(f"unknown marking strategy '{strategy}'")
    return np.flatnonzero(local >= threshold * (1 - TIE_RTOL)).astype(np.int32)
