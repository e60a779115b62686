"""Meshes with named boundary groups and material regions.

A :class:`Domain` is a DOLFINx mesh plus
- ``facet_tags``: every exterior facet tagged with its boundary group id (``UNTAGGED`` = 0 when in none);
- ``region``: a DG0 function holding each cell's region (material) id;
- ``segments``: the level-0 boundary segments with their group ids, replicated on every rank.

Boundary facets are tagged *geometrically*: a facet belongs to the group of the level-0 segment that
contains its midpoint. Because refinement only bisects edges of a polygonal boundary, every descendant
facet lies on a level-0 segment, so the same matcher re-tags the mesh after each refinement, whatever the
partition or ghost mode (``transfer_facet_meshtag`` in DOLFINx 0.5 needs ``GhostMode.none``, which would
break interior-facet integrals on partition boundaries).
"""
from dataclasses import dataclass, field

import numpy as np
import ufl
from mpi4py import MPI
from scipy.spatial import cKDTree

import dolfinx
from dolfinx import fem, mesh as dmesh

from .errors import InputError

UNTAGGED = 0
RECTANGLE_SIDES = {"left": 1, "right": 2, "bottom": 3, "top": 4}


@dataclass
class Domain:
    mesh: dmesh.Mesh
    facet_tags: object  # dolfinx MeshTags
    region: fem.Function
    facet_groups: dict
    cell_groups: dict
    segments: tuple = field(repr=False)  # (a (n, 2), b (n, 2), group id (n,))

    @property
    def comm(self):
        return self.mesh.comm

    def num_cells(self):
        return self.mesh.topology.index_map(2).size_global

    def num_vertices(self):
        return self.mesh.topology.index_map(0).size_global


# --- geometric facet tagging ------------------------------------------------------------------

def _distance_to_segments(p, a, b):
    """Distance from points p (n, 2) to segments [a, b] (n, 2), pairwise."""
    ab = b - a
    s = np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab)
    q = a + np.clip(s, 0.0, 1.0)[:, None] * ab
    return np.linalg.norm(p - q, axis=1)


def match_segments(points, segments, tol):
    """Group id of the segment containing each point, ``UNTAGGED`` where none lies within ``tol``."""
    a, b, ids = segments
    result = np.full(len(points), UNTAGGED, dtype=np.int32)
    if len(points) == 0 or len(ids) == 0:
        return result
    k = min(8, len(ids))
    _, near = cKDTree(0.5 * (a + b)).query(points, k=k)
    near = near.reshape(len(points), k)
    dist = np.stack([_distance_to_segments(points, a[near[:, j]], b[near[:, j]]) for j in range(k)], 1)
    best = np.argmin(dist, axis=1)
    found = dist[np.arange(len(points)), best] <= tol
    result[found] = ids[near[found, best[found]]]
    # Graded meshes can hide the containing segment behind k nearer midpoints: check those exhaustively.
    for i in np.flatnonzero(~found):
        d = _distance_to_segments(np.repeat(points[i:i + 1], len(ids), 0), a, b)
        j = np.argmin(d)
        if d[j] <= tol:
            result[i] = ids[j]
    return result


def tag_exterior_facets(msh, segments):
    """MeshTags on all local exterior facets, valued by the group of the segment they lie on."""
    msh.topology.create_entities(1)
    msh.topology.create_connectivity(1, 2)
    facets = np.sort(dolfinx.cpp.mesh.exterior_facet_indices(msh.topology)).astype(np.int32)
    midpoints = dmesh.compute_midpoints(msh, 1, facets)[:, :2]
    x = msh.geometry.x[:, :2]
    diameter = msh.comm.allreduce(float(np.ptp(x, axis=0).max()) if len(x) else 0.0, MPI.MAX)
    ids = match_segments(midpoints, segments, 1e-9 * diameter)
    return dmesh.meshtags(msh, 1, facets, ids)


def region_function(msh, values_of_owned_cells):
    """DG0 function of region ids from values on the owned cells (ghosts filled by scatter)."""
    region = fem.Function(fem.FunctionSpace(msh, ("DG", 0)), name="region")
    n_owned = msh.topology.index_map(2).size_local
    region.x.array[:n_owned] = values_of_owned_cells
    region.x.scatter_forward()
    return region


# --- built-in rectangle -----------------------------------------------------------------------

def rectangle(comm, corners, cells, diagonal="right"):
    """Rectangle whose sides are the groups left/right/bottom/top, one region 'body' (id 1)."""
    try:
        (x0, y0), (x1, y1) = ((float(x), float(y)) for x, y in corners)
    except (TypeError, ValueError):
        x0 = y0 = x1 = y1 = 0.0
    if not (x1 > x0 and y1 > y0):
        raise InputError(f"mesh.rectangle must be [[x0, y0], [x1, y1]] with x1 > x0, y1 > y0, got {corners}")
    if not (isinstance(cells, list) and len(cells) == 2 and all(isinstance(c, int) and c >= 1 for c in cells)):
        raise InputError(f"mesh.cells must be two positive integers, got {cells}")
    msh = dmesh.create_rectangle(comm, [np.array([x0, y0]), np.array([x1, y1])], [int(c) for c in cells],
                                 dmesh.CellType.triangle, dmesh.GhostMode.shared_facet,
                                 diagonal=getattr(dmesh.DiagonalType, diagonal))
    # The coordinate element as gmshio declares it (equispaced P1). FFCx 0.5 gives that variant to the
    # element while compiling, and refined meshes inherit it, so without this the first refined level
    # would compile its forms a second time.
    element = ufl.VectorElement(ufl.FiniteElement("Lagrange", "triangle", 1, variant="equispaced"))
    msh = dmesh.Mesh(msh._mesh, ufl.Mesh(element))
    corners_ccw = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
    a = corners_ccw[[3, 1, 0, 2]]  # left, right, bottom, top
    b = corners_ccw[[0, 2, 1, 3]]
    segments = (a.astype(float), b.astype(float), np.array([1, 2, 3, 4], dtype=np.int32))
    n_owned = msh.topology.index_map(2).size_local
    return Domain(msh, tag_exterior_facets(msh, segments), region_function(msh, np.ones(n_owned)),
                  dict(RECTANGLE_SIDES), {"body": 1}, segments)


# --- gmsh files -------------------------------------------------------------------------------

def _read_gmsh_model(path):
    """On one rank: open the file, check it, return (facet groups, cell groups, segments)."""
    import gmsh
    gmsh.open(str(path))
    model = gmsh.model
    if model.getDimension() != 2:
        raise InputError(f"mesh file '{path}' is {model.getDimension()}D: only 2D meshes are supported")
    names = {dim: {} for dim in (1, 2)}
    for dim, tag in model.getPhysicalGroups():
        if dim in names:
            name = model.getPhysicalName(dim, tag) or str(tag)
            if name in names[dim]:
                raise InputError(f"mesh file '{path}': two physical groups of dimension {dim} are named '{name}'")
            names[dim][name] = tag
    if not names[2]:
        raise InputError(f"mesh file '{path}' has no physical group on its cells")
    cell_edges = _check_elements(model, path)
    node_tags, node_x, _ = model.mesh.getNodes()
    xy = np.zeros((int(node_tags.max()) + 1 if len(node_tags) else 0, 2))
    xy[node_tags.astype(int)] = np.asarray(node_x).reshape(-1, 3)[:, :2]
    seen, a, b, ids, keys = {}, [], [], [], []
    for name, tag in names[1].items():
        for curve in model.getEntitiesForPhysicalGroup(1, tag):
            if curve in seen:
                raise InputError(f"mesh file '{path}': boundary curve {curve} is in two groups, "
                                 f"'{seen[curve]}' and '{name}'")
            seen[curve] = name
            types, _, nodes = model.mesh.getElements(1, curve)
            for etype, enodes in zip(types, nodes):
                if model.mesh.getElementProperties(etype)[3] != 2:
                    raise InputError(f"mesh file '{path}': only linear (P1) elements are supported")
                pairs = np.asarray(enodes, dtype=int).reshape(-1, 2)
                edge_keys = _edge_keys(pairs)
                if not np.all(np.isin(edge_keys, cell_edges)):
                    raise InputError(f"mesh file '{path}': curve {curve} of group '{name}' has elements that are "
                                     "not edges of the cells (a duplicate or detached curve?)")
                keys.append(edge_keys)
                a.append(xy[pairs[:, 0]])
                b.append(xy[pairs[:, 1]])
                ids.append(np.full(len(pairs), tag, dtype=np.int32))
    segments = (np.concatenate(a) if a else np.zeros((0, 2)), np.concatenate(b) if b else np.zeros((0, 2)),
                np.concatenate(ids) if ids else np.zeros(0, dtype=np.int32))
    if keys:  # the same facet (node pair) in two groups, e.g. through duplicate curves
        order = np.argsort(np.concatenate(keys), kind="stable")
        k, g = np.concatenate(keys)[order], segments[2][order]
        clash = np.flatnonzero((k[1:] == k[:-1]) & (g[1:] != g[:-1]))
        if len(clash):
            name_of = {tag: name for name, tag in names[1].items()}
            raise InputError(f"mesh file '{path}': a boundary facet is in two groups, "
                             f"'{name_of[g[clash[0]]]}' and '{name_of[g[clash[0] + 1]]}'")
    return names[1], names[2], segments


def _edge_keys(pairs):
    """One int64 per edge (unordered node pair)."""
    pairs = np.sort(np.asarray(pairs, dtype=np.int64), axis=1)
    return pairs[:, 0] * (1 << 31) + pairs[:, 1]


def _check_elements(model, path):
    """Check what dolfinx's gmshio would assert on or crash over (on rank 0, while the other ranks wait):
    one element type per entity of every physical group, and some cells. Returns the keys of the cell edges."""
    what = {0: "point", 1: "curve", 2: "surface"}
    edges = []
    for dim, tag in sorted(model.getPhysicalGroups(), key=lambda group: -group[0]):  # cells first
        name = model.getPhysicalName(dim, tag) or str(tag)
        for entity in model.getEntitiesForPhysicalGroup(dim, tag):
            types, _, nodes = model.mesh.getElements(dim, entity)
            if len(types) != 1:
                raise InputError(f"mesh file '{path}': group '{name}' has "
                                 f"{'no mesh elements' if len(types) == 0 else 'mixed element types'} on "
                                 f"{what.get(dim, 'entity')} {entity} (is the mesh generated and conforming?)")
            if dim == 2:
                _, _, _, num_nodes, _, corners = model.mesh.getElementProperties(types[0])
                cells = np.asarray(nodes[0], dtype=np.int64).reshape(-1, num_nodes)[:, :corners]
                edges.append(_edge_keys(np.stack([cells, np.roll(cells, -1, axis=1)], -1).reshape(-1, 2)))
    if not edges or sum(len(e) for e in edges) == 0:
        raise InputError(f"mesh file '{path}' has no cells")
    return np.unique(np.concatenate(edges))


def from_gmsh(comm, path):
    """Read a gmsh ``.msh`` file with physical groups (names become group names)."""
    import gmsh
    from dolfinx.io import gmshio
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        info, error = None, None
        if comm.rank == 0:
            try:
                info = _read_gmsh_model(path)
            except InputError as err:
                error = str(err)
            except Exception as err:  # gmsh raises plain Exceptions for unreadable files
                error = f"cannot read mesh file '{path}': {err}"
        error = comm.bcast(error, root=0)
        if error:
            raise InputError(error)
        facet_groups, cell_groups, segments = comm.bcast(info, root=0)
        msh, cell_tags, _ = gmshio.model_to_mesh(gmsh.model, comm, 0, gdim=2)
    finally:
        gmsh.finalize()
    if msh.topology.index_map(2).size_global == 0:
        raise InputError(f"mesh file '{path}' has no cells")
    n_owned = msh.topology.index_map(2).size_local
    values = np.zeros(n_owned)
    owned = cell_tags.indices < n_owned
    values[cell_tags.indices[owned]] = cell_tags.values[owned]
    return Domain(msh, tag_exterior_facets(msh, segments), region_function(msh, values),
                  facet_groups, cell_groups, segments)
