"""A :class:`~nc_dolfinx.mesh.domain.Domain` from any DOLFINx mesh of linear simplices and its meshtags.

This is how a user's own mesh enters (:func:`from_dolfinx`), and how a gmsh mesh does once DOLFINx has
read it (:mod:`nc_dolfinx.mesh.gmsh_io`). The owned exterior facets are tagged from the meshtags on any
local copy of the facet; refinement carries the tags on by the parent maps (:mod:`nc_dolfinx.mesh.domain`).
"""
import numpy as np
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh

from .. import dolfinx_versions as versions
from ..errors import InputError
from .domain import UNTAGGED, Domain, cell_facet_groups, cell_space, region_function, tag_from_cell_facets

SUPPORTED = "only linear triangles (2D) and tetrahedra (3D) are supported"


def from_dolfinx(mesh, facet_tags, facet_names=None, cell_tags=None, cell_names=None):
    """Domain of a DOLFINx mesh (linear triangles or tetrahedra) and its meshtags.

    ``facet_names``/``cell_names`` map tag values to group names (default: the tag value as a string);
    a name given for a value no facet carries still makes a (then empty) group. Exterior facets that no
    tag reaches (on any rank) are ``UNTAGGED``; tag 0 is reserved for them. Without
    ``cell_tags`` every cell is in region 'body' (id 1); cells that ``cell_tags`` leaves out are in region
    0, the group 'untagged' (unless a group has id 0 already), and keep the default material.
    """
    _check_linear_simplices(mesh)
    tdim = mesh.topology.dim
    for tags, dim, what in ((facet_tags, tdim - 1, "facet"), (cell_tags, tdim, "cell")):
        if tags is not None and tags.dim != dim:
            raise InputError(f"{what} tags must be of dimension {dim} on a {tdim}D mesh, got {tags.dim}")
    facet_groups = _groups(mesh.comm, facet_tags, facet_names, "facet")
    if UNTAGGED in facet_groups.values():
        raise InputError(f"facet tag {UNTAGGED} is reserved for untagged facets")
    n_owned = mesh.topology.index_map(tdim).size_local
    tags = tag_from_cell_facets(mesh, cell_facet_groups(mesh, facet_tags)[:n_owned])
    if cell_tags is None:
        regions, cell_groups = np.ones(n_owned), {"body": 1}
    else:
        regions, cell_groups = _owned_cell_values(mesh, cell_tags), _groups(mesh.comm, cell_tags, cell_names, "cell")
        if mesh.comm.allreduce(bool(np.any(np.isnan(regions))), MPI.LOR) and UNTAGGED not in cell_groups.values():
            cell_groups["untagged"] = UNTAGGED
        regions = np.nan_to_num(regions, nan=UNTAGGED)
    return Domain(mesh, tags, region_function(mesh, regions), facet_groups, cell_groups)


def _check_linear_simplices(msh, where="mesh"):
    cell, gdim = msh.topology.cell_type, msh.geometry.dim
    degree = versions.coordinate_degree(msh)
    if cell not in (dmesh.CellType.triangle, dmesh.CellType.tetrahedron) or degree != 1 or gdim != msh.topology.dim:
        raise InputError(f"{where} of {cell.name} cells of degree {degree} in {gdim}D: {SUPPORTED}")


def _groups(comm, tags, names, what):
    """name -> id for every tag value on any rank and every named value."""
    names = {int(value): str(name) for value, name in (names or {}).items()}
    local = np.unique(tags.values) if tags is not None else np.zeros(0, dtype=np.int32)
    values = sorted(set(np.concatenate(comm.allgather(local)).tolist()) | set(names))
    groups = {names.get(v, str(v)): v for v in values}
    if len(groups) < len(values):
        raise InputError(f"two {what} groups have the same name: {sorted(names.values())}")
    return groups


def _owned_cell_values(msh, cell_tags):
    """Tag of every owned cell (NaN where untagged), whichever local copy of the cell carries it."""
    V = cell_space(msh)  # dof i is cell i
    total, count = fem.Function(V), fem.Function(V)
    total.x.array[cell_tags.indices] = cell_tags.values
    count.x.array[cell_tags.indices] = 1.0
    for fn in (total, count):
        fn.x.scatter_reverse(versions.SCATTER_ADD)
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count.x.array[:n_owned] > 0, total.x.array[:n_owned] / count.x.array[:n_owned], np.nan)

