"""Domains from the built-in rectangle (2D) and box (3D), from gmsh, and from a user's DOLFINx mesh.

Every constructor returns a :class:`~nc_dolfinx.domain.Domain` whose ``boundary`` covers the whole level-0
exterior boundary (untagged parts with id ``UNTAGGED``), so that refined meshes are re-tagged by the
same geometric matcher, in 2D and 3D alike.
"""
import itertools

import numpy as np
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh

from .domain import (UNTAGGED, Domain, distance_to_simplices, match_simplices,  # noqa: F401 (re-exported)
                     cell_space, owned_exterior_facets, region_function, tag_exterior_facets)
from . import dolfinx_versions as versions
from .errors import InputError

RECTANGLE_SIDES = {"left": 1, "right": 2, "bottom": 3, "top": 4}
BOX_SIDES = {"left": 1, "right": 2, "front": 3, "back": 4, "bottom": 5, "top": 6}
SUPPORTED = "only linear triangles (2D) and tetrahedra (3D) are supported"


# --- built-in rectangle and box ---------------------------------------------------------------

def rectangle(comm, corners, cells, diagonal="right"):
    """Rectangle whose sides are the groups left/right/bottom/top (ids 1-4), one region 'body' (id 1)."""
    low, high, cells = _axis_aligned_input("rectangle", corners, cells, 2)
    msh = versions.create_rectangle(comm, [low, high], cells, diagonal)
    return _axis_aligned_domain(msh, low, high, RECTANGLE_SIDES)


def box(comm, corners, cells):
    """Box of tetrahedra whose faces are the groups left/right (x = x0/x1), front/back (y = y0/y1) and
    bottom/top (z = z0/z1), ids 1-6; one region 'body' (id 1)."""
    low, high, cells = _axis_aligned_input("box", corners, cells, 3)
    msh = versions.create_box(comm, [low, high], cells)
    return _axis_aligned_domain(msh, low, high, BOX_SIDES)


def _axis_aligned_input(kind, corners, cells, gdim):
    """Checked (low corner, high corner, cell counts) of a rectangle (gdim 2) or box (gdim 3)."""
    axes = "xyz"[:gdim]
    try:
        low, high = (np.array([float(c) for c in corner]) for corner in corners)
        valid = len(corners) == 2 and len(low) == len(high) == gdim and np.all(high > low)
    except (TypeError, ValueError):
        valid = False
    if not valid:
        form = f"[[{', '.join(a + '0' for a in axes)}], [{', '.join(a + '1' for a in axes)}]]"
        raise InputError(f"mesh.{kind} must be {form} with {', '.join(f'{a}1 > {a}0' for a in axes)}, "
                         f"got {corners}")
    if not (isinstance(cells, list) and len(cells) == gdim and all(isinstance(c, int) and c >= 1 for c in cells)):
        raise InputError(f"mesh.cells must be {['two', 'three'][gdim - 2]} positive integers, got {cells}")
    return low, high, [int(c) for c in cells]


def _axis_aligned_domain(msh, low, high, sides):
    msh = versions.with_equispaced_coordinates(msh)
    boundary = _box_faces(low, high)
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    return Domain(msh, tag_exterior_facets(msh, boundary), region_function(msh, np.ones(n_owned)),
                  dict(sides), {"body": 1}, boundary)


def _box_faces(low, high):
    """The sides of the axis-aligned box [low, high] as simplices (segments in 2D, two triangles per face
    in 3D), with ids 2·axis + 1 (side at low) and 2·axis + 2 (at high)."""
    gdim = len(low)
    simplices, ids = [], []
    for axis, side in itertools.product(range(gdim), (0, 1)):
        free = [a for a in range(gdim) if a != axis]
        for order in itertools.permutations(free):  # Kuhn's split of the face into simplices
            corners = np.zeros((gdim, gdim), dtype=bool)  # corner j: the first j free axes at high
            for j, a in enumerate(order):
                corners[j + 1:, a] = True
            corners[:, axis] = bool(side)
            simplices.append(np.where(corners, high, low))
            ids.append(2 * axis + side + 1)
    return np.array(simplices, dtype=float), np.array(ids, dtype=np.int32)


# --- a user's DOLFINx mesh --------------------------------------------------------------------

def from_dolfinx(mesh, facet_tags, facet_names=None, cell_tags=None, cell_names=None):
    """Domain of a DOLFINx mesh (linear triangles or tetrahedra) and its meshtags.

    ``facet_names``/``cell_names`` map tag values to group names (default: the tag value as a string);
    a name given for a value no facet carries still makes a (then empty) group. Exterior facets that no
    tag reaches on their owning rank are ``UNTAGGED``; tag 0 is reserved for them. Without
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
    boundary = gather_boundary(mesh, facet_tags)
    if cell_tags is None:
        regions, cell_groups = np.ones(mesh.topology.index_map(tdim).size_local), {"body": 1}
    else:
        regions, cell_groups = _owned_cell_values(mesh, cell_tags), _groups(mesh.comm, cell_tags, cell_names, "cell")
        if mesh.comm.allreduce(bool(np.any(np.isnan(regions))), MPI.LOR) and UNTAGGED not in cell_groups.values():
            cell_groups["untagged"] = UNTAGGED
        regions = np.nan_to_num(regions, nan=UNTAGGED)
    return Domain(mesh, tag_exterior_facets(mesh, boundary), region_function(mesh, regions),
                  facet_groups, cell_groups, boundary)


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


def gather_boundary(msh, facet_tags):
    """Every owned exterior facet of every rank as (vertices (n, tdim, gdim), ids (n,)), on all ranks."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    facets = owned_exterior_facets(msh)
    nodes = versions.entities_to_geometry(msh, tdim - 1, facets)
    vertices = msh.geometry.x[nodes.reshape(-1)][:, :gdim].reshape(len(facets), tdim, gdim)
    ids = np.full(len(facets), UNTAGGED, dtype=np.int32)
    if facet_tags is not None and len(facet_tags.indices):
        position = np.minimum(np.searchsorted(facet_tags.indices, facets), len(facet_tags.indices) - 1)
        tagged = facet_tags.indices[position] == facets
        ids[tagged] = facet_tags.values[position[tagged]]
    gathered = msh.comm.allgather((vertices, ids))
    return (np.concatenate([v for v, _ in gathered]).reshape(-1, tdim, gdim),
            np.concatenate([i for _, i in gathered]).astype(np.int32))


# --- gmsh (in nc_dolfinx.gmsh_io, which builds on from_dolfinx) --------------------------------

def from_gmsh(comm, path):
    """Read a gmsh ``.msh`` file (2D triangles or 3D tetrahedra) with its physical groups. Only a file
    whose name ends in ``.msh`` and that starts with ``$MeshFormat`` (MSH 2 to 4, ASCII or binary) reaches
    gmsh, which would run anything else as a script; an ``.opt`` file beside it is not read."""
    from .gmsh_io import from_gmsh as read
    return read(comm, path)


def from_gmsh_model(comm, model=None, rank=0, build=None):
    """Domain of a gmsh model built in memory on ``rank`` (default: ``gmsh.model``). Under MPI give the
    one-rank work as ``build``, a callable ``build(gmsh)`` (or ``build()``) that makes and meshes the model:
    it runs on ``rank`` only, inside ``gmsh.initialize()``/``gmsh.finalize()``, and an exception it raises
    becomes an InputError on every rank together ("the gmsh model built on rank 0 failed: …"), where a
    script that builds the model itself and fails before this call leaves the other ranks waiting here."""
    from .gmsh_io import from_gmsh_model as convert
    return convert(comm, model, rank, build)
