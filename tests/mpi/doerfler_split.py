"""Dörfler marking of one global set of η_K² split unevenly over the ranks (tests/test_marking.py).

Every rank builds the same values (a seeded mix: distinct, exact ties, ties up to round-off, zeros, a range
of magnitudes), keeps a contiguous slice of uneven length, marks it with ``nc.mark`` and the global indices
of the marked cells are gathered; rank 0 prints JSON {theta: sorted global indices} for every θ.
"""
import json

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

THETAS = (0.01, 0.3, 0.5, 0.9, 1.0)


def global_values():
    rng = np.random.default_rng(11)
    parts = [rng.lognormal(sigma=3.0, size=3000) ** 2, np.full(400, 2.5),
             2.5 * (1 + 1e-13 * rng.standard_normal(300)), np.zeros(50), rng.uniform(1e-12, 1e-10, 200)]
    values = np.concatenate(parts)
    return values[rng.permutation(len(values))]


def main():
    comm = MPI.COMM_WORLD
    values = global_values()
    weights = np.arange(1, comm.size + 1)  # rank r holds a share ∝ r + 1: uneven slices, one rank empty on 1
    bounds = np.concatenate([[0], np.cumsum(weights)]) * len(values) // weights.sum()
    first, last = bounds[comm.rank], bounds[comm.rank + 1]
    result = {}
    for theta in THETAS:
        marked = first + nc.mark(values[first:last], theta, "doerfler", comm)
        gathered = comm.gather(marked, root=0)
        if comm.rank == 0:
            result[str(theta)] = sorted(int(i) for i in np.concatenate(gathered))
    if comm.rank == 0:
        print(json.dumps(result))


if __name__ == "__main__":
    main()
