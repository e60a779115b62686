"""The bilateral predictor (solver.NonlinearSolver._bilateral_predictor) on the benchmark family's square
(E = 1, clamped top, f = (0, −0.5), c_n/E = 1e4, m_n = 1, 24 x 24 cells), on any number of ranks; prints
(rank 0, JSON) per gap and preset the Newton/Krylov counts and preconditioner set-ups with and without the
predictor, and the largest nodal differences between the two solutions and to the bilateral solution (the
linear problem with all of Γ_C in contact, K u + ∫ c_n (u_n − g_0) v_n = L(v), factorised by MUMPS), and
for a solve restarted from its own solution its Newton count and change.

Gaps: "0.002*(1 + x)", which the body closes everywhere (the solution is the bilateral one); "2*(x - 0.5)**2",
which it closes only around x = 1/2 (the bilateral guess pulls it down elsewhere: the predictor is dropped).
"""
import json

import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

import nc_dolfinx as nc
from square import square_problem
from nc_dolfinx import forms

COMM = MPI.COMM_WORLD


def problem(gap, preset):
    return square_problem(1e4, 1, gap=gap, preset=preset)


def max_difference(a, b):
    return COMM.allreduce(float(np.max(np.abs(a.x.array - b.x.array), initial=0.0)), MPI.MAX)


def bilateral_solution(solution):
    fields = solution.fields
    V = solution.u.function_space
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(V.mesh)
    dC = forms.contact_measure(fields)
    a = ufl.inner(fields.sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx + fields.c_n * ufl.dot(u, n) * ufl.dot(v, n) * dC
    L = ufl.inner(fields.f, v) * ufl.dx + fields.c_n * fields.gap * ufl.dot(v, n) * dC
    options = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    return fem_petsc.LinearProblem(a, L, bcs=fields.boundary_conditions(V), petsc_options=options).solve()


def counts(stats):
    return {"newton": stats.newton_iterations, "krylov": stats.linear_iterations, "pc_setups": stats.pc_setups,
            "reason": stats.converged_reason, "recoveries": stats.recoveries}


result = {}
for gap in ("0.002*(1 + x)", "2*(x - 0.5)**2"):
    for preset in ("iterative", "direct"):
        p = problem(gap, preset)
        domain = nc.build_domain(p, COMM)
        on = nc.solve(p, domain)
        off = nc.solve(p, domain, petsc_options={"bilateral_predictor": "false"})
        again = nc.solve(p, domain, initial=on.u)
        scale = COMM.allreduce(float(np.max(np.abs(off.u.x.array), initial=0.0)), MPI.MAX)
        result[f"{gap} {preset}"] = {
            "on": counts(on.stats), "off": counts(off.stats), "again": counts(again.stats),
            "on_off": max_difference(on.u, off.u) / scale, "again_change": max_difference(again.u, on.u) / scale,
            "off_bilateral": max_difference(off.u, bilateral_solution(off)) / scale}
if COMM.rank == 0:
    print(json.dumps(result))
