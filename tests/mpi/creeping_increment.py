"""The last increment of a load path on the solver family's square with Coulomb friction (benchmarks/family.py's
1e4-1-mu0.1 at 64 cells: c_n = 1e4 E, m_n = 1, μ = 0.1): solved at 9/10 of its weight, the law's state moved
on (nc.SlipState.after), then at the full weight from there, once with the defaults and once with
-friction_creeping_steps 0 (the passes at ε_r alone). The extra weight extends the slip zone under a stiff
foundation, and the passes' line search cuts step after step while the stick/slip front moves.

    mpirun -n N python3 tests/mpi/creeping_increment.py OUT.npz

Writes the two solutions' nodal values (sorted by coordinates) and their solvers' counts to OUT.npz on rank 0.
"""
import sys

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc
from held_by_friction import sorted_nodal_values

CELLS = 64


def square(weight):
    data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [CELLS, CELLS], "dirichlet": ["top"],
                     "neumann": ["left", "right"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", repr(-weight)]},
            "contact": {"c_n": 1e4, "m_n": 1, "friction": 0.1}}
    return nc.Problem.from_dict(data, "creeping_increment")


if __name__ == "__main__":
    comm = MPI.COMM_WORLD
    domain = nc.build_domain(square(0.5), comm)
    start = nc.solve(square(0.45), domain)
    state = nc.SlipState.after(start.u, start.fields)
    out = {}
    for name, options in (("default", None), ("passes", {"friction_creeping_steps": "0"})):
        solution = nc.solve(square(0.5), domain, initial=start.u, previous_state=state, petsc_options=options)
        points, values = sorted_nodal_values(solution.u, comm)
        stats = solution.stats
        out.update({f"{name}_values": values, f"{name}_newton": stats.newton_iterations,
                    f"{name}_passes": stats.friction_passes, f"{name}_reason": stats.converged_reason})
    if comm.rank == 0:
        np.savez(sys.argv[1], points=points, **out)
