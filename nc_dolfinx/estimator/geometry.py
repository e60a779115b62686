"""Mesh helpers of the estimator (Definition 5, §4.1), for triangles and tetrahedra alike.

- :func:`cell_diameters`: h_K (the longest edge, = the diameter of a simplex) of the owned cells.
- :func:`diameters`: h_F of facets (|E| for an edge, the longest edge of a triangular face), for ζ's
  Neumann part.
- :func:`facet_layers`: boundary facets in layers with at most one facet per cell, so that ``ds`` over
  one layer gives per-facet means from a cellwise assembly.
- :func:`patch_sum`: Σ_{K' ⊂ ω_K} o_K' over the vertex patch ω_K, by inclusion–exclusion over the
  sub-simplices of K, parallel with facet ghosts only.

The cell's geometry nodes are its vertices (P1 geometry).
"""
import math

import numpy as np
from mpi4py import MPI

import dolfinx
from dolfinx import fem, mesh as dmesh

from .. import dolfinx_versions as versions


def diameters(msh, dim, entities):
    """Diameters (longest edge) of local mesh entities of dimension ``dim`` (DOLFINx's C++ ``h``)."""
    return versions.diameters(msh, dim, entities)


def cell_diameters(msh):
    """h_K (the longest edge) of the owned cells (P1 simplices)."""
    tdim = msh.topology.dim
    return diameters(msh, tdim, np.arange(msh.topology.index_map(tdim).size_local))


def facet_layers(domain, groups):
    """The owned exterior facets of the boundary ``groups`` (a sorted sequence of group ids), dealt into
    layers that each hold at most one facet of any cell: a list of (meshtags of the layer's facets, tagged
    1 + k for the k-th group; those facets; their cells). ``ds`` over one layer sees at most one facet per
    cell, so per-facet integrals come out of a cellwise assembly, before the ghost cells' values are sent
    to their owners. As many layers as the most such facets one cell has on some rank: usually one (a
    tetrahedron with two faces on one boundary part sits at an edge of it), the same count on every rank,
    since the forms over them are built collectively."""
    msh, tags = domain.mesh, domain.facet_tags
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    mask = np.isin(tags.values, groups)
    facets = tags.indices[mask]
    tag = (1 + np.searchsorted(groups, tags.values[mask])).astype(np.int32)
    cells = f2c.array[f2c.offsets[facets]]  # an exterior facet has one cell
    order = np.argsort(cells, kind="stable")
    layer = np.empty(len(facets), dtype=np.int64)  # the facet's place among its cell's facets
    layer[order] = np.arange(len(facets)) - np.searchsorted(cells[order], cells[order])
    count = msh.comm.allreduce(int(layer.max()) + 1 if len(layer) else 0, MPI.MAX)
    return [(dmesh.meshtags(msh, tdim - 1, facets[layer == i], tag[layer == i]), facets[layer == i],
             cells[layer == i]) for i in range(count)]


def owned_values_with_ghosts(Q, owned_values, name="o", ufunc=None):
    """A DG0 function on ``Q`` holding ``owned_values`` (or ``ufunc`` of them, e.g. ``np.sqrt``, written in
    place) on the owned cells and the owners' on the ghosts."""
    fn = fem.Function(Q, name=name)
    owned = fn.x.array[:len(owned_values)]
    if ufunc is None:
        owned[:] = owned_values
    else:
        ufunc(owned_values, out=owned)
    fn.x.scatter_forward()
    return fn


def patch_sum(o, Q):
    """Σ_{K' ⊂ ω_K} o_K' for every owned K (ω_K: the cells sharing a vertex with K, the patch of §3), from
    owned-cell ``o`` — the sum over the patch in ζ_K of Definition 5.

    Inclusion–exclusion over the sub-simplices s of K (a cell K' ∈ ω_K meets K in one sub-simplex, whose
    own sub-simplices count K' with alternating signs summing to one)::

        Σ_{K' ⊂ ω_K} o_K' = Σ_{d=0}^{tdim} (−1)^d Σ_{s ⊂ K, dim s = d} S_s,   S_s = Σ_{K' ∋ s} o_K'.

    For vertices (and edges in 3D) S_s is added up over the owned cells of every rank (reverse scatter on
    index_map(d) to the owners, forward scatter back). The facet and cell terms together are
    (−1)^{tdim−1} (tdim·o_K + Σ_{N ~ K} o_N) (N: the facet neighbours, from the facet ghosts). In 2D this
    is Σ_{x ∈ K} S_x − 2 o_K − Σ_N o_N; in 3D, cells sharing only an edge with K are not counted twice.
    """
    msh = Q.mesh
    tdim = msh.topology.dim
    n_owned = len(o)
    total = 0.0
    for d in range(tdim - 1):
        msh.topology.create_entities(d)
        msh.topology.create_connectivity(tdim, d)
        per_cell = math.comb(tdim + 1, d + 1)
        entities = msh.topology.connectivity(tdim, d).array.reshape(-1, per_cell)[:n_owned]
        S = dolfinx.la.vector(msh.topology.index_map(d))
        S.array[:] = np.bincount(entities.ravel(), weights=np.repeat(o, entities.shape[1]),
                                 minlength=len(S.array))
        S.scatter_reverse(versions.SCATTER_ADD)
        S.scatter_forward()
        term = S.array[entities].sum(axis=1)
        total = term if d == 0 else total + (-1) ** d * term
    sign = (-1) ** (tdim - 1)
    msh.topology.create_connectivity(tdim - 1, tdim)
    o_all = owned_values_with_ghosts(Q, o).x.array
    f2c = msh.topology.connectivity(tdim - 1, tdim)
    interior = np.flatnonzero(np.diff(f2c.offsets) == 2)
    pairs = f2c.array[f2c.offsets[interior][:, None] + np.arange(2)]
    neighbours = (np.bincount(pairs[:, 0], weights=o_all[pairs[:, 1]], minlength=len(o_all))
                  + np.bincount(pairs[:, 1], weights=o_all[pairs[:, 0]], minlength=len(o_all)))
    total = total + sign * tdim * o
    return total + sign * neighbours[:n_owned]
