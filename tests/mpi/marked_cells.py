"""Solve a case on one mesh, estimate, mark; print the midpoints of the marked cells (rank 0, JSON).

Usage: marked_cells.py CASE.toml STRATEGY THETA [OVERRIDE ...]
"""
import json
import sys

import numpy as np
from mpi4py import MPI

from dolfinx import mesh as dmesh

import nc_dolfinx as nc

comm = MPI.COMM_WORLD
problem = nc.load_problem(sys.argv[1], sys.argv[4:])
domain = nc.build_domain(problem, comm)
solution = nc.solve(problem, domain)
marked = nc.mark(nc.estimate(solution.u, solution.fields), float(sys.argv[3]), sys.argv[2])
midpoints = dmesh.compute_midpoints(domain.mesh, 2, marked)[:, :2]
everything = comm.gather(midpoints, root=0)
if comm.rank == 0:
    points = np.concatenate(everything).round(10)
    print(json.dumps(sorted(map(tuple, points.tolist()))))
