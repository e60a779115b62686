"""The bodies of a mesh: its connected parts, found in parallel without anything of global size on one rank.

Each rank labels the connected parts of its own cells (owned and ghost: scipy's connected components on the
cell–vertex graph); a part that crosses a partition boundary has a label on each rank, and the labels met at
a shared vertex are joined (union–find over the pairs, which are few: one per pair of labels that touch, not
one per vertex). A body's number follows the lowest coordinate of its vertices (x, then y, then z), so it does
not depend on the partition; its name is that of the cell group that covers it, if exactly one does.
"""
import numpy as np
from mpi4py import MPI
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from dolfinx import fem

from .. import dolfinx_versions as versions


def body_of_vertices(msh):
    """The body (0, 1, …) of every local vertex (owned and ghost), and the number of bodies."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0)
    n_cells = msh.topology.index_map(tdim).size_local + msh.topology.index_map(tdim).num_ghosts
    vmap = msh.topology.index_map(0)
    n_vertices = vmap.size_local + vmap.num_ghosts
    cells = c2v.array.reshape(n_cells, -1) if n_cells else np.zeros((0, tdim + 1), dtype=np.int32)
    rows = np.repeat(np.arange(n_cells), cells.shape[1]) + n_vertices  # cells after the vertices
    graph = coo_matrix((np.ones(rows.size), (rows, cells.ravel())), shape=(n_vertices + n_cells,) * 2)
    _, local = connected_components(graph, directed=False)
    local = local[:n_vertices]
    _, local = np.unique(local, return_inverse=True)  # (vertices in no cell cannot occur on a mesh)
    count = int(local.max()) + 1 if n_vertices else 0
    offset = msh.comm.exscan(count) or 0
    label = (local + offset).astype(np.int64)
    roots = _joined(msh, vmap, label, offset + count)
    body = roots[label]
    return _numbered_by_position(msh, vmap, body)


def _joined(msh, vmap, label, total_hint):
    """Union–find over the labels that meet at shared vertices: the owner's label against each ghost's."""
    scalar = fem.Function(versions.p1_space(msh))
    at_vertex = _vertex_to_dof(msh, scalar.function_space)
    scalar.x.array[at_vertex] = label.astype(float)
    scalar.x.scatter_forward()  # each ghost vertex now holds its owner's label
    ghosts = np.arange(vmap.size_local, vmap.size_local + vmap.num_ghosts)
    owner_label = scalar.x.array[at_vertex[ghosts]].astype(np.int64)
    links = np.unique(np.stack([label[ghosts], owner_label], axis=1), axis=0) if len(ghosts) else \
        np.zeros((0, 2), dtype=np.int64)
    links = np.concatenate(msh.comm.allgather(links))
    total = msh.comm.allreduce(total_hint, op=MPI.MAX)
    parent = np.arange(total)

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for a, b in links:
        ra, rb = find(a), find(b)
        if ra != rb:
            parent[max(ra, rb)] = min(ra, rb)
    return np.array([find(i) for i in range(total)], dtype=np.int64)


def _numbered_by_position(msh, vmap, body):
    """Bodies renumbered 0, 1, … by their lowest vertex (lexicographic in x, y, z): partition independent."""
    x = msh.geometry.x
    owned = np.arange(vmap.size_local)
    owned_x = x[_vertex_nodes(msh)[owned]]
    roots = np.unique(np.concatenate(msh.comm.allgather(np.unique(body))))
    lowest = []
    for root in roots:
        mine = owned_x[body[owned] == root]
        lowest.append(tuple(mine[np.lexsort(mine.T[::-1])][0]) if len(mine) else (np.inf,) * 3)
    lowest = np.array([min(keys) for keys in zip(*msh.comm.allgather(lowest))])
    order = np.lexsort(lowest.T[::-1])
    number = np.empty(len(roots), dtype=np.int64)
    number[order] = np.arange(len(roots))
    return number[np.searchsorted(roots, body)], len(roots)


def _vertex_nodes(msh):
    """The geometry node of each local vertex (P1 meshes: one node per vertex)."""
    tdim = msh.topology.dim
    c2v = msh.topology.connectivity(tdim, 0)
    cells = versions.geometry_nodes(msh)
    n = len(cells)
    nodes = np.empty(msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts, dtype=np.int64)
    nodes[c2v.array[:n * cells.shape[1]].reshape(n, -1).ravel()] = cells.ravel()
    return nodes


def _vertex_to_dof(msh, space):
    """The P1 dof of each local vertex."""
    from ..mesh.domain import dof_of_node
    return dof_of_node(space)[_vertex_nodes(msh)]


def body_of_cells(msh, body_of_vertex):
    """The body of every local cell (owned and ghost)."""
    tdim = msh.topology.dim
    c2v = msh.topology.connectivity(tdim, 0)
    first = c2v.array[c2v.offsets[:-1]]
    return body_of_vertex[first]


def body_names(domain, body_of_cell, count):
    """A name per body: the cell group covering all of it (and nothing else), else "body k" (1-based)."""
    n_owned = domain.mesh.topology.index_map(domain.tdim).size_local
    region = np.rint(domain.region.x.array[:n_owned]).astype(np.int64)
    names = []
    for k in range(count):
        mine = set(np.unique(region[body_of_cell[:n_owned] == k]).tolist())
        others = set(np.unique(region[body_of_cell[:n_owned] != k]).tolist())
        mine = set().union(*domain.comm.allgather(mine))
        others = set().union(*domain.comm.allgather(others))
        groups = [name for name, i in domain.cell_groups.items() if i in mine]
        if len(mine) == 1 and len(groups) == 1 and not (mine & others):
            names.append(groups[0])
        else:
            names.append(f"body {k + 1}")
    return names
