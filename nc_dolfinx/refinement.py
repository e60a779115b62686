"""Plaza refinement of marked cells, carrying boundary groups, regions and the solution to the new mesh.

Refinement is done with ``redistribute=False``, so every child cell lives on the rank of its parent and
inside a local (owned or ghost) parent cell. Regions and the displacement are therefore transferred by
*local* point evaluation on the parent mesh: a region id at each child cell's midpoint, and the P1
displacement at each child vertex (exact, since the new vertices are edge midpoints and P1 is linear along
edges — this is nested iteration's initial guess). Boundary groups are re-derived geometrically from the
level-0 segments (see :mod:`nc_dolfinx.meshes`).

DOLFINx 0.5's refinement builds the new ghost layer with a partitioner that sends a cell once per
off-rank *neighbour*: a cell with two facet-neighbours on the same rank arrives there twice, and the facet
between the duplicate ghosts and their neighbour then has three cells and drops out of interior-facet
(``dS``) integrals (seen on 3 ranks: one interior edge missing from the jump terms of η_2). We therefore
re-create the refined mesh with :func:`_rebuild_with_unique_ghosts`, which keeps every cell on its rank and
ghosts it once on each neighbouring rank.
"""
import numpy as np

import dolfinx
from dolfinx import fem, geometry, mesh as dmesh

from .meshes import Domain, region_function, tag_exterior_facets


def refine(domain, cells=None):
    """Refine the owned ``cells`` (local indices; ``None``: every cell) and return the new Domain."""
    msh = domain.mesh
    if cells is None:
        child = dmesh.refine(msh, redistribute=False)
    else:
        msh.topology.create_entities(1)
        edges = dmesh.compute_incident_entities(msh, np.asarray(cells, dtype=np.int32), 2, 1)
        child = dmesh.refine(msh, edges, redistribute=False)
    if msh.comm.size > 1:
        child = _rebuild_with_unique_ghosts(child)
    n_owned = child.topology.index_map(2).size_local
    if len(domain.cell_groups) == 1:  # one region: nothing to locate
        regions = np.full(n_owned, next(iter(domain.cell_groups.values())))
    else:
        midpoints = dmesh.compute_midpoints(child, 2, np.arange(n_owned, dtype=np.int32))
        regions = np.rint(evaluate(domain.region, midpoints)[:, 0])
    return Domain(child, tag_exterior_facets(child, domain.segments), region_function(child, regions),
                  domain.facet_groups, domain.cell_groups, domain.segments)


def evaluate(function, points):
    """Values of ``function`` at ``points`` (n, 3), each of which must lie in a local cell of its mesh."""
    msh = function.function_space.mesh
    points = np.ascontiguousarray(points, dtype=np.float64)
    if len(points) == 0:
        return np.zeros((0, function.function_space.dofmap.index_map_bs))
    tree = geometry.BoundingBoxTree(msh, msh.topology.dim)
    candidates = geometry.compute_collisions(tree, points)
    colliding = geometry.compute_colliding_cells(msh, candidates, points)
    offsets = colliding.offsets
    if np.any(offsets[1:] == offsets[:-1]):
        raise RuntimeError("internal error: a child point lies outside the local parent mesh")
    return function.eval(points, colliding.array[offsets[:-1]])


def transfer(function, space):
    """Interpolate a P1 ``function`` of the parent mesh into ``space`` on the child mesh.

    Only the vertices of *owned* child cells are sure to lie in local parent cells (their parents are
    owned here); a dof's owner may hold it through ghost cells only. So every rank evaluates the dofs of its
    owned cells, and the owners average what they receive (reverse scatter of values and of counts).
    """
    out, count = fem.Function(space, name=function.name), fem.Function(space)
    bs = space.dofmap.index_map_bs
    n_cells = space.mesh.topology.index_map(2).size_local
    dofs = np.unique(space.dofmap.list.array.reshape(-1, 3)[:n_cells])
    out.x.array.reshape(-1, bs)[dofs] = evaluate(function, space.tabulate_dof_coordinates()[dofs])
    count.x.array.reshape(-1, bs)[dofs] = 1.0
    for fn in (out, count):
        fn.x.scatter_reverse(dolfinx.la.ScatterMode.add)
    n_owned = space.dofmap.index_map.size_local * bs
    if np.any(count.x.array[:n_owned] == 0):
        raise RuntimeError("internal error: a dof of the refined mesh was not reached by the transfer")
    out.x.array[:n_owned] /= count.x.array[:n_owned]
    out.x.scatter_forward()
    return out


def _rebuild_with_unique_ghosts(msh):
    """The same distributed mesh (owned cells stay on their rank), with a duplicate-free ghost layer."""
    comm = msh.comm
    node_map = msh.geometry.index_map()
    n_cells = msh.topology.index_map(2).size_local
    nodes = msh.geometry.dofmap.array.reshape(-1, 3)[:n_cells]
    cells = node_map.local_to_global(nodes.ravel()).reshape(-1, 3)
    x = msh.geometry.x[:node_map.size_local, :2]

    def keep_local_partitioner(comm_, nparts, tdim, cell_topology, ghost_mode):
        graph = dolfinx.cpp.mesh.build_dual_graph(comm_, cell_topology, tdim)
        counts = np.array(comm.allgather(graph.num_nodes))
        starts = np.concatenate([[0], np.cumsum(counts)])
        rank = comm.rank
        cell = np.repeat(np.arange(graph.num_nodes), np.diff(graph.offsets))
        owner = np.searchsorted(starts, graph.array, side="right") - 1
        pairs = np.unique(np.stack([cell, owner], 1)[owner != rank], axis=0)
        ghosts = np.split(pairs[:, 1], np.searchsorted(pairs[:, 0], np.arange(1, graph.num_nodes)))
        destinations = [np.concatenate([[rank], g]) for g in ghosts]
        offsets = np.concatenate([[0], np.cumsum([len(d) for d in destinations])]).astype(np.int32)
        array = np.concatenate(destinations).astype(np.int32) if destinations else np.zeros(0, np.int32)
        return dolfinx.cpp.graph.AdjacencyList_int32(array, offsets)

    return dmesh.create_mesh(comm, cells, x, msh.ufl_domain(), dmesh.GhostMode.shared_facet,
                             keep_local_partitioner)
