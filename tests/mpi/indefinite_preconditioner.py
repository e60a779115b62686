"""Solve the benchmark family's stiff penalty member (c_n/E = 1e4, m_n = 1, 24 x 24 square) with a
preconditioner that is not positive definite, as GAMG's was on a partition-dependent 3D hierarchy; print
(rank 0, JSON) the Newton and Krylov counts, the recoveries and the solution's norm, and the same for the
default preconditioner.

Usage: indefinite_preconditioner.py [KSP_TYPE]   (a given KSP type is the user's choice: kept)
"""
import json
import sys

from mpi4py import MPI
from petsc4py import PETSc

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from square import square_problem


class IndefiniteAMG:
    """M = G − 3 (vᵀGv) v vᵀ, G GAMG and v the normalised vector of ones: indefinite along v, so CG stops
    on it (DIVERGED_INDEFINITE_PC); for GMRES a rank-one change of a good preconditioner."""

    def setUp(self, pc):
        A, P = pc.getOperators()
        self.inner = PETSc.PC().create(pc.comm)
        self.inner.setOperators(A, P)
        self.inner.setType("gamg")
        self.inner.setUp()
        self.v = P.createVecRight()
        self.v.set(1.0)
        self.v.normalize()
        Gv = self.v.duplicate()
        self.inner.apply(self.v, Gv)
        self.c = 3.0 * self.v.dot(Gv)

    def apply(self, pc, x, y):
        self.inner.apply(x, y)
        y.axpy(-self.c * self.v.dot(x), self.v)


def run(options):
    problem = square_problem(1e4, 1, preset="iterative")
    try:
        solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD), petsc_options=options)
    except nc.InputError as err:
        return {"error": str(err)}
    s = solution.stats
    return {"newton": s.newton_iterations, "krylov": s.linear_iterations, "recoveries": s.recoveries,
            "reason": s.converged_reason, "norm": versions.petsc_vec(solution.u).norm()}


indefinite = {"pc_type": "python", "pc_python_type": "__main__.IndefiniteAMG", "snes_max_it": 20}
if len(sys.argv) > 1:
    indefinite["ksp_type"] = sys.argv[1]
result = {"default": run({}), "indefinite": run(indefinite)}
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(result))
