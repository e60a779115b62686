"""The solver family's square (benchmarks/family.py): unit square, E = 1, ν = 0.3, clamped top, f = (0, −0.5),
contact at the bottom; shared by tests/test_solver.py and the MPI scripts beside this file, with the
reference for a gap the body closes everywhere (bilateral_solution)."""
import numpy as np
import ufl
from mpi4py import MPI



import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.physics import forms


def square_problem(c_n, m_n, cells=24, gap=0.0, preset=None):
    """The square as an :class:`nc.Problem` with c_n, m_n, the gap and, if given, the solver preset."""
    data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [cells, cells], "dirichlet": ["top"],
                     "neumann": ["left", "right"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "-0.5"]},
            "contact": {"c_n": c_n, "m_n": m_n, "gap": gap}}
    if preset is not None:
        data["solver"] = {"preset": preset}
    return nc.Problem.from_dict(data, "square")


def bilateral_solution(solution):
    """The solution of the linear law with all of Γ_C in contact, K u + ∫ c_n (u_n − g_0) v_n = L(v) (m_n = 1),
    written here in UFL and factorised by MUMPS: the solution of (7) where the body closes the gap everywhere."""
    fields = solution.fields
    V = solution.u.function_space
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(V.mesh)
    dC = forms.contact_measure(fields)
    a = ufl.inner(fields.sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx + fields.c_n * ufl.dot(u, n) * ufl.dot(v, n) * dC
    L = ufl.inner(fields.f, v) * ufl.dx + fields.c_n * fields.gap * ufl.dot(v, n) * dC
    options = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    return versions.solve_linear_problem(a, L, fields.boundary_conditions(V), options)


def max_difference(a, b):
    """max |a − b| over the dofs of all ranks."""
    comm = a.function_space.mesh.comm
    return comm.allreduce(float(np.max(np.abs(a.x.array - b.x.array), initial=0.0)), MPI.MAX)
