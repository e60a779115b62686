"""Plaza refinement of marked cells, carrying boundary groups, regions and the solution to the new mesh.

Refinement keeps every child cell on the rank of its parent, with a ghost layer of facet neighbours, and
inside a local (owned or ghost) parent cell. What lives on the parent is therefore transferred *locally*:

- the displacement: a child vertex is either a parent vertex or the midpoint of a parent edge, and a P1
  function is linear along edges, so its value at a child vertex is the parent's value there or the mean
  of the edge's two end values: exact (this is nested iteration's initial guess), and found by matching
  coordinates, without any point location;
- regions and boundary groups: on DOLFINx 0.9 and later from the parent maps DOLFINx returns (the parent
  of each child cell, the parent facet of each child facet); on 0.5.2, which returns them for uniform
  refinement only, by position: a child's region is its parent's at its midpoint, and a child's boundary
  facet takes the group of the parent's boundary facet that holds its centroid, among the boundary facets
  of the local parent cells (a child facet lies in a facet of its parent, and an owned child's parent is
  local). Both are local: nothing of the level-0 mesh is kept.

All of this holds for triangles and tetrahedra alike. Every supported DOLFINx refines this way
(:func:`nc_dolfinx.dolfinx_versions.refine_keeping_ranks`: natively on 0.11, with a partitioner of ours on
0.9, and on 0.5.2 with a repair of the doubled ghosts its ``redistribute=False`` can leave). Then, under
MPI, a child that left the ranks unequally busy is partitioned anew and what the cells and nodes carry
follows them (:mod:`.balance`).
"""
import weakref

import numpy as np

from dolfinx import fem, mesh as dmesh

from .. import dolfinx_versions as versions
from .balance import IMBALANCE_LIMIT, imbalance, rebalance
from . import shape
from .domain import (UNTAGGED, Domain, cell_facet_groups, distance_to_simplices, dof_of_node, global_bounds,
                     region_function, tag_from_cell_facets)

_MOVES = weakref.WeakKeyDictionary()  # rebalanced child mesh -> the Move that made it (for transfer)
_NESTED = weakref.WeakKeyDictionary()  # snapped child mesh -> its nodes before the snap (for transfer)


def refine(domain, cells=None, balance=True):
    """REFINE: Plaza refinement of the owned ``cells`` (local indices, e.g. from :func:`mark`; ``None``:
    every cell, uniform refinement) and the edges needed for conformity. Returns the new
    :class:`Domain`: each child cell in its parent's region, each child facet in its parent's boundary
    group. Children are made on their parent's rank; with ``balance`` (the default) a child whose
    busiest rank owns more than ``IMBALANCE_LIMIT`` × the mean of the cells is partitioned anew
    (:mod:`nc_dolfinx.mesh.balance`), and :func:`transfer` to its spaces fetches values across ranks."""
    msh = domain.mesh
    msh.topology.create_entities(1)  # Plaza needs the edges, also for uniform refinement of tetrahedra
    edges = None if cells is None else versions.incident_edges(msh, cells)
    child, parents = _plaza(domain, edges)
    moving = balance and msh.comm.size > 1 and imbalance(child) > IMBALANCE_LIMIT
    if not moving:
        child = versions.with_unique_ghosts(child)  # 0.5.2 only, whose parent maps come after this
    inherited = _inherited(domain, parents) if parents is not None else _inherited_by_position(domain, child)
    if moving:
        child, move = rebalance(child)
        inherited = move.cell_values(child.comm, inherited)
        _MOVES[child] = move
    refined = Domain(child, tag_from_cell_facets(child, inherited[:, 1:]), region_function(child, inherited[:, 0]),
                     domain.facet_groups, domain.cell_groups, domain.shapes)
    nested = shape.snap(refined)  # new boundary vertices onto the true shape of their groups
    if nested is not None and not moving:  # (a Move computed its values before the snap already)
        _NESTED[child] = nested
    return refined


def _inherited(domain, parents):
    """What each owned child cell takes from its parent (``parents``: the parent maps, the parent of each
    owned child cell and the parent facet of each of its facets): its region and the boundary group of each
    of its facets, (n_owned, 1 + tdim + 1)."""
    parent_cell, parent_facet = parents
    groups = cell_facet_groups(domain.mesh, domain.facet_tags)[parent_cell[:, None], np.maximum(parent_facet, 0)]
    groups[parent_facet < 0] = UNTAGGED  # a facet inside its parent is inside the body
    return np.column_stack([domain.region.x.array[parent_cell], groups])  # region: DG0, dof i = cell i


def _inherited_by_position(domain, child):
    """0.5.2 only (no parent maps): what :func:`_inherited` gives, found by position. The parent of an owned
    child cell is the local parent cell that holds its midpoint; a facet of the child on the boundary lies in
    one facet of that parent, the one closest to its centroid, whose group it takes (:func:`cell_facet_groups`,
    any rank's tag). Only the parent's own facets are candidates: where two bodies touch, a boundary facet of
    one coincides with one of the other ([[pairs]]), and a match among all boundary facets could take the
    other body's group."""
    msh, tdim = domain.mesh, domain.tdim
    n_owned = child.topology.index_map(tdim).size_local
    parent = _parent_cells(msh, child, n_owned)
    parent_groups = cell_facet_groups(msh, domain.facet_tags)
    parent_facets = _cell_facets(msh)[parent]                  # (n_owned, tdim + 1)
    child_facets = _cell_facets(child)[:n_owned]
    on_boundary = np.diff(child.topology.connectivity(tdim - 1, tdim).offsets)[child_facets] == 1
    cells, local = np.nonzero(on_boundary)
    centroids = dmesh.compute_midpoints(child, tdim - 1, child_facets[cells, local])[:, :tdim]
    distance = np.stack([distance_to_simplices(centroids, _facet_simplices(msh, parent_facets[cells, j]))
                         for j in range(tdim + 1)], axis=1) if len(cells) else np.zeros((0, tdim + 1))
    groups = np.full(child_facets.shape, UNTAGGED, dtype=np.int32)
    groups[cells, local] = parent_groups[parent[cells], np.argmin(distance, axis=1)]
    return np.column_stack([domain.region.x.array[parent], groups])


def _parent_cells(msh, child, n_owned):
    """0.5.2 only: the local parent cell of each owned child cell (the one holding the child's midpoint)."""
    tdim = child.topology.dim
    if n_owned == 0:
        return np.zeros(0, dtype=np.int32)
    midpoints = dmesh.compute_midpoints(child, tdim, np.arange(n_owned, dtype=np.int32))
    colliding = versions.colliding_cells(msh, midpoints)
    if np.any(colliding.offsets[1:] == colliding.offsets[:-1]):
        raise RuntimeError("internal error: a child cell lies outside the local parent mesh")
    return colliding.array[colliding.offsets[:-1]]


def _facet_simplices(msh, facets):
    """The vertices (n, tdim, tdim) of local facets."""
    tdim = msh.topology.dim
    nodes = versions.entities_to_geometry(msh, tdim - 1, facets)
    return msh.geometry.x[nodes.reshape(-1)][:, :tdim].reshape(len(facets), tdim, tdim)


def _cell_facets(msh):
    """The local facets of every local cell, (n_cells, tdim + 1); the facet–cell links built too."""
    tdim = msh.topology.dim
    msh.topology.create_entities(tdim - 1)
    msh.topology.create_connectivity(tdim, tdim - 1)
    msh.topology.create_connectivity(tdim - 1, tdim)
    return msh.topology.connectivity(tdim, tdim - 1).array.reshape(-1, tdim + 1)


def _plaza(domain, edges):
    """DOLFINx's Plaza refinement of ``edges``, its choices made by the geometry alone; the child and its
    parent maps (:func:`~nc_dolfinx.dolfinx_versions.refine_keeping_ranks`).

    Plaza bisects the longest edge of each face; between edges of the same length DOLFINx takes, in 3D,
    the one opposite the vertex of the largest *global index*, so the numbering (and with it the number of
    ranks) decided: a box of Kuhn tetrahedra has equal edges in every face, and the adaptive meshes of 1, 2
    and 3 ranks parted at the sixth level of the benchmark's ``box``. So in 3D the parent is refined with its
    nodes moved by a fixed function of their position (:func:`_tie_breaker`), and the child's nodes are
    then put back exactly where they belong: each is a parent node or the midpoint of a parent edge, found
    as :func:`transfer` finds it. 2D (no index rule; DOLFINx's "uniform" split of a triangle compares an
    edge ratio with an equality that a move could flip) is refined as it is."""
    msh = domain.mesh
    if msh.topology.dim != 3:
        return versions.refine_keeping_ranks(msh, edges, unique_ghosts=False)
    gdim = msh.geometry.dim
    exact = msh.geometry.x.copy()
    position = fem.Function(versions.p1_space(msh, (gdim,)))
    position.x.array.reshape(-1, gdim)[dof_of_node(position.function_space)] = exact[:, :gdim]
    msh.geometry.x[:, :gdim] += _tie_breaker(exact[:, :gdim], *global_bounds(msh.comm, exact[:, :gdim]))
    try:
        child, parents = versions.refine_keeping_ranks(msh, edges, unique_ghosts=False)
        child_position = transfer(position, versions.p1_space(child, (gdim,)))
    finally:
        msh.geometry.x[:] = exact
    moved_back = child_position.x.array.reshape(-1, gdim)
    child.geometry.x[:, :gdim] = moved_back[dof_of_node(child_position.function_space)]
    return child, parents


TIE_BREAKING_MOVE = 1e-9  # of the body's extent: edge lengths change by parts in 1e9, ties (equal to the
# last bit) are split, and edges whose lengths differ by more than that keep their order
_FREQUENCIES = np.sqrt([[2.0, 3.0, 5.0], [7.0, 11.0, 13.0], [17.0, 19.0, 23.0]])  # no two alike: no symmetry


def _tie_breaker(x, low, high):
    """A small move of each point ``x`` (n, gdim), the same function of its position on every rank
    (``low``, ``high``: the corners of the body's bounding box)."""
    extent = float(np.max(high - low))
    phase = 2 * np.pi * (x - low) / extent
    dim = x.shape[1]
    return TIE_BREAKING_MOVE * extent * np.sin(phase @ _FREQUENCIES[:dim, :dim].T + np.arange(1, dim + 1))


def evaluate(function, points, anchors=None):
    """Values of ``function`` at ``points`` (n, 3), each of which must lie in a local cell of its mesh (the
    cell that holds its ``anchor``, if given)."""
    msh = function.function_space.mesh
    points = np.ascontiguousarray(points, dtype=np.float64)
    if len(points) == 0:
        return np.zeros((0, function.function_space.dofmap.index_map_bs))
    colliding = versions.colliding_cells(msh, points if anchors is None else np.ascontiguousarray(anchors))
    offsets = colliding.offsets
    if np.any(offsets[1:] == offsets[:-1]):
        raise RuntimeError("internal error: a child point lies outside the local parent mesh")
    return function.eval(points, colliding.array[offsets[:-1]])


def transfer(function, space):
    """Interpolate a P1 ``function`` of the parent mesh into ``space`` on the child mesh: exact, since a
    child vertex is a parent vertex or an edge midpoint (nested iteration's initial guess).

    Only the vertices of *owned* child cells are sure to lie in local parent cells (their parents are
    owned here); a dof's owner may hold it through ghost cells only. So every rank computes the dofs of its
    owned cells, and the owners average what they receive (reverse scatter of values and of counts). On a
    rebalanced child the values are computed where the parents are and fetched by the ranks that hold the
    nodes now (:class:`~nc_dolfinx.mesh.balance.Move`).
    """
    move = _MOVES.get(space.mesh)
    if move is not None:
        return _moved(function, space, move)
    out, count = fem.Function(space, name=function.name), fem.Function(space)
    bs = space.dofmap.index_map_bs
    n_cells = space.mesh.topology.index_map(space.mesh.topology.dim).size_local
    in_owned_cell = np.zeros(space.dofmap.index_map.size_local + space.dofmap.index_map.num_ghosts, bool)
    in_owned_cell[versions.cell_dofs(space.dofmap)[:n_cells]] = True
    dofs = np.flatnonzero(in_owned_cell)
    x = _nested_dof_coordinates(space)
    anchors = np.empty_like(x)  # for each dof, the midpoint of an owned child cell holding it
    cell_dofs = versions.cell_dofs(space.dofmap)[:n_cells]
    anchors[cell_dofs] = x[cell_dofs].mean(axis=1)[:, None, :]
    out.x.array.reshape(-1, bs)[dofs] = _values_at_child_vertices(function, x[dofs], anchors[dofs])
    count.x.array.reshape(-1, bs)[dofs] = 1.0
    for fn in (out, count):
        fn.x.scatter_reverse(versions.SCATTER_ADD)
    n_owned = space.dofmap.index_map.size_local * bs
    if np.any(count.x.array[:n_owned] == 0):
        raise RuntimeError("internal error: a dof of the refined mesh was not reached by the transfer")
    out.x.array[:n_owned] /= count.x.array[:n_owned]
    out.x.scatter_forward()
    return out


def _nested_dof_coordinates(space):
    """Where each P1 dof of a child mesh sits in its parent's cells: its coordinates, or for a mesh whose
    boundary vertices were moved onto their surfaces (:func:`~nc_dolfinx.mesh.shape.snap`) those before
    the move, i.e. a parent vertex or edge midpoint — values carry over as on the reference cell."""
    nested = _NESTED.get(space.mesh)
    if nested is None:
        return space.tabulate_dof_coordinates()
    x = np.empty_like(nested)
    x[dof_of_node(space)] = nested
    return x


def _moved(function, space, move):
    """:func:`transfer` to a rebalanced child: the values at the nodes of the cells this rank owned before
    the move (exact, as above), then every local node's value fetched from its old owner. A P1 dof is a
    node of the mesh: the cells' dofs and nodes are listed in the same order."""
    out = fem.Function(space, name=function.name)
    values = move.node_values(space.mesh.comm, _values_at_child_vertices(function, move.points, move.anchors))
    out.x.array.reshape(-1, space.dofmap.index_map_bs)[dof_of_node(space)] = values
    return out


def _values_at_child_vertices(function, points, anchors):
    """P1 ``function`` at ``points`` (n, 3) that are vertices or edge midpoints of its local mesh.

    A point that matches no vertex or midpoint is evaluated in the parent cell that holds its ``anchor``
    (the midpoint of a child cell holding it, strictly inside one parent cell): where two bodies touch, two
    vertices share a position, nothing is matched (:func:`_match_points`), and the anchor tells which body's
    value the point takes.
    """
    V = function.function_space
    msh, bs = V.mesh, V.dofmap.index_map_bs
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    msh.topology.create_entities(1)
    msh.topology.create_connectivity(1, 0)
    msh.topology.create_connectivity(tdim, 0)
    cell_vertices = msh.topology.connectivity(tdim, 0).array  # P1: the dofs of a cell are its vertices
    dof_of_vertex = np.empty(msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts,
                             dtype=np.int32)
    dof_of_vertex[cell_vertices] = versions.cell_dofs(V.dofmap).ravel()
    edge_dofs = dof_of_vertex[msh.topology.connectivity(1, 0).array.reshape(-1, 2)]
    x = V.tabulate_dof_coordinates()[:, :gdim]
    values = function.x.array.reshape(-1, bs)
    known_x = np.concatenate([x, 0.5 * (x[edge_dofs[:, 0]] + x[edge_dofs[:, 1]])])
    known_values = np.concatenate([values, 0.5 * (values[edge_dofs[:, 0]] + values[edge_dofs[:, 1]])])

    index = _match_points(known_x, points[:, :gdim])
    found = index >= 0
    result = np.empty((len(points), bs))
    result[found] = known_values[index[found]]
    if not np.all(found):
        result[~found] = evaluate(function, points[~found], anchors[~found])
    return result


def _match_points(known, wanted):
    """Index into ``known`` (n, gdim) of each ``wanted`` point (m, gdim), -1 where none matches.

    Coordinates are compared rounded to 2^-30 of the extent of ``known`` (so a midpoint summed in another
    order still matches), two coordinates packed per int64 (one word in 2D, two in 3D), and equal words
    numbered by a sort. If rounding merges two known points, nothing is matched (the caller then locates
    every point).
    """
    if len(known) == 0 or len(wanted) == 0:
        return np.full(len(wanted), -1)
    low = known.min(axis=0)
    scale = max(float(np.max(known.max(axis=0) - low)), np.finfo(float).tiny) * 2.0 ** -30
    grid = [(points - low) / scale for points in (known, wanted)]
    inside = np.all((grid[1] > -0.5) & (grid[1] < 2.0 ** 30 + 0.5), axis=1)  # else a packed key could collide
    number = _number_rows(_pack(np.rint(np.concatenate([grid[0], grid[1][inside]])).astype(np.int64)))
    known_number, wanted_number = number[:len(known)], number[len(known):]
    if np.bincount(known_number).max() > 1:
        return np.full(len(wanted), -1)
    index_of_number = np.full(number.max() + 1, -1)
    index_of_number[known_number] = np.arange(len(known))
    result = np.full(len(wanted), -1)
    result[inside] = index_of_number[wanted_number]
    return result


def _pack(rows):
    """Rows of integers in [0, 2^30] (n, gdim), two per int64 word: (n, ceil(gdim / 2))."""
    if rows.shape[1] % 2:
        rows = np.concatenate([np.zeros((len(rows), 1), dtype=np.int64), rows], axis=1)
    return (rows[:, 0::2] << 31) | rows[:, 1::2]


def _number_rows(words):
    """The same number for equal rows of ``words``, consecutive from 0 (sorted by the last word first)."""
    order = np.argsort(words[:, -1])
    for column in words.T[-2::-1]:  # stable: rows equal in this word stay sorted by the later words
        order = order[np.argsort(column[order], kind="stable")]
    ordered = words[order]
    number = np.empty(len(words), dtype=np.int64)
    number[order] = np.cumsum(np.concatenate([[0], np.any(ordered[1:] != ordered[:-1], axis=1)]))
    return number
