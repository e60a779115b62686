"""Print (rank 0) a fingerprint of how a 4x4x4 box is partitioned: the sorted owned-cell midpoints of each
rank, hashed, in rank order."""
import hashlib

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc  # noqa: F401  (sets up SCOTCH before the first partition)
from dolfinx import mesh as dmesh

comm = MPI.COMM_WORLD
msh = dmesh.create_box(comm, [[0, 0, 0], [1, 1, 1]], [4, 4, 4], dmesh.CellType.tetrahedron)
owned = np.arange(msh.topology.index_map(3).size_local, dtype=np.int32)
midpoints = np.sort(dmesh.compute_midpoints(msh, 3, owned).round(8).view("f8,f8,f8"), axis=0)
prints = comm.gather(hashlib.md5(midpoints.tobytes()).hexdigest(), root=0)
if comm.rank == 0:
    print(" ".join(prints))
