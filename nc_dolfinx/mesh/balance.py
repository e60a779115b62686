"""Rebalancing: a refined mesh partitioned anew, so that every rank owns about as many cells, with what
lives on its cells and nodes moved along exactly.

Refinement keeps each child cell on its parent's rank (:mod:`.refinement`), so the ranks that hold the
contact zone receive most of the new cells: on ``hertz3d`` on 2 ranks one rank owned 87 % of the cells
after four levels. When the busiest rank owns more than ``IMBALANCE_LIMIT`` times the mean,
:func:`rebalance` re-creates the child from its own cells and nodes with DOLFINx's graph partitioner
(:func:`~nc_dolfinx.dolfinx_versions.create_balanced_mesh`). The new mesh is the same global mesh; DOLFINx
tells, for each of its cells and nodes, the number we gave it (``original_cell_index``,
``input_global_indices``), and a :class:`Move` uses these to fetch cell values (the regions) and node
values (the displacement, computed exactly on the old partition) from their old owners: values are copied,
never interpolated.

Memory and traffic per rank are of the order of the rank's own cells and nodes: every exchange is an
all-to-all of the entries one rank sends to or asks of the others, plus one number per rank (the offsets of
the old numbering).
"""
import numpy as np
from mpi4py import MPI

from .. import dolfinx_versions as versions

IMBALANCE_LIMIT = 1.05  # rebalance when the busiest rank owns more cells than this times the mean
# (DOLFINx's graph partitioners give 1.00–1.03: a child within 1.05 is left where refinement put it)


def imbalance(msh):
    """The busiest rank's owned cells over the mean (1 on one rank), the same on every rank."""
    owned = msh.topology.index_map(msh.topology.dim).size_local
    total = msh.comm.allreduce(owned, MPI.SUM)
    return msh.comm.allreduce(owned, MPI.MAX) * msh.comm.size / max(total, 1)


def rebalance(msh):
    """``msh`` partitioned anew by DOLFINx's graph partitioner, ghosted by shared facets, and the
    :class:`Move` that carries cell and node values from ``msh`` to it. Collective."""
    comm, tdim = msh.comm, msh.topology.dim
    node_map = msh.geometry.index_map()
    n_cells = msh.topology.index_map(tdim).size_local
    nodes = versions.geometry_nodes(msh)[:n_cells]
    cells = node_map.local_to_global(nodes.ravel()).reshape(nodes.shape)
    x = msh.geometry.x[:node_map.size_local, :msh.geometry.dim]
    balanced = versions.create_balanced_mesh(comm, cells, x, msh)
    touched = np.unique(nodes)  # the nodes of the owned cells: where the old partition computes values
    n_balanced = balanced.topology.index_map(tdim).size_local
    anchors = np.empty((len(msh.geometry.x), 3))
    anchors[nodes] = msh.geometry.x[nodes].mean(axis=1)[:, None, :]  # a cell of each node: its midpoint
    move = Move(_offsets(comm, node_map.size_local), _offsets(comm, n_cells),
                np.array(balanced.geometry.input_global_indices, dtype=np.int64),
                np.array(balanced.topology.original_cell_index, dtype=np.int64)[:n_balanced],
                msh.geometry.x[touched].copy(), np.array(node_map.local_to_global(touched), dtype=np.int64),
                anchors[touched])
    return balanced, move


class Move:
    """Where each owned cell and each local node of a rebalanced mesh came from, and how to fetch values.

    ``node_offsets``/``cell_offsets``: the old numbering of nodes and cells by rank (rank r owned the
    numbers ``offsets[r]`` to ``offsets[r + 1] - 1``); ``node_origins``: the old number of every local node
    of the new mesh; ``cell_origins``: that of every owned cell; ``points``: the coordinates of the nodes of
    the old owned cells of this rank, ``point_numbers`` their old numbers, ``anchors`` the midpoint of an old
    owned cell holding each (which parent cell a point belongs to where two bodies touch). The methods take the new mesh's
    communicator: a Move keeps none, since DOLFINx 0.5's ``mesh.comm`` is valid only while its mesh lives
    (the old mesh's is gone once :func:`rebalance` returns)."""

    def __init__(self, node_offsets, cell_offsets, node_origins, cell_origins, points, point_numbers, anchors):
        self.node_offsets, self.cell_offsets = node_offsets, cell_offsets
        self.node_origins, self.cell_origins = node_origins, cell_origins
        self.points, self.point_numbers = points, point_numbers
        self.anchors = anchors  # for each point, the midpoint of an old owned cell that holds it

    def cell_values(self, comm, values):
        """Values of the old owned cells (n_old_owned, ...) → those of the new owned cells."""
        return _fetch(comm, self.cell_offsets, self.cell_origins, np.asarray(values))

    def node_values(self, comm, values):
        """Values at ``points`` (the nodes of the old owned cells, (n_points, ...)) → at every local node of
        the new mesh. Each old owner first collects the values of its nodes (any rank that computed one has
        the same value: it is a node of a cell that rank owned), then answers the ranks that hold them now."""
        owned = self.node_offsets[comm.rank + 1] - self.node_offsets[comm.rank]
        table = _deliver(comm, self.node_offsets, self.point_numbers, np.asarray(values), owned)
        return _fetch(comm, self.node_offsets, self.node_origins, table)


def _offsets(comm, owned):
    """[0, n_0, n_0 + n_1, …, Σ n]: where each rank's block of a numbering by rank starts (p + 1 numbers)."""
    return np.concatenate([[0], np.cumsum(comm.allgather(int(owned)))]).astype(np.int64)


def _by_owner(comm, offsets, numbers):
    """The order that groups ``numbers`` by the rank owning them, and the group sizes."""
    owner = np.searchsorted(offsets, numbers, side="right") - 1
    order = np.argsort(owner, kind="stable")
    return order, np.cumsum(np.bincount(owner, minlength=comm.size))[:-1]


def _deliver(comm, offsets, numbers, values, owned):
    """This rank's block (``owned`` rows) of a numbering by rank, from the values that ranks hold for
    ``numbers`` (each owned number reaches its owner from at least one rank)."""
    order, splits = _by_owner(comm, offsets, numbers)
    received = comm.alltoall(list(zip(np.split(numbers[order], splits), np.split(values[order], splits))))
    table = np.zeros((owned,) + values.shape[1:], dtype=values.dtype)
    for got_numbers, got_values in received:
        table[got_numbers - offsets[comm.rank]] = got_values
    return table


def _fetch(comm, offsets, numbers, table):
    """``table`` is this rank's block of a numbering by rank: the rows of ``numbers``, wherever they live
    (a request to each owner and its answer)."""
    order, splits = _by_owner(comm, offsets, numbers)
    requests = comm.alltoall(np.split(numbers[order], splits))
    answers = comm.alltoall([table[wanted - offsets[comm.rank]] for wanted in requests])
    result = np.empty((len(numbers),) + table.shape[1:], dtype=table.dtype)
    result[order] = np.concatenate(answers) if answers else result[:0]
    return result
