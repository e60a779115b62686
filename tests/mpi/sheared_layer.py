"""A layer on the foundation, pressed and sheared by its clamp: an exact solution of the regularised
Coulomb law with normal compliance (nc_dolfinx.physics.friction), in 2D (plane strain) and 3D.

The layer [0, L] × [0, H] (× [0, W]) rests on Γ_C = {y = 0} (2D) or {z = 0} (3D); its top is clamped to a
prescribed displacement, its sides carry the exact tractions (loads.from_exact). With the last axis
vertical and x the direction of shear, the exact u is linear,

    u_x = γ y + s,   u_vertical = −e y − d         (y the vertical coordinate; 3D: u_y = 0, the same in z),

so σ is uniform (sympy below): the foundation's pressure P = −σ_vv = c_n d^{m_n} fixes the penetration d,
and the shear σ_xv = G γ (G the shear modulus) must equal the law's tangential traction on the base, whose
slip from the unloaded state is s: μ P s / max(s, ε_r d). Given e, either

- stick: s = ε_r d · Gγ/(μP) < ε_r d for a shear Gγ < μP (the pre-slip of the regularised law), or
- slip: Gγ = μP, and any s ≥ ε_r d (the base slides by s at the friction bound).

P1 holds the linear u exactly, so u_h equals it at the nodes to the solver's tolerance. Shared by
tests/test_friction.py; run as a script (``sheared_layer.py DIM MODE M_N [held]``, any number of ranks) it
prints (rank 0, JSON) the outcome (``held``: of :func:`held_problem`'s last increment).
"""
import json
import sys

import numpy as np
import sympy as sp
from mpi4py import MPI

import nc_dolfinx as nc

L, H, W, E, NU, C_N, MU, EPS_R, STRAIN = 2.0, 1.0, 1.0, 1.0, 0.3, 100.0, 0.3, 1e-3, 0.01


def exact_state(dim, mode, m_n):
    """(γ, s, e, d, P): the exact solution's constants for ``mode`` 'stick' or 'slip' (sympy's Hooke)."""
    y = sp.symbols("x0:%d" % dim)
    g, s, e, d = sp.symbols("gamma s e d")
    u = [g * y[-1] + s] + [0] * (dim - 2) + [-e * y[-1] - d]
    grad = sp.Matrix(dim, dim, lambda i, j: sp.diff(u[i], y[j]))
    strain = (grad + grad.T) / 2
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    stress = lam * strain.trace() * sp.eye(dim) + 2 * mu * strain
    pressure = float(-stress[-1, -1].subs(e, STRAIN))
    shear_per_gamma = float(sp.diff(stress[0, -1], g))
    depth = (pressure / C_N) ** (1 / m_n)
    bound = MU * pressure
    if mode == "stick":
        gamma = 0.8 * bound / shear_per_gamma
        slip = EPS_R * depth * shear_per_gamma * gamma / bound
    else:
        gamma, slip = bound / shear_per_gamma, 5 * EPS_R * depth
    return gamma, slip, STRAIN, depth, pressure


def layer_problem(dim, mode, m_n, friction=MU):
    """The layer as an :class:`nc.Problem` (MUMPS: the identities then hold to round-off)."""
    gamma, slip, e, depth, _ = exact_state(dim, mode, m_n)
    v = "y" if dim == 2 else "z"
    u = [f"{gamma!r}*{v} + {slip!r}"] + ["0"] * (dim - 2) + [f"-{e!r}*{v} - {depth!r}"]
    if dim == 2:
        mesh = {"rectangle": [[0, 0], [L, H]], "cells": [8, 4], "dirichlet": ["top"], "neumann": ["left", "right"],
                "contact": ["bottom"]}
    else:
        mesh = {"box": [[0, 0, 0], [L, W, H]], "cells": [4, 2, 2], "dirichlet": ["top"],
                "neumann": ["left", "right", "front", "back"], "contact": ["bottom"]}
    data = {"mesh": mesh, "material": {"E": E, "nu": NU}, "loads": {"from_exact": True, "u_D": u},
            "contact": {"c_n": C_N, "m_n": m_n, "friction": friction, "slip_regularisation": EPS_R},
            "exact": {"u": u},
            # (solved to round-off: the states are exact, the test compares to 1e-10)
            "solver": {"preset": "direct", "petsc_options": {"atol_of_load": 1e-13}}}
    return nc.Problem.from_dict(data, f"layer{dim}d")


def held_problem(dim):
    """The layer sheared in stick by step 1 of a load path, the same load held over 4 increments by step 2:
    with the law's memory of the traction (nc_dolfinx/physics/slip_state.py) every increment of step 2 ends
    at the same exact state."""
    gamma, slip, e, depth, _ = exact_state(dim, "stick", 1.0)
    raw = dict(layer_problem(dim, "stick", 1.0).raw)
    raw["parameters"] = {"gamma": 0.0, "s": 0.0}
    v = "y" if dim == 2 else "z"
    u = [f"gamma*{v} + s"] + ["0"] * (dim - 2) + [f"-{e!r}*{v} - {depth!r}"]
    raw["loads"] = dict(raw["loads"], u_D=u)
    raw["exact"] = {"u": u}
    load = {"gamma": gamma, "s": slip}
    raw["steps"] = [{"set": load}, {"set": load, "increments": 4}]
    return nc.Problem.from_dict(raw, f"layer{dim}d-held")


def outcome(result, dim, mode, m_n):
    """The numbers a test checks, from :func:`nc.adapt`'s result."""
    row = result.history[-1]
    gamma, slip, e, depth, pressure = exact_state(dim, mode, m_n)
    base = L if dim == 2 else L * W
    V = result.final.u.function_space
    x = V.tabulate_dof_coordinates()[:, :dim]
    n = V.dofmap.index_map.size_local
    exact = np.zeros((len(x), dim))
    exact[:, 0] = gamma * x[:, -1] + slip
    exact[:, -1] = -e * x[:, -1] - depth
    error = np.abs(result.final.u.x.array.reshape(-1, dim)[:n] - exact[:n]).max(initial=0.0)
    measure = "length" if dim == 2 else "area"
    return {"nodal_error": MPI.COMM_WORLD.allreduce(float(error), MPI.MAX) / depth,
            "friction_force": row["friction_force"],
            "exact_friction_force": -MU * pressure * slip / max(slip, EPS_R * depth) * base,
            "contact_resultant": row["contact_resultant"], "exact_resultant": pressure * base,
            "stick": row[f"stick_{measure}"], "slip": row[f"slip_{measure}"], "base": base,
            "max_slip": row["max_slip"], "exact_slip": slip, "force_balance": row["force_balance"],
            "eta": row["eta"], "h1_error": row["h1_error"], "friction_passes": row["friction_passes"],
            "friction_newton": row["friction_newton"],
            "reaction_top": row["reaction_top"], "u": result.final.u.x.array[:n * dim].tolist(),
            "x": x[:n].tolist()}


if __name__ == "__main__":
    dim, mode, m_n = int(sys.argv[1]), sys.argv[2], float(sys.argv[3])
    problem = held_problem(dim) if "held" in sys.argv[4:] else layer_problem(dim, mode, m_n)
    result = outcome(nc.adapt(problem), dim, mode, m_n)
    gathered = MPI.COMM_WORLD.gather((result.pop("x"), result.pop("u")), root=0)
    if MPI.COMM_WORLD.rank == 0:
        points = np.concatenate([np.array(x) for x, _ in gathered])
        values = np.concatenate([np.array(u).reshape(-1, dim) for _, u in gathered])
        order = np.lexsort(np.round(points, 12).T[::-1])
        result["nodal_values"] = values[order].ravel().tolist()
        print(json.dumps(result))
