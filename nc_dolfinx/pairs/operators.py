"""Sparse operators from the displacement's dofs to values at a pair's points, as PETSc MPIAIJ matrices.

A row of such an operator reads, at one point of one face, a component of Σ_i c_i R u(x_i) over the
vertices x_i of the facets involved (the point's own facet or vertex, and the facet of the other face that
holds its projection Π x): the gap operator B of :mod:`.coupling` (R = ν_Aᵀ, c = λ and −λ'), the
tangential operator T and the vertex normal operator of :mod:`.friction` (R = I − N Nᵀ and Nᵀ). Rows: this
rank's points; columns: the dofs wherever they are owned (nothing of global size on one rank).
"""
import numpy as np
from petsc4py import PETSc


def point_operator(space, rows, blocks):
    """The matrix with ``r`` rows per point (``rows``: (n, r, gdim), the matrix R of each point) and, for
    each (dofs (n, k) global dof blocks, coefficients (n, k)) of ``blocks``, the entries c R at the k
    blocks' components: (R Σ_i c_i u(x_i))_a in row r·point + a."""
    n, r, gdim = rows.shape
    bs = space.dofmap.index_map_bs
    columns, values = [], []
    for dofs, coefficients in blocks:
        k = dofs.shape[1]
        values.append(coefficients[:, None, :, None] * rows[:, :, None, :])                        # (n, r, k, gdim)
        columns.append(np.broadcast_to((dofs[:, None, :, None] * bs + np.arange(gdim)), (n, r, k, gdim)))
    width = sum(v.shape[2] for v in values) * gdim
    columns = np.concatenate(columns, axis=2).reshape(n * r, width) if n else np.zeros((0, width), dtype=np.int64)
    data = np.concatenate(values, axis=2).reshape(n * r, width) if n else np.zeros((0, width))
    order = np.argsort(columns, axis=1, kind="stable")
    columns = np.take_along_axis(columns, order, axis=1)
    data = np.take_along_axis(data, order, axis=1)
    indptr = np.arange(0, (n * r + 1) * width, width, dtype=PETSc.IntType)
    index_map = space.dofmap.index_map
    matrix = PETSc.Mat().createAIJ(((n * r, PETSc.DECIDE), (index_map.size_local * bs, index_map.size_global * bs)),
                                   csr=(indptr, columns.ravel().astype(PETSc.IntType), data.ravel()),
                                   comm=space.mesh.comm)
    matrix.assemble()
    return matrix


def block_diagonal(comm, blocks):
    """The matrix of n blocks (``blocks``: (n, r, c), this rank's) on its diagonal: block i in rows r·i … and
    columns c·i … of this rank's part, so that it multiplies an operator of c rows per point (with the
    same points on the same ranks) from the left."""
    n, r, c = blocks.shape
    first = comm.exscan(n * c) or 0  # (the global index of this rank's first column: None on rank 0)
    columns = first + np.broadcast_to(np.arange(n)[:, None, None] * c + np.arange(c)[None, None, :], (n, r, c))
    indptr = np.arange(0, (n * r + 1) * c, c, dtype=PETSc.IntType)
    matrix = PETSc.Mat().createAIJ(((n * r, PETSc.DECIDE), (n * c, PETSc.DECIDE)),
                                   csr=(indptr, columns.reshape(-1).astype(PETSc.IntType),
                                        np.ascontiguousarray(blocks).reshape(-1)), comm=comm)
    matrix.assemble()
    return matrix
