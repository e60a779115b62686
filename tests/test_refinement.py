"""Refinement keeps the geometry of boundary groups and material regions, on 1, 2 and 3 ranks, for 2D
triangles (a gmsh file) and 3D tetrahedra (the built-in box, a gmsh model, a user's DOLFINx mesh)."""
import json

import pytest

from conftest import ROOT, run


@pytest.fixture(scope="module")
def two_region_mesh(tmp_path_factory):
    """[0,2]x[0,1] split at x = 1 into regions 'soft' and 'hard'; groups left/bottom/top, right untagged."""
    import gmsh
    path = tmp_path_factory.mktemp("mesh") / "two_regions.msh"
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    occ = gmsh.model.occ
    r1, r2 = occ.addRectangle(0, 0, 0, 1, 1), occ.addRectangle(1, 0, 0, 1, 1)
    occ.fragment([(2, r1)], [(2, r2)])
    occ.synchronize()
    model = gmsh.model
    def curves(pred):
        return [c for _, c in model.getEntities(1) if pred(*occ.getCenterOfMass(1, c)[:2])]
    for name, pred in (("left", lambda x, y: abs(x) < 1e-9), ("bottom", lambda x, y: abs(y) < 1e-9),
                       ("top", lambda x, y: abs(y - 1) < 1e-9)):
        model.setPhysicalName(1, model.addPhysicalGroup(1, curves(pred)), name)
    for name, pred in (("soft", lambda x, y: x < 1), ("hard", lambda x, y: x > 1)):
        surf = [s for _, s in model.getEntities(2) if pred(*occ.getCenterOfMass(2, s)[:2])]
        model.setPhysicalName(2, model.addPhysicalGroup(2, surf), name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.25)
    model.mesh.generate(2)
    gmsh.write(str(path))
    gmsh.finalize()
    return path


MESHES = ("gmsh", "box", "gmsh3d", "dolfinx")  # see tests/mpi/refine_check.py
EXPECTED = {  # every group, the untagged boundary and every region keep their measure
    "gmsh": {"group:left": 1.0, "group:bottom": 2.0, "group:top": 2.0, "untagged": 1.0,
             "region:soft": 1.0, "region:hard": 1.0},
    "box": {"group:left": 1.0, "group:right": 1.0, "group:front": 2.0, "group:back": 2.0, "group:bottom": 2.0,
            "group:top": 2.0, "untagged": 0.0, "region:body": 2.0},
    "gmsh3d": {"group:left": 1.0, "group:bottom": 2.0, "group:top": 2.0, "untagged": 5.0,
               "region:soft": 1.0, "region:hard": 1.0},
    "dolfinx": {"group:left": 1.0, "group:5": 2.0, "group:nowhere": 0.0, "untagged": 7.0,
                "region:soft": 1.0, "region:untagged": 1.0},
}


@pytest.fixture(scope="module")
def levels(two_region_mesh):
    out = {}
    for nprocs in (1, 2, 3):
        args = [f"gmsh={two_region_mesh}" if mesh == "gmsh" else mesh for mesh in MESHES]
        proc = run([ROOT / "tests" / "mpi" / "refine_check.py", *args], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


@pytest.mark.parametrize("mesh", MESHES)
@pytest.mark.parametrize("nprocs", [1, 2, 3])
def test_groups_and_regions_keep_their_measure(levels, nprocs, mesh):
    rows = levels[nprocs][mesh]
    assert len(rows) == 4 and rows[-1]["cells"] > 2 * rows[0]["cells"]  # the refinements did happen
    assert set(EXPECTED[mesh]) | {"interior_facets", "facets_off_their_group", "cells"} == set(rows[0])
    for row in rows:
        for key, value in EXPECTED[mesh].items():
            assert row[key] == pytest.approx(value, rel=1e-12, abs=1e-12), key
        assert row["facets_off_their_group"] == 0


@pytest.mark.parametrize("mesh", MESHES)
@pytest.mark.parametrize("nprocs", [2, 3])
def test_parallel_refinement_is_the_serial_one(levels, nprocs, mesh):
    """Same cells, and every interior facet integrated once (DOLFINx 0.5 dropped some on 3 ranks)."""
    for serial, parallel in zip(levels[1][mesh], levels[nprocs][mesh]):
        assert parallel["cells"] == serial["cells"]
        assert parallel["interior_facets"] == pytest.approx(serial["interior_facets"], rel=1e-12)


@pytest.mark.parametrize("mesh", MESHES)
@pytest.mark.parametrize("nprocs", [1, 2, 3])
def test_solution_transfer_is_exact_for_linear_fields(levels, nprocs, mesh):
    for row in levels[nprocs][mesh][1:]:
        assert row["transfer_error"] < 1e-12
        assert row["transfer_located_points"] == 0  # every child vertex matched a vertex or edge midpoint


@pytest.mark.parametrize("gdim", [2, 3])
def test_point_matching(gdim):
    """Child vertices are matched to parent vertices/midpoints by rounded coordinates, never wrongly."""
    import numpy as np
    from nc_dolfinx.mesh.refinement import _match_points
    rng = np.random.default_rng(1)
    known = rng.random((1000, gdim)) * [3.0, 1e-3, 2.0][:gdim] + [-1.0, 5.0, 1e6][:gdim]
    a, b = known[:10], known[10:20]
    midpoints = 0.5 * (a + b)
    known = np.concatenate([known, midpoints])
    off = np.eye(gdim)[-1] * 1e-6  # off a known point in its last coordinate only
    wanted = np.concatenate([known[[5, 999, 3]], b * 0.5 + a * 0.5, np.full((1, gdim), 0.123), known[[7]] + off])
    index = _match_points(known, wanted)
    np.testing.assert_array_equal(index[:3], [5, 999, 3])
    np.testing.assert_array_equal(index[3:13], np.arange(1000, 1010))  # midpoints summed in the other order
    assert index[13] == -1 and index[14] == -1  # a far point, a point slightly off a known one
    # on the grid of 2^-30, (2, 2^31) packs like the known (3, 0): a point that far out is never matched
    square = np.array([[0.0, 0.0], [1.0, 1.0], [3 * 2.0 ** -30, 0.0]])
    np.testing.assert_array_equal(_match_points(square, np.array([[2.0 ** -29, 2.0], [1.0, 1.0]])), [-1, 1])
    merged = np.concatenate([known, known[:1] + 1e-14])  # two known points closer than the rounding
    assert np.all(_match_points(merged, wanted) == -1)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("nprocs", [2, 3])
def test_rebalanced_child_is_the_same_mesh_with_the_same_data(dim, nprocs):
    """Refinement towards one corner leaves the ranks unequally busy (a child on its parents' ranks: the
    busiest rank owns > 1.15 × the mean here); the rebalanced child (issue 30) owns ≤ 1.10 × the mean on
    every rank and is the very same mesh: every owned cell with its region, every boundary facet with its
    group and every dof of the transferred P1 field (non-linear nodal values) with its value equal, as sets
    over all ranks, to those of the child that was not moved (tests/mpi/balance_check.py)."""
    proc = run([ROOT / "tests" / "mpi" / "balance_check.py", str(dim), "3"], nprocs, timeout=600)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    levels = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    assert [level["level"] for level in levels] == [1, 2, 3]
    for level in levels:
        assert level["imbalance_unbalanced"] > 1.15 and level["moved"], level
        assert level["imbalance"] <= 1.10, level
        assert level["same_cells"] and level["same_facets"] and level["same_field"], level
