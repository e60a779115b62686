"""A bar [0, L] × [0, H] (× [0, W] in 3D) in uniaxial stress, driven by a prescribed displacement only:
its left end on a roller (u_x = 0, the other components free), its right end pulled to u_x = δ (the others
free), the planes y = 0 (and z = 0) symmetry planes, the foundation under a gap it never closes (Γ_C must
not be empty). With no other load the solution is linear, so P1 holds it exactly:

    2D (plane strain): u = (δ x/L, −ν' δ y/L),  ν' = ν/(1 − ν),  σ_xx = E' δ/L,  E' = E/(1 − ν²)
    3D:                u = (δ x/L, −ν δ y/L, −ν δ z/L),           σ_xx = E δ/L

and the right end's reaction (its force on the body) is +σ_xx times its area (H, or W·H), the left end's
its opposite. Shared by tests/test_prescribed.py; run as a script (``uniaxial.py DIM``, on any number of
ranks) it prints (rank 0, JSON) the largest nodal error relative to δ, the reactions and the force balance.
"""
import json
import sys

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

L, H, W, E, NU, DELTA = 2.0, 1.0, 0.5, 1.0e3, 0.3, 0.01


def uniaxial_problem(dim, load_steps=1, preset="direct"):
    """The bar as an :class:`nc.Problem`: rectangle of 8 × 4 cells, or box of 4 × 2 × 2 cubes (MUMPS by
    default: the identities then hold to round-off)."""
    free = ["free"] * (dim - 1)
    mesh = {"rectangle": [[0, 0], [L, H]], "cells": [8, 4]} if dim == 2 else \
        {"box": [[0, 0, 0], [L, W, H]], "cells": [4, 2, 2]}
    symmetry = ["bottom"] if dim == 2 else ["front", "bottom"]
    mesh.update({"dirichlet": ["left", "right"], "symmetry": symmetry, "contact": ["top"]})
    if dim == 3:
        mesh["neumann"] = ["back"]
    data = {"parameters": {"delta": DELTA}, "mesh": mesh, "material": {"E": E, "nu": NU},
            "loads": {"u_D": {"left": ["0", *free], "right": ["delta", *free]}},
            "contact": {"c_n": E, "m_n": 1.0, "gap": 1.0}, "solver": {"load_steps": load_steps, "preset": preset}}
    return nc.Problem.from_dict(data, f"uniaxial{dim}d")


def exact_displacement(points):
    """The exact u at ``points`` (n, dim)."""
    dim = points.shape[1]
    lateral = NU / (1 - NU) if dim == 2 else NU  # ν' (plane strain) or ν
    return np.column_stack([DELTA * points[:, 0] / L, *(-lateral * DELTA * points[:, i] / L for i in range(1, dim))])


def exact_reaction(dim):
    """The right end's force on the body along x: σ_xx times its area."""
    modulus = E / (1 - NU ** 2) if dim == 2 else E  # E' (plane strain) or E
    return modulus * DELTA / L * (H if dim == 2 else W * H)


def outcome(solution):
    """The largest nodal error relative to δ (over all ranks), the reactions and the force balance."""
    u = solution.u
    dim = solution.fields.dim
    points = u.function_space.tabulate_dof_coordinates()[:, :dim]
    local = float(np.max(np.abs(u.x.array.reshape(-1, dim) - exact_displacement(points)), initial=0.0))
    q = nc.solution_quantities(u, solution.fields)
    return {"nodal_error": u.function_space.mesh.comm.allreduce(local, MPI.MAX) / DELTA,
            "reaction_right": q["reaction_right"], "reaction_left": q["reaction_left"],
            **{f"reaction_{name}": q[f"reaction_{name}"] for name in ("bottom", "front") if f"reaction_{name}" in q},
            "applied_load": q["applied_load"], "force_balance": q["force_balance"],
            "contact_resultant": q["contact_resultant"]}


if __name__ == "__main__":
    problem = uniaxial_problem(int(sys.argv[1]))
    result = outcome(nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD)))
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(result))
