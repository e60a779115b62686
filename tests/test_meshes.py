"""Mesh constructors and the geometric boundary matcher, in 2D and 3D; unsupported meshes refused clearly.

Serial, in this process (small meshes); the refinement of these meshes on 1-3 ranks is in
test_refinement.py, the error broadcast on 2 ranks at the end of this file.
"""
import contextlib
import json
import os
import signal
import subprocess

import numpy as np
import pytest
from mpi4py import MPI
from dolfinx import mesh as dmesh

from conftest import PYTHON, ROOT, mpirun_prefix, run
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.mesh import builtin, domain as mesh_domain, gmsh_io, tagged
from nc_dolfinx.errors import InputError
from mpi.boundary_oracle import gather_boundary

COMM = MPI.COMM_WORLD
SUPPORTED = "only linear triangles (2D) and tetrahedra (3D) are supported"


# --- distances and matching -------------------------------------------------------------------

def test_distance_to_a_triangle_in_3d():
    triangle = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    points = np.array([[0.2, 0.2, 0.5], [2, 0, 0], [0.5, -1, 0], [1, 1, 1], [-1, -1, 0], [0.1, 0.3, 0]])
    expected = [0.5, 1.0, 1.0, np.sqrt(1.5), np.sqrt(2), 0.0]  # face, vertex, edge, edge, vertex, inside
    got = mesh_domain.distance_to_simplices(points, np.repeat(triangle[None], len(points), 0))
    np.testing.assert_allclose(got, expected, rtol=1e-14, atol=1e-15)


def test_distance_to_a_segment_in_2d():
    segment = np.array([[0.0, 0], [2, 0]])
    points = np.array([[1.0, 1], [3, 0], [-1, -1], [0.5, 0]])
    got = mesh_domain.distance_to_simplices(points, np.repeat(segment[None], len(points), 0))
    np.testing.assert_allclose(got, [1, 1, np.sqrt(2), 0], rtol=1e-14, atol=1e-15)


def test_distance_to_random_triangles_matches_sampling():
    """Exact distance <= distance to any sampled point of the triangle <= exact + sampling spacing."""
    rng = np.random.default_rng(3)
    vertices, points = rng.random((50, 3, 3)), rng.random((50, 3)) * 2 - 0.5
    exact = mesh_domain.distance_to_simplices(points, vertices)
    n = 60
    i, j = np.meshgrid(np.arange(n + 1), np.arange(n + 1))
    keep = i + j <= n
    bary = np.stack([i[keep], j[keep], n - i[keep] - j[keep]], 1) / n
    samples = np.einsum("sk,pkg->psg", bary, vertices)
    sampled = np.linalg.norm(samples - points[:, None], axis=-1).min(axis=1)
    spacing = np.linalg.norm(vertices - np.roll(vertices, 1, axis=1), axis=-1).max(axis=1) / n
    assert np.all(exact <= sampled + 1e-14) and np.all(sampled <= exact + spacing)


def test_matching_finds_a_big_simplex_behind_many_small_ones():
    """A point on a long segment whose 8 nearest centroids belong to small segments elsewhere (a graded
    level-0 mesh) is still tagged with the long segment's group, by the fallback search."""
    small = np.stack([np.stack([np.full(20, 10.0), np.arange(20) / 100], 1),
                      np.stack([np.full(20, 10.0), np.arange(1, 21) / 100], 1)], axis=1)  # on x = 10
    vertices = np.concatenate([[[[0.0, 0], [10, 0]]], small])
    ids = np.array([7] + [3] * 20, dtype=np.int32)
    points = np.array([[9.9, 0], [10, 0.055], [5, 1], [9.9, 1e-12]])
    np.testing.assert_array_equal(mesh_domain.match_simplices(points, (vertices, ids), 1e-9),
                                  [7, 3, mesh_domain.UNTAGGED, 7])


# --- built-in rectangle and box ---------------------------------------------------------------

@pytest.mark.parametrize("gdim", [2, 3])
def test_box_faces_cover_the_sides(gdim):
    low, high = np.array([0.0, -1, 2])[:gdim], np.array([2.0, 1, 5])[:gdim]
    vertices, ids = builtin._box_faces(low, high)
    assert vertices.shape == ({2: 4, 3: 12}[gdim], gdim, gdim)
    for group in range(1, 2 * gdim + 1):
        axis, side = divmod(group - 1, 2)
        mine = vertices[ids == group]
        assert np.all(mine[..., axis] == (high if side else low)[axis])  # in the side's plane
        edges = mine[:, 1:] - mine[:, :1]
        measure = np.abs(edges[:, 0, 1 - axis]) if gdim == 2 else 0.5 * np.linalg.norm(
            np.cross(edges[:, 0], edges[:, 1]), axis=-1)
        assert measure.sum() == pytest.approx(np.prod(np.delete(high - low, axis)), rel=1e-14)


@pytest.mark.parametrize("tdim, dim", [(2, 1), (2, 5), (3, 1), (3, 8)])
def test_cell_space_numbers_dofs_as_cells(tdim, dim):
    """cell_space: component j of cell i's value is entry dim·i + j of a vector (what the estimator, the
    marking and the regions read as cell i's), here each cell's midpoint coordinates, assembled."""
    import ufl
    from dolfinx import mesh as dmesh
    from nc_dolfinx.mesh.domain import cell_space
    from nc_dolfinx.estimator.indicators import assemble_cellwise
    msh = dmesh.create_unit_square(COMM, 3, 2) if tdim == 2 else dmesh.create_unit_cube(COMM, 2, 1, 2)
    V = cell_space(msh, dim)
    w, x = ufl.TestFunction(V), ufl.SpatialCoordinate(msh)
    components = [w] if dim == 1 else [w[j] for j in range(dim)]
    values = assemble_cellwise(sum(x[j % tdim] * c for j, c in enumerate(components)) / ufl.CellVolume(msh)
                               * ufl.dx, V)
    n = msh.topology.index_map(tdim).size_local
    midpoints = dmesh.compute_midpoints(msh, tdim, np.arange(n, dtype=np.int32))
    assert values.shape == (n, dim)
    assert np.allclose(values, midpoints[:, np.arange(dim) % tdim], atol=1e-14)


def test_box_domain():
    domain = builtin.box(COMM, [[0, 0, 0], [2, 1, 3]], [2, 1, 3])
    tags = domain.facet_tags
    assert domain.tdim == 3 and domain.num_cells() == 6 * 2 * 1 * 3 and domain.num_vertices() == 3 * 2 * 4
    assert domain.facet_groups == {"left": 1, "right": 2, "front": 3, "back": 4, "bottom": 5, "top": 6}
    assert domain.cell_groups == {"body": 1} and np.all(domain.region.x.array == 1)
    counts = np.bincount(tags.values, minlength=7)  # two triangles per square of a face
    np.testing.assert_array_equal(counts, [0, 2 * 3, 2 * 3, 2 * 6, 2 * 6, 2 * 2, 2 * 2])
    midpoints = dmesh.compute_midpoints(domain.mesh, 2, tags.indices)
    np.testing.assert_allclose(midpoints[tags.values == 6, 2], 3.0, rtol=0, atol=1e-14)
    if versions.V05:  # the re-wrap that keeps 0.5.2 from compiling twice (dolfinx_versions)
        assert domain.mesh.ufl_domain().ufl_coordinate_element().sub_elements()[0].variant() == "equispaced"


@pytest.mark.parametrize("kind, corners, cells, expected", [
    ("box", [[0, 0, 0], [1, 1]], [1, 1, 1],
     "mesh.box must be [[x0, y0, z0], [x1, y1, z1]] with x1 > x0, y1 > y0, z1 > z0, got [[0, 0, 0], [1, 1]]"),
    ("box", [[0, 0, 1], [1, 1, 1]], [1, 1, 1], "mesh.box must be"),
    ("box", [[0, 0, 0], [1, 1, 1]], [1, 1], "mesh.cells must be three positive integers, got [1, 1]"),
    ("box", [[0, 0, 0], [1, 1, 1]], [1, 0, 1], "mesh.cells must be three positive integers"),
    ("rectangle", 5, [1, 1], "mesh.rectangle must be [[x0, y0], [x1, y1]] with x1 > x0, y1 > y0, got 5"),
    ("rectangle", [[0, 0], [1, 1]], [1, 1, 1], "mesh.cells must be two positive integers, got [1, 1, 1]"),
])
def test_rectangle_and_box_input(kind, corners, cells, expected):
    with pytest.raises(InputError) as err:
        getattr(builtin, kind)(COMM, corners, cells)
    assert expected in str(err.value)


# --- a user's DOLFINx mesh --------------------------------------------------------------------

def test_from_dolfinx_2d_names_and_defaults():
    """Tags become groups (named or by value), untagged exterior facets UNTAGGED, no cell tags: 'body'."""
    from dolfinx import mesh as dmesh
    msh = dmesh.create_unit_square(COMM, 4, 2)
    bottom = dmesh.locate_entities_boundary(msh, 1, lambda x: np.isclose(x[1], 0))
    domain = tagged.from_dolfinx(msh, dmesh.meshtags(msh, 1, bottom, np.full(len(bottom), 4, np.int32)),
                                 {8: "unused"})
    assert domain.facet_groups == {"4": 4, "unused": 8} and domain.cell_groups == {"body": 1}
    assert np.bincount(domain.facet_tags.values).tolist() == [2 * 2 + 4, 0, 0, 0, 4]
    vertices, ids = gather_boundary(domain.mesh, domain.facet_tags)
    assert vertices.shape == (12, 2, 2) and sorted(ids) == [0] * 8 + [4] * 4


@pytest.mark.parametrize("make, expected", [
    (lambda d: (d.create_box(COMM, [[0, 0, 0], [1, 1, 1]], [1, 1, 1], d.CellType.hexahedron), 2, 3),
     f"mesh of hexahedron cells of degree 1 in 3D: {SUPPORTED}"),
    (lambda d: (d.create_unit_square(COMM, 1, 1, d.CellType.quadrilateral), 1, 2),
     f"mesh of quadrilateral cells of degree 1 in 2D: {SUPPORTED}"),
    (lambda d: (d.create_unit_cube(COMM, 1, 1, 1), 1, 3), "facet tags must be of dimension 2 on a 3D mesh, got 1"),
    (lambda d: (d.create_unit_cube(COMM, 1, 1, 1), 2, 2), "cell tags must be of dimension 3 on a 3D mesh, got 2"),
])
def test_from_dolfinx_refuses(make, expected):
    from dolfinx import mesh as dmesh
    msh, facet_dim, cell_dim = make(dmesh)
    empty = np.zeros(0, dtype=np.int32)
    with pytest.raises(InputError) as err:
        tagged.from_dolfinx(msh, dmesh.meshtags(msh, facet_dim, empty, empty), None,
                            dmesh.meshtags(msh, cell_dim, empty, empty))
    assert str(err.value) == expected


def test_from_dolfinx_refuses_a_facet_with_two_tags():
    """One facet tagged 1 and 2: refused; tagged 5 twice: in group 5."""
    from dolfinx import mesh as dmesh
    msh = dmesh.create_unit_square(COMM, 2, 2)
    facets = mesh_domain.owned_exterior_facets(msh)
    twice = np.array([facets[0], facets[0]], dtype=np.int32)
    with pytest.raises(InputError) as err:
        tagged.from_dolfinx(msh, dmesh.meshtags(msh, 1, twice, np.array([1, 2], np.int32)))
    assert str(err.value) == "facet tags: a facet carries two different tags"
    domain = tagged.from_dolfinx(msh, dmesh.meshtags(msh, 1, twice, np.array([5, 5], np.int32)))
    assert np.bincount(domain.facet_tags.values).tolist() == [7, 0, 0, 0, 0, 1]


def test_from_dolfinx_refuses_tag_zero_and_second_order():
    import ufl
    from dolfinx import mesh as dmesh
    msh = dmesh.create_unit_square(COMM, 1, 1)
    facets = mesh_domain.owned_exterior_facets(msh)
    with pytest.raises(InputError, match="facet tag 0 is reserved for untagged facets"):
        tagged.from_dolfinx(msh, dmesh.meshtags(msh, 1, facets, np.zeros(len(facets), np.int32)))
    cells = np.array([[0, 1, 2, 3, 4, 5]], dtype=np.int64)
    x = np.array([[0, 0], [1, 0], [0, 1], [0.5, 0.5], [0, 0.5], [0.5, 0]], dtype=np.float64)
    if versions.V05:
        p2 = dmesh.create_mesh(COMM, cells, x, ufl.Mesh(ufl.VectorElement("Lagrange", "triangle", 2)))
    else:
        import basix.ufl
        p2 = dmesh.create_mesh(COMM, cells=cells, x=x, e=basix.ufl.element("Lagrange", "triangle", 2, shape=(2,)))
    with pytest.raises(InputError) as err:
        tagged.from_dolfinx(p2, dmesh.meshtags(p2, 1, np.zeros(0, np.int32), np.zeros(0, np.int32)))
    assert str(err.value) == f"mesh of triangle cells of degree 2 in 2D: {SUPPORTED}"


# --- gmsh -------------------------------------------------------------------------------------

@contextlib.contextmanager
def gmsh_session():
    import gmsh
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        yield gmsh
    finally:
        gmsh.finalize()


def two_volumes(gmsh, kind="good"):
    """[0,2]x[0,1]x[0,1] as volumes 'soft' (x < 1) and 'hard', surface groups left (x = 0) and bottom
    (z = 0); kinds: 'hex', 'second_order', 'unmeshed', 'volume_twice' (in 'soft' and 'hard'),
    'surface_twice' (the interface in 'left' and 'interface')."""
    occ, model = gmsh.model.occ, gmsh.model
    occ.fragment([(3, occ.addBox(0, 0, 0, 1, 1, 1))], [(3, occ.addBox(1, 0, 0, 1, 1, 1))])
    occ.synchronize()
    centre = {(d, t): occ.getCenterOfMass(d, t) for d, t in model.getEntities()}
    def group(dim, name, inside):
        tags = [t for d, t in model.getEntities(dim) if inside(centre[(d, t)])]
        model.setPhysicalName(dim, model.addPhysicalGroup(dim, tags), name)
    group(3, "soft", lambda c: c[0] < 1)
    group(3, "hard", lambda c: c[0] > 1 or kind == "volume_twice")
    group(2, "left", lambda c: np.isclose(c[0], 0) or (kind == "surface_twice" and np.isclose(c[0], 1)))
    group(2, "bottom", lambda c: np.isclose(c[2], 0))
    if kind == "surface_twice":
        group(2, "interface", lambda c: np.isclose(c[0], 1))
    gmsh.option.setNumber("Mesh.MeshSizeMax", 1.0)
    if kind == "hex":
        model.mesh.setTransfiniteAutomatic()
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
    if kind != "unmeshed":
        model.mesh.generate(3)
    if kind == "second_order":
        model.mesh.setOrder(2)


def square(gmsh, kind):
    """The unit square, one cell group; kinds 'quad' (recombined) and 'second_order'."""
    surface = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [surface])
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
    gmsh.option.setNumber("Mesh.RecombineAll", int(kind == "quad"))
    gmsh.model.mesh.generate(2)
    if kind == "second_order":
        gmsh.model.mesh.setOrder(2)


def test_from_gmsh_3d_file(tmp_path):
    """A 3D .msh: groups, regions, and which boundary facets are tagged."""
    path = tmp_path / "two_volumes.msh"
    with gmsh_session() as gmsh:
        two_volumes(gmsh)
        gmsh.write(str(path))
        num_cells = sum(len(t) for t in gmsh.model.mesh.getElements(3)[1])
    domain = gmsh_io.from_gmsh(COMM, path)
    assert domain.tdim == 3 and domain.num_cells() == num_cells
    assert domain.facet_groups == {"left": 3, "bottom": 4} and domain.cell_groups == {"soft": 1, "hard": 2}
    vertices, ids = gather_boundary(domain.mesh, domain.facet_tags)
    midpoints = vertices.mean(axis=1)
    assert vertices.shape[1:] == (3, 3) and len(ids) == len(domain.facet_tags.indices)
    np.testing.assert_array_equal(ids == 3, np.isclose(midpoints[:, 0], 0))
    np.testing.assert_array_equal(ids == 4, np.isclose(midpoints[:, 2], 0) & ~np.isclose(midpoints[:, 0], 0))
    cells = dmesh.compute_midpoints(domain.mesh, 3, np.arange(num_cells, dtype=np.int32))
    np.testing.assert_array_equal(domain.region.x.array, np.where(cells[:, 0] < 1, 1, 2))


@pytest.mark.parametrize("make, expected", [
    (lambda g: square(g, "quad"), f"group '1' has Quadrilateral 4 elements on surface 1: {SUPPORTED}"),
    (lambda g: square(g, "second_order"), f"group '1' has Triangle 6 elements on surface 1: {SUPPORTED}"),
    (lambda g: two_volumes(g, "hex"), f"group 'soft' has Hexahedron 8 elements on volume 1: {SUPPORTED}"),
    (lambda g: two_volumes(g, "second_order"), f"group 'soft' has Tetrahedron 10 elements on volume 1: {SUPPORTED}"),
    (lambda g: two_volumes(g, "unmeshed"), "group 'soft' has no mesh elements on volume 1"),
    (lambda g: two_volumes(g, "volume_twice"), "volume 1 is in two groups, 'soft' and 'hard'"),
])
def test_from_gmsh_model_refuses(make, expected):
    with gmsh_session() as gmsh:
        gmsh.model.add("bad")
        make(gmsh)
        with pytest.raises(InputError) as err:
            gmsh_io.from_gmsh_model(COMM)
    assert str(err.value).startswith("gmsh model 'bad': ") and expected in str(err.value)


def test_from_gmsh_refuses_a_surface_in_two_groups(tmp_path):
    path = tmp_path / "twice.msh"
    with gmsh_session() as gmsh:
        two_volumes(gmsh, "surface_twice")
        gmsh.write(str(path))
    with pytest.raises(InputError) as err:
        gmsh_io.from_gmsh(COMM, path)
    assert str(err.value) == f"mesh file '{path}': boundary surface 2 is in two groups, 'left' and 'interface'"


# --- a .msh file is read as a mesh only; a model built on one rank (issue 31, items 1 and 3) ------

def test_from_gmsh_reads_a_mesh_file_only(tmp_path):
    """gmsh runs any file it does not take for a mesh as a script (SystemCall runs a command), and merges
    <file>.opt after it as one: none of them may reach it."""
    canary = tmp_path / "CANARY"
    hostile = f'SystemCall "touch {canary}";\n'
    good = tmp_path / "good.msh"
    with gmsh_session() as gmsh:
        square(gmsh, "triangles")
        gmsh.write(str(good))
    (tmp_path / "good.msh.opt").write_text(hostile)
    assert gmsh_io.from_gmsh(COMM, good).num_cells() > 0
    (tmp_path / "script.msh").write_text(hostile)
    (tmp_path / "script.geo").write_text(hostile)
    (tmp_path / "bom.msh").write_bytes(b"\xef\xbb\xbf$MeshFormat\n" + hostile.encode())
    (tmp_path / "empty.msh").write_text("")
    (tmp_path / "folder.msh").mkdir()
    os.mkfifo(tmp_path / "fifo.msh")  # (opening it must not wait for a writer)
    for name, expected in [("script.msh", "is not a gmsh .msh file (it does not start with $MeshFormat)"),
                           ("bom.msh", "is not a gmsh .msh file (it does not start with $MeshFormat)"),
                           ("script.geo", "is not a gmsh .msh file (its name does not end in .msh)"),
                           ("empty.msh", "is not a gmsh .msh file (it is empty)"),
                           ("folder.msh", "is a directory, not a file"), ("fifo.msh", "is not a regular file"),
                           ("missing.msh", "not found"), ("x" * 300 + ".msh", "File name too long")]:
        with pytest.raises(InputError) as err:
            gmsh_io.from_gmsh(COMM, tmp_path / name)
        text = str(err.value)
        assert "mesh file '" in text and expected in text and "\n" not in text, text
        assert f"{name}' {expected}" in text or len(name) > 200, text  # (a long name is cut short)
    assert not canary.exists(), "gmsh ran a script"


def test_from_gmsh_model_runs_build_and_reports_its_failure():
    def build(gmsh):
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("bad")
        square(gmsh, "triangles")

    assert gmsh_io.from_gmsh_model(COMM, build=build).num_cells() > 0

    def failing():  # (no argument: called without gmsh)
        raise ValueError("no such geometry")

    with pytest.raises(InputError) as err:
        gmsh_io.from_gmsh_model(COMM, build=failing)
    assert str(err.value) == "the gmsh model built on rank 0 failed: ValueError: no such geometry"


@pytest.mark.parametrize("mode", ["fail", "ok", "ok_without_argument"])
def test_a_build_failing_on_its_rank_stops_every_rank(mode):
    """On 2 ranks, a build that raises on rank 0 only: both ranks end with the same InputError and exit
    status 1, in time (a rank left waiting would hang the job: it is killed and the test fails)."""
    command = mpirun_prefix(2) + [PYTHON, str(ROOT / "tests" / "mpi" / "gmsh_build.py"), mode]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
    proc = subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=120)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"no exit within 120 s (a rank waiting for rank 0?):\n{out}\n{err}")
    if mode == "fail":
        message = "InputError: the gmsh model built on rank 0 failed: ValueError: no such geometry"
        assert proc.returncode == 1, out + err
        assert sorted(line for line in out.splitlines() if line.startswith("rank ")) == \
            [f"rank 0: {message}", f"rank 1: {message}"], out + err
    else:
        assert proc.returncode == 0, out + err
        assert int(out.split("cells:")[1].split()[0]) > 0


def test_errors_reach_every_rank():
    """On 2 ranks, a model that only rank 0 holds, and a user mesh: every rank raises the same error."""
    proc = run([ROOT / "tests" / "mpi" / "bad_mesh_check.py"], 2, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    per_rank = json.loads(proc.stdout.strip().splitlines()[-1])
    assert per_rank == [per_rank[0]] * 2
    assert per_rank[0] == [f"gmsh model: group '1' has Hexahedron 8 elements on volume 1: {SUPPORTED}",
                           f"mesh of hexahedron cells of degree 1 in 3D: {SUPPORTED}"]
