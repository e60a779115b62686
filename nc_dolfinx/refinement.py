"""Plaza refinement of marked cells, carrying boundary groups, regions and the solution to the new mesh.

Refinement is done with ``redistribute=False``, so every child cell lives on the rank of its parent and
inside a local (owned or ghost) parent cell. Regions and the displacement are therefore transferred by
*local* point evaluation on the parent mesh: a region id at each child cell's midpoint, and the P1
displacement at each child vertex (exact, since the new vertices are edge midpoints and P1 is linear along
edges — this is nested iteration's initial guess). Boundary groups are re-derived geometrically from the
level-0 segments (see :mod:`nc_dolfinx.meshes`).
"""
import numpy as np

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
    n_owned = child.topology.index_map(2).size_local
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
    """Interpolate a P1 ``function`` of the parent mesh into ``space`` on the child mesh."""
    out = fem.Function(space, name=function.name)
    bs = space.dofmap.index_map_bs
    n_owned = space.dofmap.index_map.size_local
    points = space.tabulate_dof_coordinates()[:n_owned]
    out.x.array[:n_owned * bs] = evaluate(function, points).reshape(-1)
    out.x.scatter_forward()
    return out
