"""Solve a case with ``nc.solve`` on its level-0 mesh and on that mesh refined uniformly once (nested
iteration); print per mesh the dofs, Newton iterations, solution quantities, errors and ‖u_h‖_0 (rank 0, JSON).

Usage: case_quantities.py CASE [OVERRIDE ...]
"""
import json
import sys

import ufl
from mpi4py import MPI

import nc_dolfinx as nc

comm = MPI.COMM_WORLD
problem = nc.load_problem(sys.argv[1], sys.argv[2:])
domain = nc.build_domain(problem, comm)
rows, previous = [], None
for level in range(2):
    solution = nc.solve(problem, domain, initial=previous)
    row = {"dofs": domain.mesh.geometry.dim * domain.num_vertices(), "cells": domain.num_cells(),
           "newton_iterations": solution.stats.newton_iterations,
           "u_l2": nc.integrate(ufl.inner(solution.u, solution.u) * ufl.dx, comm) ** 0.5,
           **nc.solution_quantities(solution.u, solution.fields), **nc.errors(solution.u, solution.fields)}
    rows.append(row)
    previous, domain = solution.u, nc.refine(domain)
if comm.rank == 0:
    print(json.dumps(rows))
