"""A cantilever sagging onto a stiff foundation (solver.recovery.Recoveries._retry_c_n_continuation): 10 × 1
(3D: 10 × 1 × 1), 160 × 16 cells (3D: 40 × 4 × 4), E = 1, clamped at x = 0, f = −0.01 downwards (unsupported,
its tip would sink by ~150), the gap g_0 = 0.01 below it, m_n = 1, c_n/E = 1e9. Its tip touches first, and
Newton's line search then stops each step where the next points touch. Prints (rank 0, JSON) per dimension
the defaults' counts, converged reason and fallbacks, and the largest nodal difference, relative to the
largest displacement, to a reference reached by hand through the public API: c_n = 1, 1e2, …, 1e8, 1e9,
each solve from the last one's solution, with the fallbacks off."""
import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc
from square import max_difference

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from extremes import cantilever_problem  # noqa: E402
from family import Member  # noqa: E402

COMM = MPI.COMM_WORLD
C_N = 1e9
CELLS = {2: 16, 3: 4}  # n: 10n x n (x n) cells


def cantilever(c_n, dim):
    """extremes.py's cantilever with m_n = 1 and the gap 0.01."""
    return cantilever_problem(Member("cantilever", c_n, 1, (0.01, 0.0)), dim, CELLS[dim])


def run(dim):
    domain = nc.build_domain(cantilever(C_N, dim), COMM)
    try:
        solution = nc.solve(cantilever(C_N, dim), domain)
    except nc.InputError as err:
        return {"error": str(err)}
    reference = None
    for c_n in [*(10.0 ** k for k in range(0, 9, 2)), C_N]:
        reference = nc.solve(cantilever(c_n, dim), domain, initial=reference and reference.u,
                             petsc_options={"fallbacks": "false"})
    scale = COMM.allreduce(float(np.max(np.abs(reference.u.x.array), initial=0.0)), MPI.MAX)
    stats = solution.stats
    return {"newton": stats.newton_iterations, "reason": stats.converged_reason, "recoveries": stats.recoveries,
            "to_reference": max_difference(solution.u, reference.u) / scale}


result = {f"{dim}d": run(dim) for dim in (2, 3)}
if COMM.rank == 0:
    print(json.dumps(result))
