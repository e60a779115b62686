"""Limits of the model: c_n = 0 is linear elasticity; c_n → ∞ with m_n = 1 is the Signorini penalty."""
import numpy as np
import pytest
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from conftest import ROOT, run_cli, summary
from dolfinx import fem
from nc_dolfinx import dolfinx_versions as versions

import nc_dolfinx as nc

BLOCK = ROOT / "nc_dolfinx" / "cases" / "block.toml"


def test_zero_compliance_is_linear_elasticity():
    """c_n = 0: the Newton solution equals an independent linear elasticity solve to solver tolerance."""
    problem = nc.load_problem(BLOCK, ["contact.c_n=0", "mesh.cells=[12,6]"])
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    domain, u, stats = solution.domain, solution.u, solution.stats

    # Independent solve: a(w, v) = (f, v) + (g, v)_top, clamped left side, written from scratch here.
    msh = domain.mesh
    V = u.function_space
    E, nu = 1.0e3, 0.3
    mu, lmbda = E / (2 * (1 + nu)), E * nu / ((1 + nu) * (1 - 2 * nu))
    w, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    eps = lambda z: ufl.sym(ufl.grad(z))  # noqa: E731
    a = ufl.inner(2 * mu * eps(w) + lmbda * ufl.tr(eps(w)) * ufl.Identity(2), eps(v)) * ufl.dx
    x = ufl.SpatialCoordinate(msh)
    ds = ufl.Measure("ds", domain=msh, subdomain_data=domain.facet_tags)
    L = ufl.inner(ufl.as_vector([0, -10.0]), v) * ufl.dx + ufl.inner(ufl.as_vector([0, -20 * x[0]]), v) * ds(4)
    left = domain.facet_tags.indices[domain.facet_tags.values == 1]
    bc = fem.dirichletbc(np.zeros(2, dtype=PETSc.ScalarType), fem.locate_dofs_topological(V, 1, left), V)
    reference = versions.solve_linear_problem(a, L, [bc], {"ksp_type": "preonly", "pc_type": "lu"})
    diff = np.linalg.norm(u.x.array - reference.x.array) / np.linalg.norm(reference.x.array)
    assert diff < 1e-10
    assert stats.newton_iterations == 1  # a linear problem: one Newton step


def test_reaction_of_a_clamped_bar_in_tension_is_the_pull():
    """No contact (a gap of 10), the block [0,2]×[0,1] clamped on the left and pulled on the right by
    g = (3, 1 − 2y) (resultant (3, 0)), no weight: the clamp's reaction is (−3, 0), whatever the mesh, since
    the residual sums to the load on the free dofs' complement; the force balance closes."""
    problem = nc.load_problem(BLOCK, ["contact.gap=10", 'loads.f=["0", "0"]', 'loads.g={right = ["3", "1 - 2*y"]}',
                                      "mesh.cells=[10, 5]"])
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    q = nc.solution_quantities(solution.u, solution.fields)
    assert q["contact_resultant"] == 0
    assert q["applied_load"] == pytest.approx([3.0, 0.0], abs=1e-12)
    assert q["reaction_left"] == pytest.approx([-3.0, 0.0], abs=1e-9)
    assert q["force_balance"] < 1e-10


@pytest.mark.parametrize("m_n", [1])
def test_penetration_shrinks_like_one_over_c_n(tmp_path, m_n):
    """Remark 1: m_n = 1, c_n = 1/ε → (u_n)_+ = O(ε) while the contact pressure converges."""
    penetration, pressure = [], []
    for c_n in (1e5, 1e6, 1e7):
        out = tmp_path / f"c{c_n:g}"
        proc = run_cli(["block", "--out", out, "--refine", "none", "--quiet", "--set", f"contact.m_n={m_n}",
                        "--set", f"contact.c_n={c_n}", "--set", "mesh.cells=[24,12]"])
        assert proc.returncode == 0, proc.stdout + proc.stderr
        s = summary(out)
        penetration.append(s["max_penetration"])
        pressure.append(s["max_penetration"] * c_n)
    ratios = np.array(penetration[:-1]) / np.array(penetration[1:])
    assert ratios == pytest.approx(10.0, rel=0.05)
    assert pressure[2] == pytest.approx(pressure[1], rel=0.01)
