"""Unsupported meshes raise the same InputError on every rank (none is left waiting): print it per rank.

A hexahedral gmsh model meshed on rank 0 only (from_gmsh_model), then a hexahedral DOLFINx box
(from_dolfinx). Rank 0 prints, as JSON, the list of the two messages of each rank.
"""
import json

import gmsh
import numpy as np
from mpi4py import MPI

from dolfinx import mesh as dmesh

from nc_dolfinx.mesh import gmsh_io, tagged
from nc_dolfinx.errors import InputError

comm = MPI.COMM_WORLD

gmsh.initialize()
gmsh.option.setNumber("General.Terminal", 0)
if comm.rank == 0:
    volume = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(3, [volume])
    gmsh.model.mesh.setTransfiniteAutomatic()
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.model.mesh.generate(3)
messages = []
try:
    gmsh_io.from_gmsh_model(comm)
    messages.append("no error")
except InputError as err:
    messages.append(str(err))
gmsh.finalize()

msh = dmesh.create_box(comm, [[0, 0, 0], [1, 1, 1]], [2, 2, 2], dmesh.CellType.hexahedron)
empty = np.zeros(0, dtype=np.int32)
try:
    tagged.from_dolfinx(msh, dmesh.meshtags(msh, 2, empty, empty))
    messages.append("no error")
except InputError as err:
    messages.append(str(err))
everyone = comm.gather(messages, root=0)
if comm.rank == 0:
    print(json.dumps(everyone))
