"""Marking: which cells to refine, from the indicators η_K.

Both strategies decide on the global set of indicators, so the marked set does not depend on the number
of ranks, and neither gathers them: a rank holds its own cells' η_K only (:func:`doerfler_threshold`).
Indicators are compared with a relative tolerance (``TIE_RTOL``): values equal up to parallel round-off
are ties, and ties at the threshold are marked together. Without this a symmetric mesh (many exactly
equal η_K) would be marked differently on different partitions.
"""
import numpy as np
from mpi4py import MPI

TIE_RTOL = 1e-9


def doerfler_threshold(eta_squared, theta, comm=MPI.COMM_SELF):
    """The largest of the η_K² such that the cells with η_K² ≥ t carry at least θ Σ η_K² (Dörfler's bulk
    criterion), the same on every rank of ``comm``; ``eta_squared`` holds this rank's (owned cells') η_K².

    The marked set {η_K² ≥ t·(1 − TIE_RTOL)} is the minimal Dörfler set up to ties: no set made of
    strictly larger indicators satisfies the criterion. Found without gathering the indicators, as the
    largest x with T(x) = Σ_{η_K² < x} η_K² ≤ (1 − θ(1 − 1e-14)) Σ η_K² (what the marked cells leave out;
    summing the small values, not the large ones, keeps the test accurate when the left-out part is a
    sliver of the total, as at θ = 1). T is non-decreasing in x; the search is a bisection on the bit
    patterns of non-negative doubles (ordered like the values) that ends on one of the η_K² exactly. Each
    of its at most 63 steps is one allreduce of one number and a pass over the values still in the
    bracket on this rank: memory O(local cells), traffic O(log) numbers per marking.
    """
    if not 0 < theta <= 1:
        raise ValueError(f"theta must lie in (0, 1], got {theta}")
    values = np.asarray(eta_squared, dtype=np.float64).ravel()
    values = np.where(values > 0, values, 0.0)  # (a -0.0 has a negative bit pattern)
    total = comm.allreduce(float(values.sum()), MPI.SUM)
    if total == 0:
        return np.inf
    left_out = total * ((1 - theta) + theta * 1e-14)  # (no cancellation at θ = 1)
    bits = values.view(np.int64)
    low = 0                                                                   # T(0) = 0
    high = comm.allreduce(int(bits.max()) if len(bits) else 0, MPI.MAX) + 1   # T(above the max) = Σ
    below = 0.0                                  # T(x_low): the values under the bracket, summed
    while high - low > 1:                        # the values in [x_low, x_high) are still in `bits`
        middle = (low + high) // 2
        lower = bits < middle
        t_middle = below + comm.allreduce(float(values[lower].sum()), MPI.SUM)
        if t_middle <= left_out:
            low, below, keep = middle, t_middle, ~lower
        else:
            high, keep = middle, lower
        values, bits = values[keep], bits[keep]
    return float(np.array(low, dtype=np.int64).view(np.float64))


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
        threshold = doerfler_threshold(local, theta, comm)
    elif strategy == "maximum":
        threshold = theta ** 2 * comm.allreduce(float(local.max()) if len(local) else 0.0, MPI.MAX)
        if threshold == 0:
            threshold = np.inf
    else:
        raise ValueError(f"unknown marking strategy '{strategy}'")
    return np.flatnonzero(local >= threshold * (1 - TIE_RTOL)).astype(np.int32)
