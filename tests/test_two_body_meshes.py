"""The two-body meshes of meshes/two_bodies.py (issue 47), read by the package's own reader (gmsh_io.from_gmsh):
two connected components, each one cell group; every named facet group on its body and every exterior facet
in a group; volumes and areas as analytic; interface nodes that do not coincide where the meshes are meant
to be non-matching; mirrored nodes exact mirrors. Small sizes: the whole file runs in a few seconds.
"""
import math

import numpy as np
import pytest
from mpi4py import MPI
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from conftest import ROOT, import_script, run
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.mesh import gmsh_io

COMM = MPI.COMM_SELF
two_bodies = import_script("meshes", "two_bodies")


class Read:
    """A two-body mesh as the package reads it: per cell its component and region name, per facet group
    its facets' nodes and the component of their cells."""

    def __init__(self, path):
        self.domain = domain = gmsh_io.from_gmsh(COMM, path)
        msh = domain.mesh
        self.tdim = tdim = msh.topology.dim
        self.x = msh.geometry.x[:, :tdim]
        n_cells = msh.topology.index_map(tdim).size_local
        self.cells = versions.geometry_nodes(msh)[:n_cells]
        k = self.cells.shape[1]
        incidence = csr_matrix((np.ones(n_cells * k), (np.repeat(np.arange(n_cells), k), self.cells.ravel())))
        self.n_components, self.component = connected_components(incidence @ incidence.T, directed=False)
        name_of = {v: name for name, v in domain.cell_groups.items()}
        self.region = np.array([name_of[int(round(r))] for r in domain.region.x.array[:n_cells]])
        msh.topology.create_connectivity(tdim - 1, tdim)
        facet_to_cell = msh.topology.connectivity(tdim - 1, tdim)
        self.facet_ids = domain.facet_tags.values
        facets = domain.facet_tags.indices
        self.facet_cell = np.array([facet_to_cell.links(f)[0] for f in facets], dtype=np.int64)
        self.facet_nodes = versions.entities_to_geometry(msh, tdim - 1, facets)

    def body_component(self):
        """{cell group name: its component}, checking that each component is one group and vice versa."""
        bodies = {}
        for c in range(self.n_components):
            names = set(self.region[self.component == c])
            assert len(names) == 1, f"component {c} holds cell groups {names}"
            bodies[names.pop()] = c
        assert len(bodies) == self.n_components
        return bodies

    def group(self, name):
        """(facet node indices (m, tdim), the components of the facets' cells)."""
        mine = self.facet_ids == self.domain.facet_groups[name]
        return self.facet_nodes[mine], self.component[self.facet_cell[mine]]

    def volume(self, body):
        cells = self.cells[self.region == body]
        edges = self.x[cells[:, 1:]] - self.x[cells[:, :1]]
        return float(np.abs(np.linalg.det(edges)).sum() / math.factorial(self.tdim))

    def measure(self, name):
        nodes = self.x[self.group(name)[0]]
        if self.tdim == 2:
            return float(np.linalg.norm(nodes[:, 1] - nodes[:, 0], axis=1).sum())
        return float(np.linalg.norm(np.cross(nodes[:, 1] - nodes[:, 0], nodes[:, 2] - nodes[:, 0]), axis=1).sum() / 2)

    def nodes_of(self, name):
        return self.x[np.unique(self.group(name)[0])]

    def body_nodes(self, body):
        return self.x[np.unique(self.cells[self.region == body])]


def check_orientation(path):
    """Every cell as written has a positive signed volume (none inverted by the maps and the jitter, and
    the mirrored ones turned back)."""
    volumes = signed_volumes(path)
    assert np.all(volumes > 0), f"{np.sum(volumes <= 0)} of {len(volumes)} cells with a signed volume <= 0"


def signed_volumes(path):
    """Signed volumes of the cells as written in the file (the package's reader reorders cell nodes)."""
    with gmsh_io.gmsh_session() as gmsh:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.open(str(path))
        tdim = gmsh.model.getDimension()
        tags, coords, _ = gmsh.model.mesh.getNodes()
        x = np.zeros((int(tags.max()) + 1, 3))
        x[tags.astype(int)] = np.reshape(coords, (-1, 3))
        cells = np.reshape(gmsh.model.mesh.getElementsByType({2: 2, 3: 4}[tdim])[1], (-1, tdim + 1)).astype(int)
    edges = x[cells[:, 1:], :tdim] - x[cells[:, :1], :tdim]
    return np.linalg.det(edges) / math.factorial(tdim)


def check_bodies(mesh, groups_of):
    """Two components, one per cell group in ``groups_of`` ({body: [facet groups]}); each facet group on its
    body; every exterior facet in a group and no other group."""
    assert mesh.n_components == 2
    bodies = mesh.body_component()
    assert set(bodies) == set(groups_of)
    assert set(mesh.domain.facet_groups) == {g for groups in groups_of.values() for g in groups}
    assert np.all(mesh.facet_ids != 0), "an exterior facet in no group"
    for body, groups in groups_of.items():
        for name in groups:
            nodes, components = mesh.group(name)
            assert len(nodes) > 0, name
            assert np.all(components == bodies[body]), f"group {name} is not all on body {body}"


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    return tmp_path_factory.mktemp("two_bodies")


# --- stacked blocks ---------------------------------------------------------------------------------

def test_stacked_blocks_2d(folder):
    path = folder / "blocks2d.msh"
    h_lower, h_upper = 1 / 6, 1 / 9
    designed = two_bodies.stacked_blocks_2d(path, h_lower, h_upper)
    check_orientation(path)
    mesh = Read(path)
    check_bodies(mesh, {"lower": ["bottom", "lower_left", "lower_right", "lower_face"],
                        "upper": ["top", "upper_left", "upper_right", "upper_face"]})
    for body in ("lower", "upper"):
        assert mesh.volume(body) == pytest.approx(0.5, abs=1e-12)
        assert mesh.measure(f"{body}_face") == pytest.approx(1.0, abs=1e-12)
        assert mesh.measure(f"{body}_left") == pytest.approx(0.5, abs=1e-12)
    # the faces coincide exactly; their interior nodes do not (6 and 9 uniform segments would meet twice)
    lower, upper = mesh.nodes_of("lower_face"), mesh.nodes_of("upper_face")
    assert np.all(lower[:, 1] == 0.5) and np.all(upper[:, 1] == 0.5)
    assert (len(lower), len(upper)) == (7, 10)
    inner = [np.sort(n[(n[:, 0] > 0) & (n[:, 0] < 1), 0]) for n in (lower, upper)]
    separation = np.abs(inner[0][:, None] - inner[1][None, :]).min()
    assert separation > 0.2 * h_upper and separation > designed - 0.03 * h_upper


def test_stacked_blocks_3d(folder):
    path = folder / "blocks3d.msh"
    h_lower, h_upper = 1 / 3, 1 / 4  # round(1/h) = 3 and 4: coarse for speed
    designed = two_bodies.stacked_blocks_3d(path, h_lower, h_upper)
    check_orientation(path)
    mesh = Read(path)
    sides = ["x0", "x1", "y0", "y1"]
    check_bodies(mesh, {"lower": ["bottom", "lower_face"] + [f"lower_{s}" for s in sides],
                        "upper": ["top", "upper_face"] + [f"upper_{s}" for s in sides]})
    for body in ("lower", "upper"):
        assert mesh.volume(body) == pytest.approx(0.5, abs=1e-12)
        assert mesh.measure(f"{body}_face") == pytest.approx(1.0, abs=1e-12)
        for side in sides:
            assert mesh.measure(f"{body}_{side}") == pytest.approx(0.5, abs=1e-12)
    lower, upper = mesh.nodes_of("lower_face"), mesh.nodes_of("upper_face")
    assert np.all(lower[:, 2] == 0.5) and np.all(upper[:, 2] == 0.5)
    assert (len(lower), len(upper)) == (16, 25)  # structured faces: (n + 1)^2 nodes
    corner = np.all(np.isin(upper[:, :2], [0.0, 1.0]), axis=1)
    distance, _ = cKDTree(lower).query(upper[~corner])
    assert distance.min() > 0.2 * h_upper and distance.min() > designed - 0.03 * h_upper


# --- mirrored ---------------------------------------------------------------------------------------

def check_mirror(mesh, axis_value, axis=1):
    """The lower body's nodes are the upper's with x_axis -> 2 axis_value - x_axis (in float64), bitwise."""
    upper, lower = mesh.body_nodes("upper").copy(), mesh.body_nodes("lower")
    upper[:, axis] = 2.0 * axis_value - upper[:, axis]
    np.testing.assert_array_equal(upper[np.lexsort(upper.T[::-1])], lower[np.lexsort(lower.T[::-1])])


def test_mirrored_hertz_mesh(folder):
    """The hertz case's half-disc and its mirror: touching at the origin, groups prefixed."""
    path = folder / "hertz_mirrored.msh"
    n, binary = two_bodies.mirrored(ROOT / "nc_dolfinx" / "cases" / "hertz.msh", path)
    assert not binary
    mesh = Read(path)
    check_bodies(mesh, {body: [f"{body}_{g}" for g in ("top", "contact", "free")] for body in ("upper", "lower")})
    check_mirror(mesh, 0.0)
    assert len(mesh.body_nodes("upper")) == n
    assert mesh.volume("lower") == pytest.approx(mesh.volume("upper"), rel=1e-14)
    assert mesh.volume("upper") == pytest.approx(math.pi / 2, rel=3e-3)  # chords of R/8 away from the contact
    assert mesh.measure("lower_top") == pytest.approx(2.0, rel=1e-14)
    check_orientation(path)


def test_mirrored_3d_off_axis(folder):
    """A coarse quarter ball (on the foundation z = 0) mirrored in z = -0.1: the mirror in float64 does not
    print alike in ASCII, so the file is binary, and still bitwise."""
    one = folder / "quarterball.msh"
    import_script("meshes", "quarterball").write(one, h=0.5)
    path = folder / "quarterball_mirrored.msh"
    _, binary = two_bodies.mirrored(one, path, axis_value=-0.1)
    assert binary  # 2 * (-0.1) - z has digits that %.16g loses
    mesh = Read(path)
    groups = ("top", "symm_x", "symm_y", "contact", "free")
    check_bodies(mesh, {body: [f"{body}_{g}" for g in groups] for body in ("upper", "lower")})
    check_mirror(mesh, -0.1, axis=2)
    assert np.all(mesh.nodes_of("lower_top")[:, 2] == 2 * -0.1 - 1.0)
    assert mesh.measure("lower_contact") == pytest.approx(mesh.measure("upper_contact"), rel=1e-13)
    assert mesh.volume("lower") == pytest.approx(mesh.volume("upper"), rel=1e-13)
    assert mesh.volume("upper") == pytest.approx(math.pi / 6, rel=0.08)  # a quarter of a half ball, h = R/2
    check_orientation(path)


# --- two cylinders, a sphere on a block -----------------------------------------------------------------

def test_two_cylinders_2d(folder):
    path = folder / "cylinders.msh"
    R1, R2, h, h_contact = 1.0, 1.5, 0.25, 0.02
    designed = two_bodies.two_cylinders_2d(path, R1, R2, h, h_contact)
    check_orientation(path)
    mesh = Read(path)
    check_bodies(mesh, {"upper": ["upper_top", "upper_contact", "upper_free"],
                        "lower": ["lower_bottom", "lower_contact", "lower_free"]})
    assert mesh.volume("upper") == pytest.approx(math.pi * R1 ** 2 / 2, rel=0.01)
    assert mesh.volume("lower") == pytest.approx(math.pi * R2 ** 2 / 2, rel=0.01)
    assert mesh.measure("upper_top") == pytest.approx(2 * R1, abs=1e-12)
    assert mesh.measure("lower_bottom") == pytest.approx(2 * R2, abs=1e-12)
    assert mesh.measure("upper_contact") == pytest.approx(2 * R1 * math.asin(0.5), rel=1e-3)
    assert mesh.measure("lower_contact") == pytest.approx(2 * R2 * math.asin(0.5), rel=1e-3)
    upper, lower = mesh.nodes_of("upper_contact"), mesh.nodes_of("lower_contact")
    np.testing.assert_allclose(np.hypot(upper[:, 0], upper[:, 1] - R1), R1, atol=1e-12)
    np.testing.assert_allclose(np.hypot(lower[:, 0], lower[:, 1] + R2), R2, atol=1e-12)
    assert np.abs(upper[:, 0]).max() == pytest.approx(R1 / 2, abs=1e-12)
    assert np.abs(lower[:, 0]).max() == pytest.approx(R2 / 2, abs=1e-12)
    for nodes in (upper, lower):  # each has a node at the origin, exactly
        assert np.any(np.all(nodes == 0.0, axis=1))
    # graded: chords of about h_contact (upper) and 0.7 h_contact (lower) near the origin; non-matching
    near = [np.sort(n[(np.abs(n[:, 0]) < 0.12) & (n[:, 0] != 0), 0]) for n in (upper, lower)]
    chords = [np.diff(n).mean() for n in near]
    assert chords[0] == pytest.approx(h_contact, rel=0.15) and chords[1] == pytest.approx(0.7 * h_contact, rel=0.15)
    separation = np.abs(near[0][:, None] - near[1][None, :]).min()
    assert separation > 0.01 * h_contact and separation == pytest.approx(designed, abs=0.02 * 0.7 * h_contact)


def test_sphere_on_block_3d(folder):
    path = folder / "sphere_block.msh"
    R, h, h_contact = 1.0, 0.5, 0.15
    two_bodies.sphere_on_block_3d(path, R, h, h_contact)
    check_orientation(path)
    mesh = Read(path)
    check_bodies(mesh, {"ball": ["ball_top", "ball_contact", "ball_free", "ball_sym_x", "ball_sym_y"],
                        "block": ["block_face", "block_bottom", "block_sym_x", "block_sym_y", "block_sides"]})
    assert mesh.volume("block") == pytest.approx(R ** 3, abs=1e-12)
    assert mesh.volume("ball") == pytest.approx(math.pi * R ** 3 / 6, rel=0.05)
    assert mesh.measure("block_face") == pytest.approx(R ** 2, abs=1e-12)
    assert mesh.measure("ball_top") == pytest.approx(math.pi * R ** 2 / 4, rel=0.05)
    for name, axis, value in (("ball_sym_x", 0, 0.0), ("ball_sym_y", 1, 0.0), ("block_sym_x", 0, 0.0),
                              ("block_sym_y", 1, 0.0), ("block_face", 2, 0.0), ("block_bottom", 2, -R),
                              ("ball_top", 2, R)):
        assert np.all(mesh.nodes_of(name)[:, axis] == value), name
    cap = mesh.nodes_of("ball_contact")
    np.testing.assert_allclose(np.linalg.norm(cap - [0, 0, R], axis=1), R, atol=1e-12)
    assert np.hypot(cap[:, 0], cap[:, 1]).max() == pytest.approx(R / 2, abs=1e-9)
    for name in ("ball_contact", "block_face"):  # both have a node at the origin, exactly
        assert np.any(np.all(mesh.nodes_of(name) == 0.0, axis=1)), name


def test_command_line(folder):
    """``python3 meshes/two_bodies.py NAME OUT.msh [options]``, and mirrored's --input."""
    blocks, pair = folder / "cli_blocks.msh", folder / "cli_mirrored.msh"
    script = ROOT / "meshes" / "two_bodies.py"
    done = run([script, "stacked_blocks_2d", blocks, "--h-lower", "0.5", "--h-upper", "0.25"])
    assert done.returncode == 0, done.stderr
    done = run([script, "mirrored", pair, "--input", blocks])
    assert done.returncode == 0, done.stderr
    mesh = Read(pair)
    assert mesh.n_components == 4  # the two blocks and their mirror images, as two cell groups
    assert set(mesh.domain.cell_groups) == {"upper", "lower"} and "lower_upper_face" in mesh.domain.facet_groups
