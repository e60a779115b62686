"""Domains from gmsh: ``.msh`` files and models built in memory, 2D (triangles) and 3D (tetrahedra).

Facet groups are the physical groups of dimension tdim - 1 (curves in 2D, surfaces in 3D), cell groups
those of dimension tdim (surfaces in 2D, volumes in 3D); a group's name is its physical name, or its tag
as a string. The model is checked on the rank that holds it for everything DOLFINx 0.5's ``gmshio`` would
assert on or crash over; an error is broadcast and raised on every rank together, so no rank is left
waiting for one that failed.
"""
import gmsh
import numpy as np

from . import dolfinx_versions as versions
from .errors import InputError
from .meshes import SUPPORTED, from_dolfinx

ENTITY = {0: "point", 1: "curve", 2: "surface", 3: "volume"}
FACETS_OF_CELLS = {2: "edges", 3: "faces"}


def from_gmsh(comm, path):
    """Read a gmsh ``.msh`` file with physical groups (names become group names)."""
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    try:
        error = None
        if comm.rank == 0:
            try:
                gmsh.open(str(path))
            except Exception as err:  # gmsh raises plain Exceptions for unreadable files
                error = f"cannot read mesh file '{path}': {err}"
        _raise_everywhere(comm, error, 0)
        return _to_domain(comm, gmsh.model, 0, f"mesh file '{path}'")
    finally:
        gmsh.finalize()


def from_gmsh_model(comm, model=None, rank=0):
    """Domain of a gmsh model (default ``gmsh.model``) meshed in memory on ``rank`` by a user script.
    Only ``rank`` needs the model; gmsh stays initialised (the caller finalises it)."""
    model = gmsh.model if model is None else model
    where = None
    if comm.rank == rank:
        where = f"gmsh model '{model.getCurrent()}'" if model.getCurrent() else "gmsh model"
    return _to_domain(comm, model, rank, where)


def _raise_everywhere(comm, error, root):
    error = comm.bcast(error, root=root)
    if error:
        raise InputError(error)


def _to_domain(comm, model, rank, where):
    info, error = None, None
    if comm.rank == rank:
        try:
            info = _inspect(model, where)
        except InputError as err:
            error = str(err)
        except Exception as err:  # a gmsh call failed on a model it cannot handle
            error = f"cannot read {where}: {err}"
    _raise_everywhere(comm, error, rank)
    facet_names, cell_names, tdim = comm.bcast(info, root=rank)
    msh, cell_tags, facet_tags = versions.model_to_mesh(model, comm, rank, gdim=tdim)
    return from_dolfinx(msh, facet_tags, facet_names, cell_tags, cell_names)


def _inspect(model, where):
    """Check the model; return ({tag: name} of facet groups, {tag: name} of cell groups, tdim)."""
    tdim = model.getDimension()
    if tdim not in (2, 3):
        raise InputError(f"{where} is {tdim}D: only 2D and 3D meshes are supported")
    names = _physical_names(model, where)
    if not names[tdim]:
        raise InputError(f"{where} has no physical group on its cells")
    cell_facets = _check_elements(model, where, tdim)
    _check_facet_groups(model, where, names[tdim - 1], cell_facets, tdim)
    _check_nodes(model, where, tdim)
    return ({tag: name for name, tag in names[tdim - 1].items()},
            {tag: name for name, tag in names[tdim].items()}, tdim)


def _physical_names(model, where):
    """{dim: {name: tag}} of the physical groups; a group without a name is called by its tag."""
    names = {dim: {} for dim in range(4)}
    for dim, tag in model.getPhysicalGroups():
        name = model.getPhysicalName(dim, tag) or str(tag)
        if name in names[dim]:
            raise InputError(f"{where}: two physical groups of dimension {dim} are named '{name}'")
        names[dim][name] = tag
    return names


def _check_elements(model, where, tdim):
    """Every entity of a physical group holds one type of linear simplex elements, each cell entity is in
    one group, and there are cells. Returns the keys of the cells' facets."""
    facets, group_of_cell_entity = [], {}
    for dim, tag in sorted(model.getPhysicalGroups(), key=lambda group: -group[0]):  # cells first
        name = model.getPhysicalName(dim, tag) or str(tag)
        for entity in model.getEntitiesForPhysicalGroup(dim, tag):
            types, _, nodes = model.mesh.getElements(dim, entity)
            for element_type in types:
                element, _, _, num_nodes, _, _ = model.mesh.getElementProperties(element_type)
                if num_nodes != dim + 1:
                    raise InputError(f"{where}: group '{name}' has {element} elements on {ENTITY[dim]} "
                                     f"{entity}: {SUPPORTED}")
            if len(types) != 1:
                raise InputError(f"{where}: group '{name}' has "
                                 f"{'no mesh elements' if len(types) == 0 else 'mixed element types'} on "
                                 f"{ENTITY[dim]} {entity} (is the mesh generated and conforming?)")
            if dim == tdim:
                if entity in group_of_cell_entity:
                    raise InputError(f"{where}: {ENTITY[dim]} {entity} is in two groups, "
                                     f"'{group_of_cell_entity[entity]}' and '{name}'")
                group_of_cell_entity[entity] = name
                cells = np.asarray(nodes[0], dtype=np.int64).reshape(-1, tdim + 1)
                facets.extend(_row_keys(np.delete(cells, j, axis=1)) for j in range(tdim + 1))
    if sum(len(f) for f in facets) == 0:
        raise InputError(f"{where} has no cells")
    return np.unique(np.concatenate(facets))


def _check_facet_groups(model, where, groups, cell_facets, tdim):
    """Each facet entity in one group, its elements facets of the cells, no facet in two groups."""
    what = ENTITY[tdim - 1]
    group_of_entity, keys, ids = {}, [], []
    for name, tag in groups.items():
        for entity in model.getEntitiesForPhysicalGroup(tdim - 1, tag):
            if entity in group_of_entity:
                raise InputError(f"{where}: boundary {what} {entity} is in two groups, "
                                 f"'{group_of_entity[entity]}' and '{name}'")
            group_of_entity[entity] = name
            _, _, nodes = model.mesh.getElements(tdim - 1, entity)
            entity_keys = _row_keys(np.asarray(nodes[0], dtype=np.int64).reshape(-1, tdim))
            if not np.all(np.isin(entity_keys, cell_facets)):
                raise InputError(f"{where}: {what} {entity} of group '{name}' has elements that are not "
                                 f"{FACETS_OF_CELLS[tdim]} of the cells (a duplicate or detached {what}?)")
            keys.append(entity_keys)
            ids.append(np.full(len(entity_keys), tag, dtype=np.int32))
    if keys:  # the same facet (node set) in two groups, e.g. through duplicate entities
        facet = np.unique(np.concatenate(keys), return_inverse=True)[1]
        order = np.argsort(facet, kind="stable")
        k, g = facet[order], np.concatenate(ids)[order]
        clash = np.flatnonzero((k[1:] == k[:-1]) & (g[1:] != g[:-1]))
        if len(clash):
            name_of = {tag: name for name, tag in groups.items()}
            raise InputError(f"{where}: a boundary facet is in two groups, "
                             f"'{name_of[g[clash[0]]]}' and '{name_of[g[clash[0] + 1]]}'")


def _check_nodes(model, where, tdim):
    """gmshio asserts that the node tags are 1..N; a 2D mesh must be flat (gmshio drops z)."""
    tags, x, _ = model.mesh.getNodes()
    if not np.array_equal(np.sort(tags), np.arange(1, len(tags) + 1)):
        raise InputError(f"{where}: the node tags are not 1..N (renumber the nodes in gmsh)")
    if tdim == 2 and len(tags) and np.ptp(np.asarray(x).reshape(-1, 3)[:, 2]) > 0:
        raise InputError(f"{where}: a 2D mesh must lie in a plane z = constant")


def _row_keys(rows):
    """One hashable, sortable key per row of node tags, whatever the order of the nodes in the row."""
    rows = np.ascontiguousarray(np.sort(np.asarray(rows, dtype=np.int64), axis=1))
    return rows.view(np.dtype((np.void, rows.dtype.itemsize * rows.shape[1]))).ravel()
