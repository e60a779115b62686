"""Inexact Newton on a linear problem (solver.forcing.Forcing), on any number of ranks: the benchmark family's square
(E = 1, clamped top, f = (0, −0.5), 24 x 24 cells) with c_n = 0 (linear elasticity), solved by the
`iterative` preset (CG + BoomerAMG, the forcing terms) and by `direct` (MUMPS). Prints (rank 0, JSON) the
Newton counts and the largest nodal difference between the two solutions relative to the largest
displacement. The remainder of the first step, ‖F_1 − (F_0 − J y)‖, is a global norm: on every partition it
is round-off, so the second Krylov solve goes to the target and the solve ends after 2 Newton steps."""
import json

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc
from square import square_problem

COMM = MPI.COMM_WORLD
problem = square_problem(0.0, 1)
domain = nc.build_domain(problem, COMM)
solutions = {preset: nc.solve(problem.replace({"solver.preset": preset}), domain)
             for preset in ("iterative", "direct")}
u, reference = (solutions[p].u.x.array for p in ("iterative", "direct"))
scale = COMM.allreduce(float(np.max(np.abs(reference), initial=0.0)), MPI.MAX)
difference = COMM.allreduce(float(np.max(np.abs(u - reference), initial=0.0)), MPI.MAX)
if COMM.rank == 0:
    print(json.dumps({"newton": {p: s.stats.newton_iterations for p, s in solutions.items()},
                      "difference": difference / scale}))
