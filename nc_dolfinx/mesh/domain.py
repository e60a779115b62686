"""A mesh with named boundary groups and material regions, in 2D (triangles) and 3D (tetrahedra).

A :class:`Domain` is a DOLFINx mesh plus
- ``facet_tags``: every owned exterior facet tagged with its boundary group id (``UNTAGGED`` = 0 when in none);
- ``region``: a DG0 function holding each cell's region (material) id.

After a refinement, a facet keeps its parent's group: from the parent of each child cell and the parent
facet of each child facet (:func:`cell_facet_groups` gives the parent's groups cell by cell,
:func:`tag_from_cell_facets` tags the child from them), exact and local. DOLFINx's own
``transfer_meshtag`` is not used: it refuses ghosted meshes (0.9, 0.11), and 0.5.2's needs
``GhostMode.none``, which would break interior-facet integrals on partition boundaries.
The built-in rectangle and box are tagged geometrically (:func:`tag_exterior_facets`): a facet belongs
to the side (a few simplices) that holds its centroid.
"""
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

import dolfinx
from dolfinx import fem, mesh as dmesh

from .. import dolfinx_versions as versions
from ..errors import InputError

UNTAGGED = 0
_NEAREST = 8  # simplices checked exactly per point before the exhaustive fallback


@dataclass
class Domain:
    """A mesh with named boundary groups and material regions: where the problem's Γ_D, Γ_N, Γ_C (paper
    §2) and symmetry planes are chosen, by group name, and where each material applies.

    ``mesh``: the DOLFINx mesh (P1 triangles or tetrahedra, ``GhostMode.shared_facet``);
    ``facet_tags``: the owned exterior facets tagged with their group id (``UNTAGGED`` = 0 in none);
    ``region``: a DG0 function of the cells' region ids; ``facet_groups`` / ``cell_groups``: name → id;
    ``shapes``: the surface each boundary group lies on (:mod:`nc_dolfinx.mesh.shape`; set from the problem
    when it is bound, kept by refinement, which places new boundary vertices on it); ``cad``: the CAD the
    mesh was made from (a gmsh model's, :func:`from_gmsh_model`), where the shapes not given are found.
    Made by :func:`rectangle`, :func:`box`, :func:`from_gmsh`, :func:`from_gmsh_model`,
    :func:`from_dolfinx` or :func:`build_domain`; :func:`refine` returns the next one.
    """
    mesh: dmesh.Mesh
    facet_tags: object  # dolfinx MeshTags on the owned exterior facets
    region: fem.Function
    facet_groups: dict  # name -> id
    cell_groups: dict  # name -> id
    shapes: object = None  # the true shape of each boundary group (:class:`~nc_dolfinx.mesh.shape.Shapes`)
    cad: object = None     # the CAD the mesh was made from (:class:`~nc_dolfinx.mesh.cad.Cad`), if known

    @property
    def comm(self):
        """The mesh's MPI communicator."""
        return self.mesh.comm

    @property
    def tdim(self):
        """The topological dimension: 2 (triangles) or 3 (tetrahedra)."""
        return self.mesh.topology.dim

    def num_cells(self):
        """The global number of cells."""
        return self.mesh.topology.index_map(self.tdim).size_global

    def num_vertices(self):
        """The global number of vertices (a P1 vector field has tdim times as many dofs)."""
        return self.mesh.topology.index_map(0).size_global


# --- point-in-simplex matching ----------------------------------------------------------------

def distance_to_simplices(points, vertices):
    """Distance from points (n, gdim) to simplices given by their vertices (n, k, gdim), pairwise.

    The closest point of the simplex's affine hull is found from the normal equations; where its
    barycentric coordinates are not all >= 0, the closest point lies on a face, so the distance is the
    smallest one to the k faces (recursively, down to segments and points).
    """
    points, vertices = np.asarray(points, float), np.asarray(vertices, float)
    k = vertices.shape[1]
    if k == 1 or len(points) == 0:
        return np.linalg.norm(points - vertices[:, 0], axis=-1)
    origin = vertices[:, 0]
    edges = vertices[:, 1:] - origin[:, None]  # (n, k-1, gdim)
    gram = np.einsum("nig,njg->nij", edges, edges)
    lam = np.linalg.solve(gram, np.einsum("nig,ng->ni", edges, points - origin)[..., None])[..., 0]
    dist = np.linalg.norm(points - origin - np.einsum("ni,nig->ng", lam, edges), axis=-1)
    outside = (lam.min(axis=1) < 0) | (lam.sum(axis=1) > 1)
    if np.any(outside):
        faces = [np.delete(vertices[outside], j, axis=1) for j in range(k)]
        dist[outside] = np.min([distance_to_simplices(points[outside], f) for f in faces], axis=0)
    return dist


def match_simplices(points, boundary, tol):
    """Group id of a simplex within ``tol`` of each point, ``UNTAGGED`` where none is.

    The simplices are tried nearest centroid first, and a point takes the first within ``tol``: a facet
    centroid lies inside its simplex (distance ~1e-16) and at least a third of the facet's smallest
    height away from any other, so the choice is unambiguous, and most points stop at the first candidate."""
    vertices, ids = boundary
    result = np.full(len(points), UNTAGGED, dtype=np.int32)
    if len(points) == 0 or len(ids) == 0:
        return result
    from scipy.spatial import cKDTree  # here: importing it costs every run 0.13 s at start-up
    centroids = vertices.mean(axis=1)
    tree = cKDTree(centroids)
    k = min(_NEAREST, len(ids))
    _, near = tree.query(points, k=k)
    near = near.reshape(len(points), k)
    lost = np.arange(len(points))
    for j in range(k):
        within = distance_to_simplices(points[lost], vertices[near[lost, j]]) <= tol
        result[lost[within]] = ids[near[lost[within], j]]
        lost = lost[~within]
        if not len(lost):
            break
    # Graded meshes can hide the containing simplex behind k nearer centroids. A point inside a simplex
    # is no farther from its centroid than the simplex's farthest vertex: that radius finds it for sure.
    if len(lost):
        radius = np.linalg.norm(vertices - centroids[:, None], axis=-1).max() + tol
        candidates = tree.query_ball_point(points[lost], radius)
        point = np.repeat(lost, [len(c) for c in candidates])
        simplex = np.fromiter((s for c in candidates for s in c), dtype=np.int64, count=len(point))
        dist = distance_to_simplices(points[point], vertices[simplex])
        order = np.lexsort((dist, point))  # per point, nearest first
        first = order[np.r_[True, point[order][1:] != point[order][:-1]]] if len(order) else order
        within = first[dist[first] <= tol]
        result[point[within]] = ids[simplex[within]]
    return result


# --- tags and regions on a mesh ---------------------------------------------------------------

def owned_exterior_facets(msh):
    """Sorted local indices of the owned exterior facets."""
    tdim = msh.topology.dim
    msh.topology.create_entities(tdim - 1)
    msh.topology.create_connectivity(tdim - 1, tdim)
    return np.sort(versions.exterior_facet_indices(msh)).astype(np.int32)


def extent(boundary):
    """Largest extent along a coordinate axis of the body whose whole ``boundary`` (vertices (n, tdim,
    gdim), ids) is given."""
    vertices = boundary[0].reshape(-1, boundary[0].shape[-1])
    return float(np.ptp(vertices, axis=0).max()) if len(vertices) else 0.0


def tag_exterior_facets(msh, boundary):
    """MeshTags on the owned exterior facets, valued by the group of the boundary simplex they lie in
    (``boundary``: the whole boundary as simplices and their group ids, e.g. a box's sides)."""
    facets = owned_exterior_facets(msh)
    centroids = dmesh.compute_midpoints(msh, msh.topology.dim - 1, facets)[:, :msh.geometry.dim]
    ids = match_simplices(centroids, boundary, 1e-9 * extent(boundary))
    return dmesh.meshtags(msh, msh.topology.dim - 1, facets, ids)


def cell_facet_groups(msh, facet_tags):
    """The group of each local facet of every local cell, (n_cells, tdim + 1) ordered as the cell's facets
    (UNTAGGED where none), from ``facet_tags`` on any local copies of the facets. A facet tagged on several
    ranks must carry one value (else :class:`InputError`, on every rank)."""
    tdim = msh.topology.dim
    total, count = (fem.Function(cell_space(msh, tdim + 1)) for _ in range(2))
    if facet_tags is not None and len(facet_tags.indices):
        which, cells, local = cells_of_facets(msh, facet_tags.indices)
        at = cells * (tdim + 1) + local
        np.add.at(total.x.array, at, facet_tags.values[which])
        np.add.at(count.x.array, at, 1.0)
    for fn in (total, count):
        fn.x.scatter_reverse(versions.SCATTER_ADD)
    n_owned = msh.topology.index_map(tdim).size_local * (tdim + 1)
    seen = count.x.array[:n_owned] > 0
    groups = np.full(n_owned, float(UNTAGGED))
    groups[seen] = np.rint(total.x.array[:n_owned][seen] / count.x.array[:n_owned][seen])
    if msh.comm.allreduce(bool(np.any(groups[seen] * count.x.array[:n_owned][seen] != total.x.array[:n_owned][seen])),
                          MPI.LOR):
        raise InputError("facet tags: a facet carries two different tags")
    total.x.array[:n_owned] = groups
    total.x.scatter_forward()
    return total.x.array.reshape(-1, tdim + 1).astype(np.int32)


def tag_from_cell_facets(msh, groups):
    """MeshTags on the owned exterior facets from ``groups`` (n_owned_cells, tdim + 1): the group of each
    local facet of the owned cells (a facet whose cell is a ghost here takes it from the cell's owner)."""
    tdim = msh.topology.dim
    fn = fem.Function(cell_space(msh, tdim + 1))
    fn.x.array[:groups.size] = groups.ravel()
    fn.x.scatter_forward()
    facets = owned_exterior_facets(msh)
    _, cells, local = cells_of_facets(msh, facets)  # an exterior facet has one cell
    return dmesh.meshtags(msh, tdim - 1, facets, fn.x.array.reshape(-1, tdim + 1)[cells, local].astype(np.int32))


def cells_of_facets(msh, facets):
    """Each local cell of each of ``facets``: (which facet, as an index into ``facets``; the cell; the
    facet's place among the cell's facets), facet after facet."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    msh.topology.create_connectivity(tdim, tdim - 1)
    f_to_c, c_to_f = msh.topology.connectivity(tdim - 1, tdim), msh.topology.connectivity(tdim, tdim - 1)
    facets = np.asarray(facets, dtype=np.int64)
    starts, counts = f_to_c.offsets[facets], np.diff(f_to_c.offsets)[facets]
    which = np.repeat(np.arange(len(facets)), counts)
    first_of_which = np.repeat(np.cumsum(counts) - counts, counts)
    cells = f_to_c.array[np.repeat(starts, counts) + np.arange(len(which)) - first_of_which]
    local = np.argmax(c_to_f.array.reshape(-1, tdim + 1)[cells] == facets[which, None], axis=1)
    return which, cells, local


def cell_space(msh, dim=1):
    """The DG0 space of ``dim`` components (scalar for 1) whose dof i is the local cell i: a cell's value is
    at ``dim·i`` … ``dim·i + dim − 1`` of a function's array, owned cells first, as in the cells' index map.

    ``fem.FunctionSpace(msh, ("DG", 0))`` builds a dofmap with DOLFINx's numbering and reordering (0.02 s
    at 5e5 cells, at every refinement and in every estimate) for what is one dof per cell."""
    cells = msh.topology.index_map(msh.topology.dim)
    n = cells.size_local + cells.num_ghosts
    identity = dolfinx.cpp.graph.AdjacencyList_int32(np.arange(n, dtype=np.int32), np.arange(n + 1, dtype=np.int32))
    dofmap = dolfinx.cpp.fem.DofMap(versions.dof_layout_dg0(msh.topology.dim, dim), cells, dim, identity, dim)
    return versions.cell_space_from_dofmap(msh, dim, dofmap)


def global_bounds(comm, x):
    """The smallest and largest coordinates of points ``x`` (n, dim) over all ranks (elementwise over the
    coordinates: the pickling allreduce would compare whole arrays)."""
    low, high = np.empty(x.shape[1]), np.empty(x.shape[1])
    comm.Allreduce(x.min(axis=0) if len(x) else np.full(x.shape[1], np.inf), low, MPI.MIN)
    comm.Allreduce(x.max(axis=0) if len(x) else np.full(x.shape[1], -np.inf), high, MPI.MAX)
    return low, high


def dof_of_node(space):
    """The P1 dof (block index) at each geometry node of the space's mesh (a cell lists its dofs and nodes
    in the same order: both follow the cell's vertices)."""
    nodes = versions.geometry_nodes(space.mesh)
    at_node = np.empty(space.mesh.geometry.x.shape[0], dtype=np.int64)
    at_node[nodes.ravel()] = versions.cell_dofs(space.dofmap)[:len(nodes)].ravel()
    return at_node


def region_function(msh, values_of_owned_cells):
    """DG0 function of region ids from values on the owned cells (ghosts filled by scatter)."""
    region = fem.Function(cell_space(msh), name="region")
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    region.x.array[:n_owned] = values_of_owned_cells
    region.x.scatter_forward()
    return region
