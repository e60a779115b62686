"""Domains from gmsh: ``.msh`` files and models built in memory, 2D (triangles) and 3D (tetrahedra).

Facet groups are the physical groups of dimension tdim - 1 (curves in 2D, surfaces in 3D), cell groups
those of dimension tdim (surfaces in 2D, volumes in 3D); a group's name is its physical name, or its tag
as a string. The model is checked on the rank that holds it for everything DOLFINx 0.5's ``gmshio`` would
assert on or crash over; an error is broadcast and raised on every rank together, so no rank is left
waiting for one that failed.

``gmsh`` is imported inside the functions that call it (:func:`import_gmsh`): loading it takes 0.4 s that
only gmsh users pay.
"""
import contextlib
import importlib
import inspect
import os
import shutil
import signal
import stat
import sys
import tempfile
import threading

import numpy as np

from .. import dolfinx_versions as versions
from ..errors import InputError, brief_text
from .tagged import SUPPORTED, from_dolfinx

ENTITY = {0: "point", 1: "curve", 2: "surface", 3: "volume"}
FACETS_OF_CELLS = {2: "edges", 3: "faces"}
MSH_SIGNATURE = b"$MeshFormat"  # the first bytes of every MSH 2 and 4 file, ASCII and binary


def import_gmsh():
    """The ``gmsh`` module, imported on first use, with the SIGINT handler in place kept (:func:`_keep_sigint`):
    gmsh 4.8 (bookworm) sets SIGINT to SIG_DFL when imported."""
    if "gmsh" in sys.modules:
        return sys.modules["gmsh"]
    return _keep_sigint(lambda: importlib.import_module("gmsh"))


@contextlib.contextmanager
def gmsh_session():
    """``gmsh.initialize()`` … ``gmsh.finalize()``, the SIGINT handler in place kept through both. gmsh sets
    SIGINT to SIG_DFL (4.8 when imported, 4.13 and 4.15 in ``initialize``) and 4.13 and 4.15 never restore
    it (``finalize`` reads a module variable that ``initialize`` assigned as a local): without this, Ctrl-C
    after a gmsh mesh was built would kill a run on trixie and sid instead of ending it cleanly."""
    gmsh = import_gmsh()
    _keep_sigint(gmsh.initialize)
    _SESSIONS.append(gmsh)
    try:
        yield gmsh
    finally:
        _SESSIONS.pop()
        _keep_sigint(gmsh.finalize)


_SESSIONS = []  # the sessions of gmsh_session now open (gmsh 4.8 cannot say whether it is initialised)


def in_session():
    """Whether a :func:`gmsh_session` is open (gmsh is initialised by this package)."""
    return bool(_SESSIONS)


def _keep_sigint(call):
    """``call()``, then the SIGINT handler found before it put back (the command line's, cli/interrupt.py)."""
    before = signal.getsignal(signal.SIGINT)
    try:
        return call()
    finally:
        if before is not None and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, before)


def _file(path):
    """A file's name for a message: in full (control characters escaped) unless absurdly long."""
    return brief_text(path, 300)


def from_gmsh(comm, path):
    """Read a gmsh ``.msh`` file with physical groups (names become group names); a list of files (bodies
    meshed apart, e.g. for [[pairs]]) is read into one mesh, each file's nodes, cells and groups as they are
    (:func:`_merged`).

    gmsh reads whatever it does not recognise as a *script* (a .geo file), and a script can run commands
    (``SystemCall``, ``Shell``); so only a file that gmsh reads as a mesh is handed to it. gmsh's
    ``MergeFile`` (behind ``gmsh.open`` and ``gmsh.merge``, the same in gmsh 4.8, 4.13 and 4.15, bookworm to
    sid) picks a reader by the name's extension first (``.gz``: a shell ``gunzip``; ``.stl``, ``.step``, …;
    ONELAB solvers' extensions), then, for any other extension, ``.msh`` included, by the first line: one
    that begins with the 11 bytes ``$MeshFormat`` goes to ``GModel::readMSH`` (and the post-processing
    reader of MSH data), whose MSH 2/3/4 parsers never call the script parser; everything else goes to
    ``GModel::readGEO``, the script parser. Hence the check, on the rank that reads, before gmsh sees the
    file: the name ends in ``.msh`` and the file's first bytes are exactly ``$MeshFormat`` (gmsh compares
    them at the very start: a BOM or whitespace before them makes the file a script). After reading it,
    ``MergeFile`` also merges ``<file>.opt`` if that exists — as a script (gmsh's GUI saves display options
    there); so gmsh reads the file through a link in a private temporary folder, where there is none.
    A missing, unreadable or special file (a directory, a FIFO) is refused too, without waiting on it."""
    with gmsh_session() as gmsh:
        gmsh.option.setNumber("General.Terminal", 0)
        error = None
        paths = list(path) if isinstance(path, (list, tuple)) else [path]
        if comm.rank == 0:
            error = _merged(paths) if len(paths) > 1 else _not_a_mesh_file(path) or _open_mesh_file(path)
        _raise_everywhere(comm, error, 0)
        where = f"mesh file '{_file(path)}'" if len(paths) == 1 else \
            f"mesh files {', '.join(repr(_file(p)) for p in paths)}"
        return _to_domain(comm, gmsh.model, 0, where)


def _merged(paths):
    """The files' meshes as one gmsh model (rank 0): each file read in turn (checked as one mesh file), its
    physical groups' elements and its nodes kept, numbered after the files before it, each group one
    discrete entity; a group name in two files is an error. None, or the error as one line."""
    gmsh = import_gmsh()
    parts, seen = [], {}
    for path in paths:
        error = _not_a_mesh_file(path) or _open_mesh_file(path)
        if error:
            return error
        model = gmsh.model
        tags, x, _ = model.mesh.getNodes()
        groups = []
        for dim, tag in model.getPhysicalGroups():
            name = model.getPhysicalName(dim, tag) or str(tag)
            if (dim, name) in seen:
                return (f"mesh files '{_file(seen[dim, name])}' and '{_file(path)}' both have a group named "
                        f"'{name}': name the groups of bodies meshed apart differently")
            seen[dim, name] = path
            blocks = [model.mesh.getElements(dim, entity) for entity in model.getEntitiesForPhysicalGroup(dim, tag)]
            groups.append((dim, name, [(t, n) for types, _, nodes in blocks for t, n in zip(types, nodes)]))
        parts.append((np.asarray(tags, dtype=np.int64), np.asarray(x), groups))
    gmsh.clear()
    gmsh.model.add("merged")
    node_offset, element_offset, entity, group_tag = 0, 0, 0, 0
    for tags, x, groups in parts:
        order = np.argsort(tags)
        nodes_placed = False
        for dim, name, blocks in sorted(groups, key=lambda g: -g[0]):  # cells first: they hold the nodes
            entity += 1
            gmsh.model.addDiscreteEntity(dim, entity)
            if not nodes_placed:
                gmsh.model.mesh.addNodes(dim, entity, list(tags[order] + node_offset), list(x.reshape(-1, 3)[order].ravel()))
                nodes_placed = True
            for element_type, nodes in blocks:
                nodes = np.asarray(nodes, dtype=np.int64) + node_offset
                count = len(nodes) // gmsh.model.mesh.getElementProperties(element_type)[3]
                gmsh.model.mesh.addElementsByType(entity, element_type,
                                                  list(range(element_offset + 1, element_offset + count + 1)), list(nodes))
                element_offset += count
            group_tag += 1
            gmsh.model.addPhysicalGroup(dim, [entity], group_tag)
            gmsh.model.setPhysicalName(dim, group_tag, name)
        node_offset += int(tags.max()) if len(tags) else 0
    return None


def _not_a_mesh_file(path):
    """Why gmsh would not read ``path`` as a mesh (one line naming it), or None (see :func:`from_gmsh`)."""
    name = f"mesh file '{_file(path)}'"
    if not str(path).lower().endswith(".msh"):
        return f"{name} is not a gmsh .msh file (its name does not end in .msh)"
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # (a FIFO: no wait for a writer)
    except FileNotFoundError:
        return f"{name} not found"
    except (OSError, ValueError) as err:  # permission, a name too long, a NUL in it, ...
        return f"cannot read {name}: {getattr(err, 'strerror', None) or err}"
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            return f"{name} is a directory, not a file"
        if not stat.S_ISREG(mode):
            return f"{name} is not a regular file"
        head = os.read(fd, len(MSH_SIGNATURE))
    except OSError as err:
        return f"cannot read {name}: {err.strerror or err}"
    finally:
        os.close(fd)
    if head != MSH_SIGNATURE:
        why = "it is empty" if not head else "it does not start with $MeshFormat"
        return f"{name} is not a gmsh .msh file ({why})"
    return None


def _open_mesh_file(path):
    """``gmsh.open`` of the checked file through a link in a new private folder (no ``.opt`` beside it);
    None, or gmsh's error as one line."""
    gmsh = import_gmsh()
    folder = tempfile.mkdtemp(prefix="nc_dolfinx_msh_")
    try:
        link = os.path.join(folder, os.path.basename(str(path)))
        try:
            os.symlink(os.path.abspath(path), link)
        except OSError:  # (a file system without symbolic links)
            shutil.copyfile(path, link)
        try:
            gmsh.open(link)
        except Exception as err:  # gmsh raises plain Exceptions for unreadable files
            text = str(err).replace(link, str(path))
            return f"cannot read mesh file '{_file(path)}': {brief_text(text, 300)}"
        return None
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def from_gmsh_model(comm, model=None, rank=0, build=None):
    """Domain of a gmsh model (default ``gmsh.model``) meshed in memory on ``rank`` by a user script.
    Only ``rank`` needs the model.

    ``build``: the one-rank work as a callable, ``build(gmsh)`` or ``build()``, which makes and meshes the
    model; it runs on ``rank`` only, between ``gmsh.initialize()`` and ``gmsh.finalize()`` (done here), and
    an exception it raises is an InputError on every rank together ("the gmsh model built on rank 0
    failed: ValueError: ..."), instead of a job whose other ranks wait for ``rank`` forever in the
    collective call it never reaches. Without ``build`` the caller builds the model and initialises and
    finalises gmsh (an exception before this call then stops one rank only: use ``build`` under MPI)."""
    gmsh = import_gmsh()
    if build is not None:
        return _built_model(comm, model, rank, build)
    model = gmsh.model if model is None else model
    where = None
    if comm.rank == rank:
        where = f"gmsh model '{model.getCurrent()}'" if model.getCurrent() else "gmsh model"
    return _to_domain(comm, model, rank, where)


def _built_model(comm, model, rank, build):
    """from_gmsh_model with ``build`` (see there)."""
    if not callable(build):
        raise TypeError(f"build must be a callable, build(gmsh) or build(), got {type(build).__name__}")
    if not 0 <= rank < comm.size:
        raise ValueError(f"rank {rank} is not a rank of the communicator (size {comm.size})")
    error = None
    if comm.rank == rank:
        with gmsh_session() as gmsh:
            try:
                build(gmsh) if _takes_an_argument(build) else build()
            except Exception as err:
                error = f"the gmsh model built on rank {rank} failed: {type(err).__name__}: {brief_text(err, 300)}"
            _raise_everywhere(comm, error, rank)
            return from_gmsh_model(comm, model, rank)
    _raise_everywhere(comm, error, rank)
    return from_gmsh_model(comm, model, rank)


def _takes_an_argument(function):
    """Whether ``function`` takes one positional argument (build(gmsh)) rather than none."""
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):  # (a builtin without a signature: called with gmsh)
        return True
    positional = [p for p in parameters if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return bool(positional) or any(p.kind == p.VAR_POSITIONAL for p in parameters)


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
    domain = from_dolfinx(msh, facet_tags, facet_names, cell_tags, cell_names)
    domain.cad = comm.bcast(_model_cad() if comm.rank == rank else None, root=rank)
    return domain


def _model_cad():
    """The current gmsh model's CAD as BREP (OpenCASCADE kernel), for refinement onto the true shape
    (:mod:`.cad`); None for a model without one (gmsh's built-in kernel writes no BREP)."""
    from .cad import Cad
    folder = tempfile.mkdtemp()
    try:
        path = os.path.join(folder, "model.brep")
        import_gmsh().write(path)
        with open(path, "rb") as file:
            data = file.read()
        return Cad(data, ".brep") if b"CASCADE" in data[:200] else None
    except Exception:  # no OpenCASCADE shapes: no CAD to keep
        return None
    finally:
        shutil.rmtree(folder, ignore_errors=True)


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
