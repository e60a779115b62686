"""A stiff penalty with a gap ends where the residual reaches its round-off (solver.newton.NonlinearSolver._within_roundoff):
the family's square (24 x 24 cells) and cube (6 x 6 x 6), m_n = 1, c_n/E = 1e8 and 1e12, g_0 = 0.002(1 + x),
which the body closes everywhere, so that (7) is the linear bilateral law (square.bilateral_solution). There
c_n g_0 computed to round-off leaves ‖F‖ above the target 1e-10 ‖L‖. Prints (rank 0, JSON) per case the
counts, the converged reason, the largest nodal difference to the bilateral solution relative to the largest
displacement, and the measure of Γ_C where that solution leaves the foundation (0: it solves (7))."""
import json
import sys
from pathlib import Path

import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem

import nc_dolfinx as nc
from nc_dolfinx.physics import forms
from square import bilateral_solution, max_difference

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
from family import Member, member_problem  # noqa: E402

COMM = MPI.COMM_WORLD
GAP = (0.002, 0.002)  # g_0 = 0.002 (1 + x)


def separated_measure(u, fields):
    """|{x ∈ Γ_C : u_n − g_0 < 0}|, by a Gauss rule on Γ_C."""
    n = ufl.FacetNormal(u.function_space.mesh)
    separated = ufl.conditional(ufl.lt(ufl.dot(u, n) - fields.gap, 0.0), 1.0, 0.0)
    return COMM.allreduce(fem.assemble_scalar(fem.form(separated * forms.contact_measure(fields, 4))), MPI.SUM)


result = {}
for dim, cells, presets in ((2, 24, ("auto", "iterative")), (3, 6, ("auto",))):
    for c_n in (1e8, 1e12):
        for preset in presets:
            member = Member(f"{c_n:g}-1-gap", c_n, 1, GAP, body="square" if dim == 2 else "cube")
            problem, domain = member_problem(member, cells, COMM, None)
            try:
                solution = nc.solve(problem.replace({"solver.preset": preset}), domain)
            except nc.InputError as err:
                result[f"{dim}d {c_n:g} {preset}"] = {"error": str(err)}
                continue
            stats, reference = solution.stats, bilateral_solution(solution)
            scale = COMM.allreduce(float(np.max(np.abs(reference.x.array), initial=0.0)), MPI.MAX)
            result[f"{dim}d {c_n:g} {preset}"] = {
                "newton": stats.newton_iterations, "reason": stats.converged_reason, "preset": stats.preset,
                "recoveries": stats.recoveries, "to_bilateral": max_difference(solution.u, reference) / scale,
                "separated": separated_measure(reference, solution.fields)}
if COMM.rank == 0:
    print(json.dumps(result))
