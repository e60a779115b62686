"""A nested level in 3D with the default solver (preset "auto"): the unit cube (clamped top, f = (0, 0, −0.5),
contact on the bottom, c_n = 100, m_n = 1.5), solved on 6 x 6 x 6 cells, refined uniformly, solved again
from the transferred solution. Prints (rank 0, JSON) the preconditioner the nested solve used, its counts
and reason, the largest nodal difference to the same level solved by MUMPS's Cholesky (preset direct),
relative to the largest displacement, the elastic energy of the nested solution, and how the direct solve
ended (on 3 ranks MUMPS ran out of workspace at its first factorisation: the refresh fallback widens it)."""
import json

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

COMM = MPI.COMM_WORLD
DATA = {"mesh": {"box": [[0, 0, 0], [1, 1, 1]], "cells": [6, 6, 6], "dirichlet": ["top"],
                 "neumann": ["left", "right", "front", "back"], "contact": ["bottom"]},
        "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "0", "-0.5"]},
        "contact": {"c_n": 100.0, "m_n": 1.5}}


def largest(array):
    return COMM.allreduce(float(np.max(np.abs(array), initial=0.0)), MPI.MAX)


problem = nc.Problem.from_dict(DATA, "cube")
parent = nc.build_domain(problem, COMM)
u_parent = nc.solve(problem, parent).u
child = nc.refine(parent)
direct = nc.solve(problem.replace({"solver.preset": "direct"}), child, initial=u_parent)
auto = nc.solve(problem, child, initial=u_parent)  # (BoomerAMG after MUMPS, in one process)
s = auto.stats
result = {"pc_type": s.pc_type, "preset": s.preset, "newton": s.newton_iterations, "krylov": s.linear_iterations,
          "reason": s.converged_reason, "recoveries": s.recoveries,
          "difference": largest(auto.u.x.array - direct.u.x.array) / largest(direct.u.x.array),
          "energy": nc.solution_quantities(auto.u, auto.fields)["elastic_energy"],
          "direct_reason": direct.stats.converged_reason, "direct_recoveries": direct.stats.recoveries}
if COMM.rank == 0:
    print(json.dumps(result))
