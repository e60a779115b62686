"""The bilateral predictor (solver.newton.NonlinearSolver._bilateral_predictor) on the benchmark family's square
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
from mpi4py import MPI

import nc_dolfinx as nc
from square import bilateral_solution, max_difference, square_problem

COMM = MPI.COMM_WORLD


def problem(gap, preset):
    return square_problem(1e4, 1, gap=gap, preset=preset)


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
