"""The 3D cases (box, hertz3d, manufactured3d, fichera): the manufactured solution satisfies the law
exactly (sympy), every case validates, solves and gives the same numbers on 1, 2 and 3 ranks.
"""
import json

import numpy as np
import pytest
import sympy as sp

from conftest import ROOT, run
from nc_dolfinx.physics import lame
from nc_dolfinx.problem import read_toml

import nc_dolfinx as nc

CASES_3D = ("box", "hertz3d", "manufactured3d", "fichera")
MANUFACTURED = ROOT / "nc_dolfinx" / "cases" / "manufactured3d.toml"
# small enough for CI: the built-in boxes get coarser cells, the gmsh cases keep their level-0 meshes
TINY = {"box": ["mesh.cells=[6,3,3]"], "manufactured3d": ["mesh.cells=[3,3,3]"], "hertz3d": [], "fichera": []}


# --- the manufactured solution, symbolically ------------------------------------------------------------

def sympy_exact(m, c=None):
    """u of manufactured3d.toml as sympy expressions, with its parameters (m, and c if given, replaced)."""
    data = read_toml(MANUFACTURED)
    x, y, z = sp.symbols("x y z", real=True)
    params = {}
    for name, value in data["parameters"].items():
        params[name] = sp.sympify(value, locals=params) if isinstance(value, str) else sp.nsimplify(value)
        if name == "m":
            params["m"] = sp.nsimplify(m)
        if name == "c" and c is not None:
            params["c"] = sp.nsimplify(c)
    names = {**params, "x": x, "y": y, "z": z, "pos": lambda a: sp.Max(a, 0)}
    u = sp.Matrix([sp.sympify(text, locals=names) for text in data["exact"]["u"]])
    return (x, y, z), u, params


def stress(u, X, params):
    lmbda, mu = (sp.nsimplify(v) for v in lame(float(params["E"]), float(params["nu"])))
    grad = u.jacobian(X)
    eps = (grad + grad.T) / 2
    return lmbda * eps.trace() * sp.eye(3) + 2 * mu * eps, lmbda + 2 * mu


@pytest.mark.parametrize("m,c", [(1, 10), (1.5, 10), (2, 0.1), (3, 1000)])
def test_manufactured3d_satisfies_the_law_symbolically(m, c):
    (x, y, z), u, params = sympy_exact(m, c)
    sigma, L = stress(u, (x, y, z), params)
    assert sp.simplify(params["L"] - L) == 0  # the file's L is λ + 2μ
    nu_c = sp.Matrix([0, 0, -1])              # outward normal of Γ_C = {z = 0}
    at_contact = {z: 0}
    u_n = (u.T * nu_c)[0].subs(at_contact)
    traction = (sigma * nu_c).subs(at_contact)
    sigma_n = (traction.T * nu_c)[0]
    sigma_t = traction - sigma_n * nu_c
    # σ_t = 0 componentwise, identically in (x, y)
    assert all(sp.simplify(component) == 0 for component in sigma_t)
    # σ_n = −c (u_n)_+^m: on a grid of Γ_C covering both contact (u_n > 0) and gap (u_n < 0)
    law = sp.lambdify((x, y), sigma_n + params["c"] * sp.Max(u_n, 0) ** params["m"], "mpmath")
    values = sp.lambdify((x, y), u_n, "mpmath")
    grid = np.linspace(0, 1, 17)
    scale = float(params["c"]) * 0.5 ** (3 * m) + 1  # the size of the terms of the law
    assert max(abs(float(law(a, b))) for a in grid for b in grid) < 1e-12 * scale
    un = [float(values(a, b)) for a in grid for b in grid]
    assert min(un) < 0 < max(un)  # a free boundary: contact and gap both present
    # Γ_D = {z = 1} is clamped
    assert all(sp.simplify(component.subs(z, 1)) == 0 for component in u)


# --- every case validates, solves, and gives the same numbers on 1, 2, 3 ranks --------------------------

@pytest.mark.parametrize("case", CASES_3D)
def test_case_validates(case):
    problem = nc.load_problem(case)
    assert problem.title.startswith(f"{case}:")
    assert problem["adapt.refine"] in ("adaptive", "uniform")


@pytest.fixture(scope="module", params=CASES_3D)
def solved(request):
    out = {}
    for nprocs in (1, 2, 3):
        proc = run([ROOT / "tests" / "mpi" / "case_quantities.py", request.param, *TINY[request.param]], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = json.loads(proc.stdout.strip().splitlines()[-1])
    return request.param, out


# In 3D the default linear solver is GAMG, whose aggregates depend on the partition: the Newton iterates,
# and at times their number, differ between rank counts, the converged solutions agree to the tolerance.
EXACT = ("dofs", "cells")
CLOSE = ("u_l2", "elastic_energy", "contact_resultant", "max_contact_pressure", "max_penetration",
         "contact_area", "h1_error", "l2_error")


@pytest.mark.parametrize("nprocs", [2, 3])
def test_cases_agree_on_1_2_3_ranks(solved, nprocs):
    case, runs = solved
    for serial, parallel in zip(runs[1], runs[nprocs]):
        for key in EXACT:
            assert serial[key] == parallel[key], (case, key)
        for key in CLOSE:
            if key in serial:
                assert parallel[key] == pytest.approx(serial[key], rel=1e-8, abs=1e-14), (case, key)


def test_cases_touch_the_foundation(solved):
    """Every case is in contact, and on a flat Γ_C (all but hertz3d) the contact force on the body points
    straight up: frictionless contact on the plane z = const has no horizontal component."""
    case, runs = solved
    for row in runs[1]:
        assert row["contact_resultant"] > 0 and row["contact_area"] > 0
        fx, fy, fz = row["contact_force"]
        assert fz > 0
        if case != "hertz3d":
            assert abs(fx) < 1e-12 * fz and abs(fy) < 1e-12 * fz
