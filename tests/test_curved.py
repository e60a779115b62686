"""Curved bodies (issue 46): a coarse half-disc (and quarter ball) refined onto the shape its problem file
gives. Vertices land on the surface, η_geo falls with the shape and not without, the history does not
depend on the rank count, a wrong shape is one error line, a faceted group a warning, an implicit surface is
snapped to like an analytic one, and the transfer to a snapped child is the parent's P1 function at the
parent-edge midpoints. The problems and meshes are verification/curved.py's (meshes/halfdisc.py,
meshes/quarterball.py), at coarse sizes. (Unit tests of shape.py and surfaces.py: tests/test_shapes.py.)"""
import dataclasses

import numpy as np
import pytest

from conftest import ROOT, history, import_script, run_cli
from test_bad_input import assert_bad_input, cli as bad_cli

curved = import_script("verification", "curved")

H_2D = 0.25            # the half-disc's coarse size here (the study's is R/10)
H_3D = 0.25            # the quarter ball's
ON_CIRCLE = 1e-12


@pytest.fixture(scope="module")
def meshes(tmp_path_factory):
    folder = tmp_path_factory.mktemp("curved_meshes")
    return {2: curved.make_mesh(2, H_2D, folder / "halfdisc.msh"), 3: curved.make_mesh(3, H_3D, folder / "quarterball.msh")}


def _adapt(path, **settings):
    import nc_dolfinx as nc
    problem = nc.load_problem(str(path))
    return nc.adapt(problem, nc.AdaptSettings.from_problem(problem, **settings))


def _group_vertices(domain, names):
    """Coordinates of the vertices of the facets of the named groups (this rank's)."""
    from nc_dolfinx import dolfinx_versions as versions
    msh, tags = domain.mesh, domain.facet_tags
    ids = [domain.facet_groups[n] for n in names]
    facets = tags.indices[np.isin(tags.values, ids)]
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)
    return msh.geometry.x[np.unique(nodes.reshape(-1)), :msh.geometry.dim]


def test_vertices_on_the_circle_and_the_geometric_term(meshes, tmp_path):
    shaped = _adapt(curved.write_problem(tmp_path, 2, meshes[2], True), refine="uniform", levels=4)
    x = _group_vertices(shaped.final.solution.domain, ["contact", "free"])
    assert len(x) > 4 * 16  # (three bisections of the coarse arcs)
    distance = np.abs(np.hypot(x[:, 0], x[:, 1] - 1) - 1)
    assert distance.max() <= ON_CIRCLE, distance.max()
    geometry = [r["eta_geometry"] for r in shaped.history]
    assert all(b < 0.7 * a for a, b in zip(geometry, geometry[1:])), geometry  # ∝ h: halves per level
    faceted = _adapt(curved.write_problem(tmp_path, 2, meshes[2], False), refine="uniform", levels=4)
    x = _group_vertices(faceted.final.solution.domain, ["contact", "free"])
    assert np.abs(np.hypot(x[:, 0], x[:, 1] - 1) - 1).max() > 1e-3  # new vertices on the chords
    geometry = [r["eta_geometry"] for r in faceted.history]
    assert min(geometry) > 0.8 * geometry[0], geometry  # the level-0 sag stays


KEYS = ("eta", "eta_1", "eta_2", "eta_3", "eta_4", "eta_geometry", "geometry_sag", "contact_resultant",
        "elastic_energy", "max_contact_pressure", "max_penetration")


@pytest.mark.parametrize("dim, levels", [(2, 4), (3, 2)])
def test_the_same_history_on_1_2_3_ranks(meshes, tmp_path, dim, levels):
    problem = curved.write_problem(tmp_path, dim, meshes[dim], True)
    histories = {}
    for nprocs in (1, 2, 3):
        out = tmp_path / f"out{nprocs}"
        proc = run_cli([problem, "--refine", "adaptive", "--levels", str(levels), "--out", out, "--quiet"], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        histories[nprocs] = history(out)
    serial = histories[1]
    assert serial[-1]["dofs"] > serial[0]["dofs"] and serial[-1]["eta_geometry"] < serial[0]["eta_geometry"]
    for nprocs in (2, 3):
        assert len(histories[nprocs]) == len(serial)
        for s, p in zip(serial, histories[nprocs]):
            assert (p["dofs"], p["cells"]) == (s["dofs"], s["cells"]), (nprocs, s["level"])
            for key in KEYS:
                assert p[key] == pytest.approx(s[key], rel=1e-8, abs=1e-14), (nprocs, key, s["level"])


@pytest.mark.parametrize("nprocs", [1, 2])
def test_a_shape_the_mesh_does_not_lie_on_is_one_error(meshes, tmp_path, nprocs):
    wrong = curved.shape_table(2, ["contact"], radius=1.1)
    problem = curved.write_problem(tmp_path, 2, meshes[2], shapes_text=wrong)
    out = tmp_path / "out"
    result = bad_cli([problem, "--levels", "2", "--out", out], nprocs)
    assert_bad_input(result, "group 'contact' lies 0.1", out, nprocs)


def test_a_faceted_group_is_named_in_a_warning(meshes, tmp_path):
    problem = curved.write_problem(tmp_path, 2, meshes[2], False)
    proc = run_cli([problem, "--refine", "none", "--out", tmp_path / "out"])
    assert proc.returncode == 0, proc.stdout + proc.stderr
    warnings = [line for line in (proc.stdout + proc.stderr).splitlines() if "warning" in line]
    for group, role in (("contact", "contact"), ("free", "neumann")):
        assert any(f"boundary group '{group}' ({role})" in line and "[mesh.shapes." in line for line in warnings), warnings
    assert not any("'top'" in line for line in warnings), warnings  # flat: found, not warned
    # and, after the solve, the sag against the penetration (h = R/10: the chords' sag is ~20 × the penetration)
    against = [line for line in warnings if "× the largest penetration" in line]
    assert len(against) == 1 and float(against[0].split("smooth surface by up to ")[1].split(",")[0]) > 0
    shaped = run_cli([curved.write_problem(tmp_path, 2, meshes[2], True), "--refine", "none", "--out", tmp_path / "o2"])
    assert shaped.returncode == 0 and "is given no shape" not in shaped.stdout + shaped.stderr
    assert "shaped by the facets" not in shaped.stdout + shaped.stderr


def _stretched(source, target, a):
    """The half-disc mesh stretched by ``a`` along x: its arc lies on the ellipse (x/a)² + (y − 1)² = 1."""
    lines = source.read_text().splitlines()
    start, end = lines.index("$Nodes"), lines.index("$EndNodes")
    i = start + 2
    while i < end:
        _, _, parametric, count = map(int, lines[i].split())
        for j in range(i + 1 + count, i + 1 + 2 * count):
            x, y, z = map(float, lines[j].split()[:3])
            lines[j] = f"{a * x!r} {y!r} {z!r}"
        i += 1 + 2 * count
    target.write_text("\n".join(lines) + "\n")
    return target


def test_an_implicit_surface_is_snapped_to_like_an_analytic_one(meshes, tmp_path):
    implicit = curved.shape_table(2, text='implicit = "x**2 + (y - 1)**2 - 1"')
    circle = _adapt(curved.write_problem(tmp_path, 2, meshes[2], True), refine="uniform", levels=3)
    by_phi = _adapt(curved.write_problem(tmp_path, 2, meshes[2], shapes_text=implicit, name="phi.toml"),
                    refine="uniform", levels=3)
    a, b = (r.final.solution.domain.mesh.geometry.x for r in (circle, by_phi))
    assert np.abs(a - b).max() <= ON_CIRCLE
    a_x = 1.6
    ellipse = _stretched(meshes[2], tmp_path / "ellipse.msh", a_x)
    shapes = curved.shape_table(2, text=f'implicit = "(x/{a_x})**2 + (y - 1)**2 - 1"')
    result = _adapt(curved.write_problem(tmp_path, 2, ellipse, shapes_text=shapes, name="ellipse.toml"),
                    refine="uniform", levels=3)
    x = _group_vertices(result.final.solution.domain, ["contact", "free"])
    t = np.arctan2(x[:, 1] - 1, x[:, 0] / a_x)
    off = np.hypot(x[:, 0] - a_x * np.cos(t), x[:, 1] - 1 - np.sin(t))  # ≥ the distance to the ellipse
    phi = (x[:, 0] / a_x) ** 2 + (x[:, 1] - 1) ** 2 - 1
    assert np.abs(phi).max() <= 4 * ON_CIRCLE and off.max() <= 4 * ON_CIRCLE, (np.abs(phi).max(), off.max())


def test_the_transfer_to_a_snapped_child_is_the_parent_at_edge_midpoints(meshes):
    from mpi4py import MPI
    from dolfinx import fem
    import nc_dolfinx as nc
    from nc_dolfinx import dolfinx_versions as versions
    from nc_dolfinx.mesh import shape, surfaces
    from nc_dolfinx.mesh.domain import dof_of_node
    from nc_dolfinx.mesh.refinement import evaluate

    parent = nc.from_gmsh(MPI.COMM_SELF, str(meshes[2]))
    circle = surfaces.Sphere([0.0, 1.0], 1.0)
    shape.resolve(parent, extra={parent.facet_groups[g]: circle for g in ("contact", "free")})
    V = versions.p1_space(parent.mesh, (2,))
    u = fem.Function(V)
    u.interpolate(lambda x: np.vstack([np.sin(3 * x[0]) + x[1] ** 2, np.exp(x[0] * x[1])]))
    snapped = nc.refine(parent)
    straight = nc.refine(dataclasses.replace(parent, shapes=None))  # the same Plaza, no snap
    xs, xf = snapped.mesh.geometry.x, straight.mesh.geometry.x
    moved = np.linalg.norm(xs - xf, axis=1) > 1e-12
    assert moved.sum() >= 8, moved.sum()  # the new vertices of the arcs
    on_arc = np.abs(np.hypot(xs[moved, 0], xs[moved, 1] - 1) - 1)
    assert on_arc.max() <= ON_CIRCLE
    child = nc.transfer(u, versions.p1_space(snapped.mesh, (2,)))
    values = child.x.array.reshape(-1, 2)[dof_of_node(child.function_space)]  # per geometry node
    expected = evaluate(u, xf)  # the parent's P1 function where the child's vertices were born
    assert np.abs(values - expected).max() <= 1e-12


def test_the_benchmark_runs_at_a_tiny_size(tmp_path):
    """benchmarks/curved_refinement.py, 1 rank, tiny meshes: its table and rows (snap timed, children larger)."""
    import json
    from conftest import run
    out = tmp_path / "rows.json"
    proc = run([ROOT / "benchmarks" / "curved_refinement.py", "--np", "1", "--sizes2d", "0.25", "--sizes3d", "0.5",
                "--repeat", "1", "--json-out", out], timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "- commit:" in proc.stdout and "snap/refine" in proc.stdout
    rows = json.loads(out.read_text())
    assert {(r["body"], r["marking"]) for r in rows} == {(b, m) for b in ("half-disc", "quarter ball")
                                                         for m in ("uniform", "local")}
    assert all(r["cells"] > r["parent_cells"] and r["t_snap"] > 0 for r in rows)


def test_a_frictional_load_path_refines_onto_the_circle_on_1_and_2_ranks(tmp_path):
    """The built-in cattaneo (friction, a load path of three steps) refined adaptively after each step with
    its circle: the slip history moves to snapped meshes, and 1 and 2 ranks give the same states."""
    histories = {}
    for nprocs in (1, 2):
        out = tmp_path / f"out{nprocs}"
        proc = run_cli(["cattaneo", "--refine", "adaptive", "--levels", "2", "--out", out, "--quiet"], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        histories[nprocs] = history(out)
    serial = histories[1]
    assert serial[-1]["dofs"] > serial[0]["dofs"] and "is given no shape" not in proc.stdout + proc.stderr
    assert serial[-1]["stick_length"] > 0 and serial[-1]["slip_length"] > 0
    for s, p in zip(serial, histories[2]):
        assert p["dofs"] == s["dofs"]
        for key in ("friction_force", "stick_length", "slip_length", "contact_resultant", "eta_geometry"):
            assert np.allclose(p[key], s[key], rtol=1e-7, atol=1e-12), (key, s["level"])
