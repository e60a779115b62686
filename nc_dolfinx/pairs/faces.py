"""A face of a contact pair: the owned facets of one boundary group, with what the pair needs of each facet.

For every owned facet of the group: its vertices' coordinates, the global P1 dof blocks at them, its
outward unit normal ν (away from its cell), its measure, its cell; and a Gauss rule on it (points,
weights, barycentric coordinates). P1 on a P1 mesh: the trace of a P1 function on a facet is P1 on the
facet, so the displacement at a point of a facet is Σ_i λ_i u(x_i) over the facet's vertices, λ its
barycentric coordinates; nothing of the cell's basis is needed, and the same code serves 0.5.2 to 0.11.
"""
from dataclasses import dataclass

import numpy as np

from .. import dolfinx_versions as versions
from ..mesh.domain import dof_of_node

DEFAULT_DEGREE = {2: 8, 3: 6}  # the Gauss rule on the facets of a pair (the law's kink may lie inside a facet)


@dataclass
class Face:
    """The owned facets of one boundary group (n facets of k = gdim vertices each)."""
    name: str
    facets: np.ndarray     # (n,) local facet indices
    cells: np.ndarray      # (n,) the local cell of each facet
    nodes: np.ndarray      # (n, k) the geometry nodes of its vertices
    vertices: np.ndarray   # (n, k, gdim) coordinates
    dofs: np.ndarray       # (n, k) global dof blocks (of the P1 vector space's index map)
    local_dofs: np.ndarray  # (n, k) local dof blocks
    normals: np.ndarray    # (n, gdim) outward unit normals
    sizes: np.ndarray      # (n,) measures (length, area)

    @property
    def count(self):
        return len(self.facets)


def face(domain, space, group_id, name):
    """The :class:`Face` of boundary group ``group_id`` on ``domain`` (``space``: the P1 vector space)."""
    msh, tdim = domain.mesh, domain.tdim
    gdim = msh.geometry.dim
    tags = domain.facet_tags
    facets = np.sort(tags.indices[tags.values == group_id]).astype(np.int32)
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    cells = f2c.array[f2c.offsets[facets]] if len(facets) else np.zeros(0, dtype=np.int32)
    nodes = versions.entities_to_geometry(msh, tdim - 1, facets)
    vertices = msh.geometry.x[nodes][:, :, :gdim]
    cell_nodes = versions.entities_to_geometry(msh, tdim, cells)
    centroids = msh.geometry.x[cell_nodes][:, :, :gdim].mean(axis=1)
    normals, sizes = _normals_and_sizes(vertices)
    away = np.einsum("ij,ij->i", normals, vertices.mean(axis=1) - centroids) < 0
    normals[away] *= -1.0
    local = dof_of_node(space)[nodes] if len(facets) else np.zeros((0, gdim), dtype=np.int64)
    index_map = space.dofmap.index_map
    dofs = index_map.local_to_global(local.ravel().astype(np.int32)).reshape(local.shape) if len(facets) else local
    return Face(name, facets, cells, nodes, vertices, np.asarray(dofs, dtype=np.int64), local, normals, sizes)


def _normals_and_sizes(vertices):
    """Unit normals (unoriented) and measures of segments (2D) or triangles (3D)."""
    if vertices.shape[2] == 2:
        edge = vertices[:, 1] - vertices[:, 0]
        normal = np.stack([edge[:, 1], -edge[:, 0]], axis=1)
        size = np.linalg.norm(edge, axis=1)
        return normal / size[:, None], size
    cross = np.cross(vertices[:, 1] - vertices[:, 0], vertices[:, 2] - vertices[:, 0])
    twice = np.linalg.norm(cross, axis=1)
    return cross / twice[:, None], 0.5 * twice


def gauss_rule(gdim, degree):
    """A Gauss rule on the reference facet exact to ``degree``: barycentric coordinates (m, gdim) of its
    points and weights (m,) summing to 1 (a facet's weights are these times its measure)."""
    if gdim == 2:
        points, weights = np.polynomial.legendre.leggauss(degree // 2 + 1)
        t = 0.5 * (points + 1.0)
        return np.stack([1.0 - t, t], axis=1), 0.5 * weights
    import basix
    points, weights = basix.make_quadrature(basix.CellType.triangle, degree)
    points, weights = np.asarray(points), np.asarray(weights)
    return np.stack([1.0 - points.sum(axis=1), points[:, 0], points[:, 1]], axis=1), weights / weights.sum()


def quadrature_points(face_, degree):
    """The Gauss points of every facet of ``face_``: (coordinates (n·m, gdim), weights (n·m,), barycentric
    coordinates (n·m, k), the facet of each point (n·m,))."""
    bary, weights = gauss_rule(face_.vertices.shape[2], degree)
    m = len(weights)
    x = np.einsum("qk,nkd->nqd", bary, face_.vertices).reshape(-1, face_.vertices.shape[2])
    w = (face_.sizes[:, None] * weights[None, :]).ravel()
    return x, w, np.tile(bary, (face_.count, 1)), np.repeat(np.arange(face_.count), m)


def pair_normal(own, other):
    """The normal n along which a pair's law measures the jump at a point: the mean of the two faces' outward
    normals there, n = (ν_A − ν_B)/|ν_A − ν_B| (ν_B the other face's at the closest point), where they face
    each other (ν_A·ν_B < 0), else ν_A. Why not ν_A: on curved faces ν_A and −ν_B differ by the angle
    between the faces' slopes, and a tangential slip of the faces, (u_A − u_B)·ν_A ≠ (u_A − u_B)·(−ν_B),
    then entered the two half-passes' normal jumps with opposite signs; between two identical cylinders
    sheared at a fixed normal load (Dundurs' β = 0: the contact keeps its width) the contact narrowed by
    up to 5.9 % with the faces' own normals, by less than 1e-4 with n (verification/cattaneo_two_bodies.py).
    On flat faces n = ν_A = −ν_B: nothing changes there. (The averaged normal of mortar methods: Puso &
    Laursen, CMAME 193, 2004.)"""
    difference = own - other
    size = np.linalg.norm(difference, axis=1)
    facing = np.einsum("ij,ij->i", own, other) < 0
    return np.where(facing[:, None], difference / np.where(size > 0, size, 1.0)[:, None], own)
