"""The true shape of a boundary (nc_dolfinx/mesh/surfaces.py, shape.py): projections onto surfaces and their
intersections against closed forms, the implicit surface's derived gradient against finite differences,
the problem-file keys and their errors, the interior's move where a snap would invert a cell, and the
geometric term on flat and curved boundaries."""
import numpy as np
import pytest
import ufl
from mpi4py import MPI

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.errors import InputError
from nc_dolfinx.mesh import refinement, shape, surfaces
from nc_dolfinx.mesh.domain import cell_space


def test_projection_onto_a_sphere_and_a_plane_lands_on_their_common_circle():
    """The great circle of the sphere |x − (0, 0, 1)| = 1 in the plane x = 0: the closest point of a point
    (0, y, z) of the plane is along the ray from the centre, in closed form."""
    rng = np.random.default_rng(1)
    x = np.column_stack([np.zeros(20), rng.uniform(-0.9, 0.9, 20), rng.uniform(0.2, 1.8, 20)])
    sphere, plane = surfaces.Sphere([0, 0, 1], 1.0), surfaces.Plane([0, 0, 0], [1, 0, 0])
    on = surfaces.project(x, [sphere, plane])
    ray = x - [0, 0, 1]
    expected = [0, 0, 1] + ray / np.linalg.norm(ray, axis=1)[:, None]
    assert np.abs(on - expected).max() < 1e-14
    x_off = x + [0.01, 0, 0]  # off the plane: onto both surfaces
    on = surfaces.project(x_off, [sphere, plane, sphere])  # a surface twice: equal rows, still one answer
    assert np.abs(sphere.phi(on)).max() < 1e-14 and np.abs(on[:, 0]).max() < 1e-14


def test_a_cylinder_s_distance_and_closest_points():
    cylinder = surfaces.Cylinder([1, 0, 0], [0, 0, 3], 0.5)
    x = np.array([[2.0, 0, 7], [1, -2, -1], [1.3, 0.4, 0]])
    assert np.allclose(cylinder.distance(x), [0.5, 1.5, 0.0], atol=1e-15)
    on = cylinder.closest(x)
    assert np.allclose(on[:, 2], x[:, 2]) and np.allclose(np.linalg.norm(on[:, :2] - [1, 0], axis=1), 0.5)


def test_an_implicit_surface_s_gradient_is_derived_and_its_projection_exact():
    """An ellipse x²/a² + (y − 1)² = 1 with a from the parameters: the derived gradient against central
    differences, and projected points on the ellipse to round-off, nearer than the points themselves."""
    ellipse = surfaces.Implicit("x**2/a**2 + (y - 1)**2 - 1", {"a": 2.0}, 2)
    rng = np.random.default_rng(2)
    x = rng.uniform([-2.5, -0.5], [2.5, 2.5], (30, 2))
    h = 1e-6
    numeric = np.column_stack([(ellipse.phi(x + h * e) - ellipse.phi(x - h * e)) / (2 * h) for e in np.eye(2)])
    assert np.abs(ellipse.gradient(x) - numeric).max() < 1e-7
    on = surfaces.project(x, [ellipse])
    assert np.abs(on[:, 0] ** 2 / 4 + (on[:, 1] - 1) ** 2 - 1).max() < 1e-13
    # the closest point: no sampled point of the ellipse is nearer
    t = np.linspace(0, 2 * np.pi, 20001)
    curve = np.column_stack([2 * np.cos(t), 1 + np.sin(t)])
    nearest = np.min(np.linalg.norm(x[:, None] - curve[None], axis=2), axis=1)
    assert np.all(np.linalg.norm(x - on, axis=1) <= nearest + 1e-6)


def test_a_surface_a_point_cannot_reach_is_one_clear_error():
    never = surfaces.Implicit("x**2 + y**2 + 1", {}, 2)
    with pytest.raises(InputError, match="do not reach it"):
        surfaces.project(np.array([[0.3, 0.2]]), [never])


def _disc_problem(shapes, group="top"):
    """A rectangle on 2 × 2 cells whose top side is the group 'top'; ``group`` is given the shape ``shapes``
    (a table)."""
    return nc.Problem.from_dict({
        "mesh": {"rectangle": [[-1, 0], [1, 1]], "cells": [2, 2], "dirichlet": ["bottom"], "contact": ["top"],
                 "shapes": {group: shapes}},
        "material": {"E": 1.0, "nu": 0.3}, "contact": {"c_n": 1.0, "m_n": 1}, "loads": {"u_D": ["0", "0.02"]}})


@pytest.mark.parametrize("shapes, message", [
    ({"sphere": {"centre": [0, 0, 0], "radius": 1}}, "the mesh is 2D, a sphere is a 3D shape"),
    ({"circle": {"centre": [0, 0], "radius": 1}, "implicit": "y - 1"}, "exactly one of"),
    ({"circle": {"centre": [0, 0, 0], "radius": 1}}, "centre has 3 components"),
    ({"circle": {"centre": [0, -3], "radius": 4.5}}, "lies .* from its circle"),
    ({"plane": {"point": [0, 1], "normal": [0, 0]}}, "must not be the zero vector"),
])
def test_a_shape_that_does_not_fit_is_refused_naming_the_group(shapes, message):
    problem = _disc_problem(shapes)
    with pytest.raises(InputError, match=message) as err:
        nc.bind(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    assert "mesh.shapes.top" in str(err.value)


def test_a_shape_of_a_group_the_mesh_lacks_is_refused():
    problem = _disc_problem({"implicit": "y - 1"}, group="tpo")
    with pytest.raises(InputError, match="mesh.shapes.tpo: no boundary group of that name"):
        nc.bind(problem, nc.build_domain(problem, MPI.COMM_WORLD))


def _bump(a):
    """The top side bent into y = 1 + a x² (x² − 1): through the level-0 vertices x = −1, 0, 1 of a 2 × 2
    rectangle, a dip of 3a/16 at x = ±1/2 where refinement puts the top's new vertices."""
    return {"implicit": f"y - 1 - {a}*x**2*(x**2 - 1)"}


def test_a_snap_that_would_invert_a_cell_moves_the_interior_along():
    """a = 3: the top's new vertices (±1/2, 1) go to their closest points on the curve, far below the
    interior vertices under them: the snapped cells alone would invert. The interior follows (harmonic
    extension), every cell keeps its orientation, and the transfer still sees the nested positions."""
    problem = _disc_problem(_bump(3))
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    nc.bind(problem, domain)
    child = nc.refine(domain)
    x, nested = child.mesh.geometry.x[:, :2], refinement._NESTED[child.mesh][:, :2]
    curve = surfaces.Implicit(_bump(3)["implicit"], {}, 2)
    new_top = np.isclose(nested[:, 1], 1.0) & np.isclose(np.abs(nested[:, 0]), 0.5)
    assert new_top.sum() == 2
    assert np.abs(curve.phi(x[new_top])).max() < 1e-13
    normal = curve.gradient(x[new_top])
    move = nested[new_top] - x[new_top]
    assert np.abs(normal[:, 0] * move[:, 1] - normal[:, 1] * move[:, 0]).max() < 1e-12  # along the normal
    boundary = np.isclose(np.abs(nested[:, 0]), 1) | np.isclose(nested[:, 1], 0) | np.isclose(nested[:, 1], 1)
    assert np.linalg.norm(x[~boundary] - nested[~boundary], axis=1).max() > 0.05  # the interior followed
    quality_now, quality_nested = shape.cell_quality(child.mesh), shape.cell_quality(child.mesh, refinement._NESTED[child.mesh])
    assert np.all(quality_now * np.sign(quality_nested) > 0.05)


def test_a_snap_no_interior_move_can_save_is_one_clear_error():
    problem = _disc_problem(_bump(40))
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    nc.bind(problem, domain)
    with pytest.raises(InputError, match="refinement onto the shape of 'top'.*too coarse"):
        nc.refine(domain)


def test_flat_boundaries_have_no_geometric_term_and_mark_as_before():
    problem = nc.load_problem("block", ["adapt.refine=none"])
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    est = nc.estimate(solution.u, solution.fields)
    assert est.totals["eta_geometry"] == 0.0 and est.totals["geometry_sag"] == 0.0
    # marking reads η_K² alone: the squares of the written η_K (a square root and its square: round-off)
    assert np.allclose(est.squares, est.fields["eta"].x.array[:len(est.squares)] ** 2, rtol=1e-14, atol=0)


def test_the_geometric_term_is_the_chord_s_sag_times_the_boundary_stress():
    """On the bent top (a = 0.5, exact on the level-0 vertices), δ_F of each top edge is its largest
    distance from the curve (at its midpoint, to first order), and η_geo² = Σ δ_F |F| |σ|² over the top:
    recomputed here from the cell stresses."""
    problem = _disc_problem(_bump(0.5))
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    solution = nc.solve(problem, domain)
    est = nc.estimate(solution.u, solution.fields)
    midpoints = np.array([[-0.5, 1.0], [0.5, 1.0]])
    curve = surfaces.Implicit(_bump(0.5)["implicit"], {}, 2)
    sag = curve.distance(midpoints)
    assert est.totals["geometry_sag"] == pytest.approx(sag.max(), rel=1e-12)
    stress = nc.sigma(solution.u, *nc.lame(1.0, 0.3))
    msh = domain.mesh
    top = domain.facet_tags.indices[domain.facet_tags.values == domain.facet_groups["top"]]
    _, cells, _ = shape.cells_of_facets(msh, top)
    Q = cell_space(msh, 1)
    energy = nc.assemble_cellwise(ufl.inner(stress, stress) * ufl.TestFunction(Q) * ufl.dx, Q)[:, 0]
    area = nc.assemble_cellwise(ufl.TestFunction(Q) * ufl.dx, Q)[:, 0]
    by_cell = energy[cells] / area[cells]  # |σ|² on each top cell (constant there)
    centres = msh.geometry.x[versions.entities_to_geometry(msh, 1, top)].mean(axis=1)
    delta = curve.distance(centres[:, :2])
    expected = np.sqrt(np.sum(delta * 1.0 * by_cell))  # |F| = 1
    assert est.totals["eta_geometry"] == pytest.approx(expected, rel=1e-10)


@pytest.mark.parametrize("case", ["fichera", "corner"])
def test_the_edges_of_a_flat_faced_group_are_not_curvature(case):
    """A group of flat faces meeting at edges (the Fichera corner's 'free', the corner case's L): no level-0
    sag, no warning, no geometric term — an unbalanced mean normal at an edge once read as a 60° curve."""
    problem = nc.load_problem(case)
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    fields = nc.bind(problem, domain)
    assert all(sag == 0.0 for sag in domain.shapes.sag.values()), domain.shapes.sag
    assert not any("is given no shape" in text for text in fields.warnings)
