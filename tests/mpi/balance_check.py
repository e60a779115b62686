"""Refinement with and without rebalancing, compared (tests/test_refinement.py).

Usage: balance_check.py 2|3 [LEVELS]: a rectangle (2D) or box (3D) with two regions, refined LEVELS times
towards one corner (the cells near it marked, so the refined cells pile up on few ranks). At every level
the same parent is refined twice, with ``balance=True`` and ``balance=False``, and a P1 field (its nodal
values a non-linear function of the coordinates, so a value put at the wrong node shows) is transferred
to both. Rank 0 prints one JSON line per level: the imbalance of both children, whether the balanced one
was partitioned anew, and whether the two agree exactly: the owned cells (midpoint → region), the boundary
facets (midpoint → group) and the transferred field (dof coordinates → value), as sets over all ranks.
"""
import json
import sys

import numpy as np
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.mesh import balance, refinement
from nc_dolfinx.mesh.domain import region_function

comm = MPI.COMM_WORLD
dim, levels = int(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 3


def two_regions(domain):
    """The same domain with the cells of x > 1 in a second region 'hard' (id 2)."""
    tdim = domain.tdim
    n = domain.mesh.topology.index_map(tdim).size_local
    x = dmesh.compute_midpoints(domain.mesh, tdim, np.arange(n, dtype=np.int32))
    region = region_function(domain.mesh, np.where(x[:, 0] > 1.0, 2, 1))
    return nc.Domain(domain.mesh, domain.facet_tags, region, domain.facet_groups, {"soft": 1, "hard": 2})


def gathered(rows):
    """Rows (n, k) of every rank, rounded and sorted on rank 0 (None elsewhere)."""
    everything = comm.gather(np.asarray(rows, dtype=float).round(12), root=0)
    if comm.rank == 0:
        rows = np.concatenate(everything)
        return rows[np.lexsort(rows.T[::-1])]


def snapshot(domain, u):
    msh, tdim = domain.mesh, domain.tdim
    n = msh.topology.index_map(tdim).size_local
    cells = dmesh.compute_midpoints(msh, tdim, np.arange(n, dtype=np.int32))
    regions = domain.region.x.array[:n]
    tags = domain.facet_tags
    facets = dmesh.compute_midpoints(msh, tdim - 1, tags.indices)
    V = u.function_space
    owned = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    dofs = V.tabulate_dof_coordinates()[:owned]
    return [gathered(np.column_stack([cells, regions])), gathered(np.column_stack([facets, tags.values])),
            gathered(np.column_stack([dofs, u.x.array.reshape(-1, bs)[:owned]]))]


corners = [[0.0] * dim, [2.0] + [1.0] * (dim - 1)]
domain = two_regions(nc.rectangle(comm, corners, [24, 12]) if dim == 2 else nc.box(comm, corners, [8, 4, 4]))
V = versions.p1_space(domain.mesh, (dim,))
u = fem.Function(V)
u.interpolate(lambda x: np.stack([np.sin(3 * x[0]) + x[1] ** 2, np.cos(2 * x[1]) * x[0], x[2] ** 3 + x[0]][:dim]))
for level in range(levels):
    n = domain.mesh.topology.index_map(domain.tdim).size_local
    x = dmesh.compute_midpoints(domain.mesh, domain.tdim, np.arange(n, dtype=np.int32))
    marked = np.flatnonzero(np.linalg.norm(x[:, :dim], axis=1) < 0.6 / 1.6 ** level).astype(np.int32)
    children = {}
    for balanced in (True, False):
        child = nc.refine(domain, marked, balance=balanced)
        uc = nc.transfer(u, versions.p1_space(child.mesh, (dim,)))
        children[balanced] = (child, uc, balance.imbalance(child.mesh), snapshot(child, uc))
    same = [bool(a.shape == b.shape and np.array_equal(a, b)) if comm.rank == 0 else None
            for a, b in zip(children[True][3], children[False][3])]
    if comm.rank == 0:
        print(json.dumps({"level": level + 1, "cells": int(len(children[True][3][0])),
                          "imbalance": children[True][2], "imbalance_unbalanced": children[False][2],
                          "moved": children[True][0].mesh in refinement._MOVES,
                          "same_cells": same[0], "same_facets": same[1], "same_field": same[2]}), flush=True)
    domain, u = children[True][0], children[True][1]
