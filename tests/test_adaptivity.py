"""Adaptivity wins on the singular `corner` case; the `hertz` case approaches 2D Hertz contact."""
import numpy as np
import pytest

from conftest import ROOT
import dolfinx
from dolfinx import mesh as dmesh

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions

CASES = ROOT / "nc_dolfinx" / "cases"


def run(case, overrides=(), **settings):
    problem = nc.load_problem(case, list(overrides))
    result = nc.adapt(problem, nc.AdaptSettings.from_problem(problem, **settings))
    final, history = result.final, result.history
    return problem, final, history


def slope(rows, last=4):
    dofs = np.array([r["dofs"] for r in rows[-last:]], dtype=float)
    eta = np.array([r["eta"] for r in rows[-last:]])
    return np.polyfit(np.log(dofs), np.log(eta), 1)[0]


@pytest.fixture(scope="module")
def corner_runs():
    return run("corner", refine="adaptive", levels=12), run("corner", refine="uniform", levels=5)


def test_adaptive_refinement_restores_the_optimal_rate(corner_runs):
    (_, _, adaptive_rows), (_, _, uniform_rows) = corner_runs
    assert slope(adaptive_rows) <= -0.45
    assert slope(uniform_rows) >= slope(adaptive_rows) + 0.1  # the singularity slows uniform refinement
    # at equal cost adaptivity is more accurate
    dofs = uniform_rows[-1]["dofs"]
    adaptive_eta = np.interp(np.log(dofs), np.log([r["dofs"] for r in adaptive_rows]),
                             [r["eta"] for r in adaptive_rows])
    assert adaptive_eta < 0.75 * uniform_rows[-1]["eta"]


def test_refined_cells_cluster_at_the_singularities(corner_runs):
    """The smallest cells sit at the singular corners: (0, 2) where the clamp meets the loaded edge,
    the re-entrant corner (1, 1), and (0, 0) where Γ_D meets Γ_C; the convex corners stay coarse."""
    (_, final, _), _ = corner_runs
    msh = final.u.function_space.mesh
    cells = np.arange(msh.topology.index_map(2).size_local, dtype=np.int32)
    size = versions.diameters(msh, 2, cells)
    mid = dmesh.compute_midpoints(msh, 2, cells)[:, :2]
    singular = np.array([[0.0, 2.0], [1.0, 1.0], [0.0, 0.0]])
    convex = np.array([[2.0, 0.0], [2.0, 1.0], [1.0, 2.0]])
    near = lambda points: np.linalg.norm(mid[:, None] - points[None], axis=2).min(axis=1)  # noqa: E731
    smallest = np.argsort(size)[:500]
    assert np.all(near(singular)[smallest] < 0.01)
    for point in singular:
        assert size[np.linalg.norm(mid - point, axis=1) < 0.01].min() < 1e-3
    for point in convex:
        assert size[np.linalg.norm(mid - point, axis=1) < 0.1].min() > 5e-3


def test_hertz_half_width_and_peak_pressure():
    """Within 3 % of 2D Hertz (for the computed force) once the contact zone is resolved (5 levels)."""
    problem, _, rows = run("hertz", refine="adaptive", levels=6)
    for quantity, computed, expected in nc.compare_with_reference(problem, rows[-1]):
        assert computed == pytest.approx(expected, rel=0.03), quantity
    assert rows[-1]["contact_length"] / 2 < 0.1  # a << R: the regime where Hertz applies
