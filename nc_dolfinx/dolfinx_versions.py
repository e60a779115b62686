"""Everything that differs between the DOLFINx versions nc_dolfinx supports, in one place.

Supported: the python3-dolfinx of Debian bookworm (0.5.2), trixie (0.9.0) and sid (0.11.0). Each function
below is named by what differs and hides one difference; the rest of the package calls them and never
tests a version. Where a newer DOLFINx does natively what 0.5.2 needed a workaround for, the newer path is
the native one and the workaround is marked "0.5.2 only": dropping 0.5.2 is deleting those branches.

The facts behind each branch (measured on the three versions) are in ``../shared/dolfinx-versions.md``.
"""
import ctypes
import math

import numpy as np
import ufl
from mpi4py import MPI

import dolfinx
import dolfinx.fem.petsc
from dolfinx import fem, geometry, mesh as dmesh

from .errors import UnsupportedDolfinx

SUPPORTED = ((0, 5), (0, 9), (0, 10), (0, 11))
SUPPORTED_TEXT = "0.5.2 (Debian bookworm), 0.9 (trixie) and 0.11 (sid)"


def _version(text):
    """(major, minor) of a version string such as '0.11.0.post0'."""
    parts = []
    for piece in text.split(".")[:2]:
        digits = "".join(c for c in piece if c.isdigit())
        parts.append(int(digits or 0))
    return tuple(parts)


VERSION = _version(dolfinx.__version__)
V05 = VERSION < (0, 6)        # Debian bookworm: 0.5.2 (Debian's patch of upstream PR 2500: msh._mesh)
NEW = VERSION >= (0, 9)       # 0.9 and later: the API of functionspace, basix.ufl, petsc_vec, ...
V011 = VERSION >= (0, 10)     # 0.10/0.11 and later: io.gmsh, identity partitioner in refine, ...


def check_version():
    """Raise :class:`UnsupportedDolfinx` (one line) for a DOLFINx outside the supported ones. 0.10 lies
    between two tested versions and takes 0.11's paths; a version newer than 0.11 is tried (a DOLFINx
    that fails there fails with DOLFINx's own error)."""
    if VERSION[:2] not in SUPPORTED and not VERSION > SUPPORTED[-1]:
        raise UnsupportedDolfinx(f"DOLFINx {dolfinx.__version__} is installed; nc_dolfinx runs on DOLFINx "
                                 f"{SUPPORTED_TEXT}")


check_version()  # before anything below touches an API that differs


def keep_quiet_about_unused_options():
    """PETSc 3.22 and 3.25 (0.9, 0.11) list every option nobody read when the process ends; the solver
    sets options of presets it may not use, and the command line checks the user's own options itself
    (:mod:`nc_dolfinx.solver.petsc_options`), so the list is noise. A user's own ``-options_left`` wins."""
    from petsc4py import PETSc
    if not PETSc.Options().hasName("options_left"):
        PETSc.Options().setValue("options_left", "no")


keep_quiet_about_unused_options()

if NEW:
    import basix.ufl


# --- meshes ------------------------------------------------------------------------------------

def create_rectangle(comm, corners, cells, diagonal):
    """A ghosted (shared-facet) triangle mesh of a rectangle; ``diagonal`` a ``DiagonalType`` name."""
    return dmesh.create_rectangle(comm, corners, cells, dmesh.CellType.triangle,
                                  ghost_mode=dmesh.GhostMode.shared_facet,
                                  diagonal=getattr(dmesh.DiagonalType, diagonal))


def create_box(comm, corners, cells):
    """A ghosted (shared-facet) tetrahedral mesh of a box."""
    return dmesh.create_box(comm, corners, cells, dmesh.CellType.tetrahedron,
                            ghost_mode=dmesh.GhostMode.shared_facet)


def with_equispaced_coordinates(msh):
    """0.5.2 only: the mesh with the coordinate element gmshio declares (equispaced P1). FFCx 0.5 gives
    that variant to the element while compiling and refined meshes inherit it, so without this the first
    refined level would compile its forms a second time. 0.9 does not recompile, 0.11 refuses the re-wrap."""
    if not V05:
        return msh
    element = ufl.VectorElement(ufl.FiniteElement("Lagrange", msh.topology.cell_type.name, 1,
                                                  variant="equispaced"))
    return dmesh.Mesh(msh._mesh, ufl.Mesh(element))


def coordinate_degree(msh):
    """Polynomial degree of the mesh's coordinate element."""
    element = msh.ufl_domain().ufl_coordinate_element()
    return element.degree() if V05 else element.embedded_superdegree


def entities_to_geometry(msh, dim, entities):
    """Geometry node indices (n, k) of local entities of dimension ``dim``."""
    entities = np.asarray(entities, dtype=np.int32)
    if len(entities) == 0:  # 0.9 divides by the number of entities (an integer division by zero: SIGFPE)
        return np.zeros((0, dim + 1), dtype=np.int32)  # linear simplices: dim + 1 nodes
    if V05:
        return dolfinx.cpp.mesh.entities_to_geometry(msh._mesh, dim, entities, False)
    return dmesh.entities_to_geometry(msh, dim, entities, False)


def diameters(msh, dim, entities):
    """Diameters (longest edge) of local mesh entities of dimension ``dim`` (DOLFINx's C++ ``h``)."""
    entities = np.asarray(entities, dtype=np.int32)
    return dolfinx.cpp.mesh.h(msh._mesh, dim, entities) if V05 else msh.h(dim, entities)


def exterior_facet_indices(msh):
    """Local indices of the exterior facets (facets with one cell)."""
    return dmesh.exterior_facet_indices(msh.topology)


def incident_edges(msh, cells):
    """Local edges of the given local cells."""
    topology = msh if V05 else msh.topology
    return dmesh.compute_incident_entities(topology, np.asarray(cells, dtype=np.int32), msh.topology.dim, 1)


def cell_dofs(dofmap):
    """A dofmap's cell → dofs table as a 2D array (n_cells, dofs per cell)."""
    if V05:
        return dofmap.list.array.reshape(-1, dofmap.dof_layout.num_dofs)
    return dofmap.list


def geometry_nodes(msh):
    """The geometry's cell → node table as a 2D array (n_cells, nodes per cell)."""
    if V05:
        dofmap = msh.geometry.dofmap
        return dofmap.array.reshape(dofmap.num_nodes, -1)
    return msh.geometry.dofmaps[0] if V011 else msh.geometry.dofmap  # (0.11: one per cell type)


def colliding_cells(msh, points):
    """For each point (n, 3), the local cells that contain it (an adjacency list)."""
    tdim = msh.topology.dim
    if V05:
        candidates = geometry.compute_collisions(geometry.BoundingBoxTree(msh, tdim), points)
    else:
        candidates = geometry.compute_collisions_points(geometry.bb_tree(msh, tdim), points)
    return geometry.compute_colliding_cells(msh, candidates, points)


def colliding_cell_pairs(msh_a, msh_b):
    """Pairs (n, 2) of a local cell of ``msh_a`` and one of ``msh_b`` whose bounding boxes overlap (a
    tree-against-tree search: ``compute_collisions`` of two ``BoundingBoxTree`` in 0.5.2,
    ``compute_collisions_trees`` of two ``bb_tree`` in 0.9 and later)."""
    dim_a, dim_b = msh_a.topology.dim, msh_b.topology.dim
    if V05:
        pairs = geometry.compute_collisions(geometry.BoundingBoxTree(msh_a, dim_a),
                                            geometry.BoundingBoxTree(msh_b, dim_b))
    else:
        pairs = geometry.compute_collisions_trees(geometry.bb_tree(msh_a, dim_a), geometry.bb_tree(msh_b, dim_b))
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def create_mesh_keeping_ranks(comm, cells, x, domain_like, destinations):
    """0.5.2 only (see :mod:`nc_dolfinx.mesh.refinement`): the mesh of these owned ``cells`` (global node
    numbers) and owned nodes ``x``, each cell sent to the ranks of its row of ``destinations`` (an
    adjacency list: its own rank first, then those that ghost it)."""
    def partitioner(comm_, nparts, tdim, cell_topology, ghost_mode):
        return destinations  # the i-th cell given to create_mesh is the owned cell i

    return dmesh.create_mesh(comm, cells, x, domain_like.ufl_domain(), dmesh.GhostMode.shared_facet,
                             partitioner)


_SIMPLEX = {2: "interval", 3: "triangle", 4: "tetrahedron"}  # vertices per cell -> cell name


def create_serial_mesh(comm, cells, x):
    """A mesh of P1 simplices from ``cells`` (n, vertices per cell; node numbers) and nodes ``x`` (m, gdim),
    all given on the calling process (meant for ``MPI.COMM_SELF``). The coordinate element and the order of
    ``create_mesh``'s parameters differ: 0.5.2 takes a ``ufl.Mesh`` of a ``ufl.VectorElement`` as
    ``create_mesh(comm, cells, x, domain)``; 0.9 a ``basix.ufl`` element as ``create_mesh(comm, cells, x,
    e)``; 0.11 swaps them, ``create_mesh(comm, cells, e, x)`` (keywords work in both)."""
    cells = np.asarray(cells, dtype=np.int64)
    x = np.ascontiguousarray(x, dtype=np.float64)
    cell, gdim = _SIMPLEX[cells.shape[1]], x.shape[1]
    if V05:
        element = ufl.VectorElement("Lagrange", ufl.Cell(cell, geometric_dimension=gdim), 1, dim=gdim)
        return dmesh.create_mesh(comm, cells, x, ufl.Mesh(element))
    element = basix.ufl.element("Lagrange", cell, 1, shape=(gdim,))
    return dmesh.create_mesh(comm, cells=cells, x=x, e=element)


# --- refinement --------------------------------------------------------------------------------

def refine_keeping_ranks(msh, edges=None, unique_ghosts=True):
    """Plaza refinement of ``edges`` (local indices; ``None``: every edge) whose children stay on their
    parent's rank, with a ghost layer of facet neighbours. Returns the child and its parent maps
    (:func:`_owned_parents`; ``None`` on 0.5.2).

    - 0.11: DOLFINx's default (its identity partitioner) does exactly this.
    - 0.9: ``partitioner=None`` keeps the children but builds no ghost cells, and the graph partitioner
      moves them; so a partitioner of our own keeps every cell on its rank and ghosts it on the ranks of
      its facet neighbours, from DOLFINx's dual graph of the child cells (what 0.11 does in C++).
    - 0.5.2 only: ``redistribute=False``, and no parent maps (its ``plaza_refine_data`` gives them for
      uniform refinement only; :mod:`nc_dolfinx.mesh.refinement` finds what they would give by position). Its partitioner sends a cell once per off-rank *neighbour*: a cell
      with two facet-neighbours on the same rank arrives there twice, and the facet between the duplicate
      ghosts and their neighbour then has three cells and drops out of interior-facet (``dS``) integrals
      (seen on 3 ranks: one interior edge missing from the jumps of η_2). When that happens (two ghost
      cells with the same vertices on some rank) the child is re-created with each ghost once
      (:func:`_rebuild_with_unique_ghosts`: about two thirds of a refinement, 0.17 s against 0.26 s in 3D
      at 9.2e4 dofs on 2 ranks, so only when needed). ``unique_ghosts=False`` skips it, for a child that
      is about to be re-created anyway (:func:`create_balanced_mesh`); :func:`with_unique_ghosts` does it
      later."""
    if V05:
        child = dmesh.refine(msh, edges, redistribute=False) if edges is not None else \
            dmesh.refine(msh, redistribute=False)
        return (with_unique_ghosts(child) if unique_ghosts else child), None
    option = dmesh.RefinementOption.parent_cell_and_facet
    if V011:
        child, parent_cell, parent_facet = dmesh.refine(msh, edges, option=option)
    else:
        child, parent_cell, parent_facet = dmesh.refine(msh, edges, partitioner=_keep_ranks_with_facet_ghosts,
                                                        option=option)
    return child, _owned_parents(child, parent_cell, parent_facet)


def _owned_parents(child, parent_cell, parent_facet):
    """0.9 and later: for each owned child cell its parent (a local cell of the parent mesh) and, for each
    of its local facets, the parent's local facet that contains it (-1: inside the parent), as arrays
    (n_owned,) and (n_owned, tdim + 1). DOLFINx lists both in the order the children were made, which
    ``create_mesh`` then reorders; ``original_cell_index`` gives each owned cell its place in that order
    (numbered on from this rank's first child: the children stay on the rank that made them)."""
    tdim = child.topology.dim
    n_owned = child.topology.index_map(tdim).size_local
    first = child.comm.exscan(len(parent_cell)) or 0
    made = np.asarray(child.topology.original_cell_index[:n_owned], dtype=np.int64) - first
    if len(made) and (made.min() < 0 or made.max() >= len(parent_cell)):
        raise RuntimeError("internal error: a refined cell left the rank of its parent")
    return (np.asarray(parent_cell)[made],
            np.asarray(parent_facet, dtype=np.int32).reshape(-1, tdim + 1)[made])


def with_unique_ghosts(msh):
    """0.5.2 only: ``msh``, or the same mesh re-created with each ghost cell once if refinement doubled some
    (:func:`refine_keeping_ranks`); other versions never double them."""
    if V05 and msh.comm.size > 1 and _has_duplicate_ghosts(msh):
        return _rebuild_with_unique_ghosts(msh)
    return msh


def create_balanced_mesh(comm, cells, x, like):
    """A mesh of ``cells`` (owned by this rank: global node numbers, one row per cell) and of this rank's
    block ``x`` of the nodes (numbered by rank, in rank order), partitioned anew by DOLFINx's graph
    partitioner (ParMETIS, SCOTCH or KaHIP, whichever DOLFINx was built with) and ghosted by shared facets;
    ``like``: a mesh of the same cell and coordinate element. 0.5.2's ``create_mesh`` does exactly this by
    default; 0.9 and 0.11 build no ghosts unless given the partitioner (0.11's also takes the number of
    cells a facet may have); keywords serve both of their argument orders."""
    cells = np.asarray(cells, dtype=np.int64)
    x = np.ascontiguousarray(x, dtype=np.float64)
    if V05:
        return dmesh.create_mesh(comm, cells, x, like.ufl_domain())
    mode = (dmesh.GhostMode.shared_facet, 2) if V011 else (dmesh.GhostMode.shared_facet,)
    return dmesh.create_mesh(comm, cells=cells, x=x, e=like.ufl_domain(),
                             partitioner=dmesh.create_cell_partitioner(*mode))


def _has_duplicate_ghosts(msh):
    """0.5.2 only: whether some rank holds a cell twice: two ghost cells with the same vertices (the partitioner sends a
    cell to its own rank once, so an owned cell is never doubled). Read from the cell–vertex connectivity,
    without the facets (which on a mesh about to be rebuilt would be built twice)."""
    tdim = msh.topology.dim
    cells = msh.topology.index_map(tdim)
    ghosts = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)[cells.size_local:]
    doubled = len(np.unique(np.sort(ghosts, axis=1), axis=0)) < len(ghosts)
    return msh.comm.allreduce(bool(doubled), MPI.LOR)


def _rebuild_with_unique_ghosts(msh):
    """0.5.2 only: the same distributed mesh (owned cells stay on their rank), with a duplicate-free ghost
    layer: each owned cell goes to its own rank, then once to every rank that held it as a ghost (the ranks
    owning a facet-neighbour, which is what the doubled ghost layer got right)."""
    node_map = msh.geometry.index_map()
    n_cells = msh.topology.index_map(msh.topology.dim).size_local
    nodes = geometry_nodes(msh)[:n_cells]
    cells = node_map.local_to_global(nodes.ravel()).reshape(nodes.shape)
    x = msh.geometry.x[:node_map.size_local, :msh.geometry.dim]
    return create_mesh_keeping_ranks(msh.comm, cells, x, msh, cell_destinations(msh))


def _keep_ranks_with_facet_ghosts(comm, nparts, cell_types, cells):
    """0.9: a cell partitioner that keeps each cell on this rank and ghosts it on every other rank
    holding one of its facet neighbours (``cells``: one array of global vertex numbers per cell type)."""
    n_cells = len(cells[0]) // dolfinx.cpp.mesh.cell_num_vertices(cell_types[0])
    graph = dolfinx.cpp.mesh.build_dual_graph(comm, cell_types, cells)
    first = comm.exscan(n_cells) or 0
    starts = np.array(comm.allgather(first), dtype=np.int64)
    neighbours = np.asarray(graph.array, dtype=np.int64)
    cell_of = np.repeat(np.arange(n_cells), np.diff(graph.offsets))
    rank_of = np.searchsorted(starts, neighbours, side="right") - 1
    off_rank = rank_of != comm.rank
    key = np.unique(cell_of[off_rank] * comm.size + rank_of[off_rank])
    return _destinations(comm.rank, n_cells, key // comm.size, key % comm.size)


def _destinations(rank, n_cells, ghost_cell, ghost_rank):
    """Adjacency list: each cell to ``rank``, then to the ranks (sorted by cell) that ghost it."""
    offsets = np.zeros(n_cells + 1, dtype=np.int32)
    offsets[1:] = np.cumsum(1 + np.bincount(ghost_cell, minlength=n_cells))
    array = np.full(offsets[-1], rank, dtype=np.int32)
    first_of_cell = np.searchsorted(ghost_cell, ghost_cell)
    array[offsets[ghost_cell] + 1 + np.arange(len(ghost_cell)) - first_of_cell] = ghost_rank
    return dolfinx.cpp.graph.AdjacencyList_int32(array, offsets)


def cell_destinations(msh):
    """0.5.2 only: for each owned cell this rank, then every other rank that holds it as a ghost, each
    once (an adjacency list, as a DOLFINx cell partitioner returns it)."""
    comm = msh.comm
    cell_map = msh.topology.index_map(msh.topology.dim)
    first = cell_map.local_range[0]
    ghosts, owners = cell_map.ghosts, cell_map.owners
    received = comm.alltoall([ghosts[owners == r] for r in range(comm.size)])  # my cells others ghost
    key = np.unique(np.concatenate([(np.asarray(g, dtype=np.int64) - first) * comm.size + r
                                    for r, g in enumerate(received)]))
    return _destinations(comm.rank, cell_map.size_local, key // comm.size, key % comm.size)


# --- function spaces ---------------------------------------------------------------------------

def p1_space(msh, shape=()):
    """Continuous P1 Lagrange space: scalar, or of the given value ``shape`` (e.g. ``(gdim,)``)."""
    if NEW:
        return fem.functionspace(msh, ("Lagrange", 1, shape))
    if shape == ():
        return fem.FunctionSpace(msh, ("CG", 1))
    return fem.VectorFunctionSpace(msh, ("CG", 1), dim=shape[0])


def dg0_space(msh, shape=()):
    """DOLFINx's own DG0 space: scalar, or of the given value ``shape`` (e.g. ``(3, 3)``)."""
    if NEW:
        return fem.functionspace(msh, ("DG", 0, shape))
    if shape == ():
        return fem.FunctionSpace(msh, ("DG", 0))
    return fem.TensorFunctionSpace(msh, ("DG", 0), shape=shape)


def interpolation_points(space):
    """The reference points at which ``space`` interpolates (a method in 0.5.2 and 0.9, a property later)."""
    points = space.element.interpolation_points
    return points() if callable(points) else points


def cell_space_from_dofmap(msh, dim, layout_dofmap):
    """The DG0 space of ``dim`` components on ``msh`` with the given (identity) dofmap; see
    :func:`nc_dolfinx.mesh.domain.cell_space`. Element construction differs in each version."""
    cell = msh.topology.cell_type
    if V05:
        element, cpp_element = _compiled_dg0_element(msh, dim)
        return fem.FunctionSpace(msh, element, dolfinx.cpp.fem.FunctionSpace(msh._mesh, cpp_element,
                                                                             layout_dofmap))
    shape = (dim,) if dim > 1 else ()
    element = basix.ufl.element("DG", cell.name, 0, shape=shape)
    if V011:
        cpp_element = fem.finiteelement(cell, element, np.float64)._cpp_object
        cpp_space = dolfinx.cpp.fem.FunctionSpace_float64(msh._cpp_object, cpp_element, layout_dofmap)
    else:
        cpp_element = fem.function._create_dolfinx_element(msh.comm, cell, element, np.float64)
        cpp_space = dolfinx.cpp.fem.FunctionSpace_float64(msh._cpp_object, cpp_element, layout_dofmap,
                                                          element.reference_value_shape)
    return fem.FunctionSpace(msh, element, cpp_space)


_COMPILED_DG0 = {}  # 0.5.2: (cell, dim) -> (UFL element, compiled element), kept for meshes on one process


def _compiled_dg0_element(msh, dim):
    """0.5.2 only: the UFL and the compiled DG0 element of ``dim`` components (scalar for 1).

    The JIT cache's lookup costs 1-2 ms (a listing of its directory), a few per estimate; on one process
    the elements are kept. On several the lookup is collective (rank 0 first, then an allreduce), and a
    rank that skipped it would leave the others waiting, so it is done every time."""
    key = (msh.topology.cell_type.name, dim)
    if msh.comm.size == 1 and key in _COMPILED_DG0:
        return _COMPILED_DG0[key]
    element = ufl.FiniteElement("DG", msh.ufl_cell(), 0)
    if dim > 1:
        element = ufl.VectorElement(element, dim=dim)
    (ufcx_element, _), module, _ = dolfinx.jit.ffcx_jit(msh.comm, element)
    result = element, dolfinx.cpp.fem.FiniteElement(module.ffi.cast("uintptr_t",
                                                                    module.ffi.addressof(ufcx_element)))
    if msh.comm.size == 1:
        _COMPILED_DG0[key] = result
    return result


def dof_layout_dg0(tdim, dim):
    """The element dof layout DOLFINx gives a DG0 element of ``dim`` components: one dof on the cell;
    blocked, one sub-layout per component (the same constructor in every supported version)."""
    on_cell = [[[] for _ in range(math.comb(tdim + 1, d + 1))] for d in range(tdim)] + [[[0]]]
    components = [dolfinx.cpp.fem.ElementDofLayout(1, on_cell, on_cell, [i], []) for i in range(dim)]
    return dolfinx.cpp.fem.ElementDofLayout(dim, on_cell, on_cell, [], components if dim > 1 else [])


# --- vectors -----------------------------------------------------------------------------------

SCATTER_ADD = (dolfinx.la.ScatterMode if V05 else dolfinx.la.InsertMode).add


def petsc_vec(function):
    """The PETSc vector (ghosted) that shares a Function's values."""
    return function.vector if V05 else function.x.petsc_vec


def create_petsc_vector(form):
    """A ghosted PETSc vector for assembling the linear ``form`` (a compiled ``fem.Form``)."""
    if V011:
        return dolfinx.fem.petsc.create_vector(form.function_spaces[0])
    return dolfinx.fem.petsc.create_vector(form)


def solve_raising_callback_errors(snes, x):
    """``snes.solve(None, x)``, raising a Python exception that one of our SNES callbacks raised as itself,
    with ``x`` writable again.

    petsc4py 3.18 (0.5.2's) re-raises it; 3.22 and 3.25 (0.9, 0.11) raise a ``PETSc.Error`` whose
    ``__cause__`` it is. PETSc 3.22 and 3.25 also lock ``x`` for reading around a callback (e.g. in
    ``SNESComputeJacobian``) and, when the callback fails, return before unlocking it: the next solve from
    ``x`` then failed in the line search's ``VecCopy`` ("locked for read-only access")."""
    from petsc4py import PETSc
    try:
        snes.solve(None, x)
    except BaseException as err:
        _release_read_locks(x)
        cause = err.__cause__ if isinstance(err, PETSc.Error) else None
        if isinstance(cause, BaseException) and not isinstance(cause, PETSc.Error):
            raise cause from None
        raise


def _release_read_locks(vec):
    """Pop the read locks an aborted PETSc call left on ``vec`` (``VecLockGet``/``VecLockReadPop`` through
    ctypes: petsc4py wraps neither)."""
    try:
        lib = libpetsc()
    except OSError:
        return  # (then the next solve from vec reports PETSc's own error)
    if not hasattr(lib, "VecLockGet"):
        return  # PETSc 3.18 (0.5.2's) exports no VecLockGet, and leaves no lock behind
    state = ctypes.c_int64(0) if _petsc_int_bytes() == 8 else ctypes.c_int32(0)
    handle = ctypes.c_void_p(vec.handle)
    for _ in range(64):  # (a bound, not a count: one lock per aborted call level)
        if lib.VecLockGet(handle, ctypes.byref(state)) != 0 or state.value <= 0:
            return
        lib.VecLockReadPop(handle)


def libpetsc():
    """The ``libpetsc`` that petsc4py has loaded (found in the process's memory map, so that a real or
    complex build, whichever petsc4py uses, answers), for the calls petsc4py does not wrap."""
    with open("/proc/self/maps") as fh:
        paths = {line.split()[-1] for line in fh if "/libpetsc" in line and ".so" in line}
    if len(paths) != 1:
        raise OSError(f"cannot tell which libpetsc petsc4py uses (found {sorted(paths)})")
    return ctypes.CDLL(paths.pop())


def _petsc_int_bytes():
    """Bytes of PETSc's integer type (4 in Debian's builds)."""
    from petsc4py import PETSc
    return np.dtype(PETSc.IntType).itemsize


def petsc_error_message(err):
    """PETSc's own message of a ``PETSc.Error`` (e.g. "Unable to find requested KSP type bogus"). petsc4py
    3.18, 3.22 and 3.25 alike put PETSc's traceback into ``str(err)``, "error code 86" and then one line
    per call level, "[rank] ..."; the last line is the message of the call that failed."""
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    text = lines[-1] if lines else ""
    if text.startswith("[") and "]" in text:
        text = text[text.index("]") + 1:].strip()
    return text or f"PETSc error code {getattr(err, 'ierr', '?')}"


def hypre_types():
    """The values of ``-pc_hypre_type`` that PETSc's hypre interface accepts: PETSc 3.22 and 3.25 (0.9,
    0.11) added hypre's ILU to those of 3.18 (0.5.2's), as their error messages list them."""
    types = ("boomeramg", "ams", "ads", "euclid", "pilut", "parasails")
    return types if V05 else types + ("ilu",)


def line_search_types():
    """The names of SNES line searches, for messages: petsc4py 3.25 (0.11's) lists them
    (``PETSc.SNESLineSearch.Type``; PETSc 3.25 also still takes l2, the old name of secant); 3.18 and 3.22
    have no such list, and PETSc 3.18 and 3.22 register these."""
    from petsc4py import PETSc
    if hasattr(PETSc, "SNESLineSearch"):
        listed = PETSc.SNESLineSearch.Type
        return sorted({v for k, v in vars(listed).items() if not k.startswith("_") and isinstance(v, str)} | {"l2"})
    return sorted(("basic", "bt", "cp", "l2", "ncglinear", "nleqerr", "none", "shell"))


def entities_built(msh, dim):
    """Whether the mesh entities of dimension ``dim`` have been computed (0.5.2's ``index_map`` returns
    None for them, 0.9 and later raise)."""
    try:
        return msh.topology.index_map(dim) is not None
    except RuntimeError:
        return False


def solve_linear_problem(a, L, bcs, petsc_options):
    """The solution (a Function) of the linear variational problem a(u, v) = L(v) with Dirichlet ``bcs``,
    by DOLFINx's ``LinearProblem`` (0.11 requires an options prefix of its own)."""
    if V011:
        problem = dolfinx.fem.petsc.LinearProblem(a, L, bcs=bcs, petsc_options=petsc_options,
                                                  petsc_options_prefix="nc_linear_problem_")
    else:
        problem = dolfinx.fem.petsc.LinearProblem(a, L, bcs=bcs, petsc_options=petsc_options)
    return problem.solve()


def set_dirichlet_rows(vector, bcs, scale):
    """The entries of ``vector`` that ``bcs`` hold set to ``scale`` times the conditions' values (scale 0:
    zero; the keyword is ``scale`` in 0.5.2, ``alpha`` later: passed by position)."""
    dolfinx.fem.petsc.set_bc(vector, bcs, None, scale)


def lift(vector, bilinear_form, bcs):
    """vector −= A g on the free rows, A the compiled ``bilinear_form`` and g the values of ``bcs`` (the
    lifting of non-zero Dirichlet values; ghosts not yet added to their owners)."""
    dolfinx.fem.petsc.apply_lifting(vector, [bilinear_form], [bcs])


# --- forms and the JIT -------------------------------------------------------------------------

FORM_COMPILER = {"scalar_type": "double" if V05 else np.float64}  # what fem.form passes to FFCx by default


def geometric_dimension(domain):
    """A UFL domain's geometric dimension (a method until UFL 2024, a property since)."""
    gdim = domain.geometric_dimension
    return gdim() if callable(gdim) else gdim


def compile_form(form, options):
    """``fem.form(form)`` with form compiler ``options``."""
    if V05:
        return fem.form(form, form_compiler_params=options)
    return fem.form(form, form_compiler_options=options)


def interior_facet_integrals(comm, form, options):
    """The compiled (ufcx) interior-facet integrals of a UFL ``form``, as the JIT cache holds them for
    :func:`compile_form` with the same ``options`` (their flags can be changed before DOLFINx reads them)."""
    if V05:
        ufcx_form = dolfinx.jit.ffcx_jit(comm, form, form_compiler_params=options)[0]
        kind = int(dolfinx.cpp.fem.IntegralType.interior_facet)
        return [ufcx_form.integrals(kind)[i] for i in range(ufcx_form.num_integrals(kind))]
    ufcx_form = dolfinx.jit.ffcx_jit(comm, form, form_compiler_options=options)[0]
    kind = fem.IntegralType.interior_facet.value
    offsets = ufcx_form.form_integral_offsets
    return [ufcx_form.form_integrals[i] for i in range(offsets[kind], offsets[kind + 1])]


def newton_problem(F, u, bcs):
    """The nonlinear problem (residual ``F`` in ``u``, Dirichlet ``bcs``) that ``dolfinx.nls.petsc.NewtonSolver``
    solves: ``fem.petsc.NonlinearProblem`` in 0.5.2 and 0.9; 0.10 gave that name to a SNES-based class and
    renamed the NewtonSolver's one ``NewtonSolverNonlinearProblem`` (deprecated, as NewtonSolver is)."""
    if V011:
        return dolfinx.fem.petsc.NewtonSolverNonlinearProblem(F, u, bcs=bcs)
    return dolfinx.fem.petsc.NonlinearProblem(F, u, bcs=bcs)


UFL_ERRORS = (ufl.UFLException,) if hasattr(ufl, "UFLException") else ()  # 0.5.2's UFL only


# --- gmsh --------------------------------------------------------------------------------------

def model_to_mesh(model, comm, rank, gdim):
    """(mesh, cell tags, facet tags) of a gmsh model held on ``rank``, ghosted by shared facets (0.9 and
    later build no ghosts unless told; 0.11 moved the module to ``dolfinx.io.gmsh`` and returns a tuple
    of six)."""
    if V05:
        from dolfinx.io import gmshio
        return gmshio.model_to_mesh(model, comm, rank, gdim=gdim)
    if V011:
        from dolfinx.io import gmsh as gmshio
        partitioner = dmesh.create_cell_partitioner(dmesh.GhostMode.shared_facet, 2)
        data = gmshio.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)
        return data.mesh, data.cell_tags, data.facet_tags
    from dolfinx.io import gmshio
    partitioner = dmesh.create_cell_partitioner(dmesh.GhostMode.shared_facet)
    return gmshio.model_to_mesh(model, comm, rank, gdim=gdim, partitioner=partitioner)


__all__ = []  # internal: no public API here
