"""A user's script that builds its gmsh model on rank 0 through nc.from_gmsh_model(build=...)
(tests/test_meshes.py).

    mpirun -n 2 python3 tests/mpi/gmsh_build.py fail|ok|ok_without_argument

``fail``: the build raises on rank 0 only; every rank must end with the same InputError (rank 0 prints
every rank's, exit status 1), none waiting for rank 0. ``ok``, ``ok_without_argument``: rank 0 prints
the number of cells.
"""
import sys

from mpi4py import MPI

import nc_dolfinx as nc

comm = MPI.COMM_WORLD
mode = sys.argv[1]


def square(gmsh):
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("square")
    surface = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [surface])
    gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
    if mode == "fail":
        raise ValueError("no such geometry")
    gmsh.model.mesh.generate(2)


def square_without_argument():
    import gmsh
    square(gmsh)


try:
    domain = nc.from_gmsh_model(comm, build=square_without_argument if mode == "ok_without_argument" else square)
except nc.InputError as err:
    everyone = comm.gather(f"rank {comm.rank}: InputError: {err}")  # (mpirun ends the job at the first exit 1)
    if comm.rank == 0:
        print("\n".join(everyone), flush=True)
    sys.exit(1)
if comm.rank == 0:
    print(f"cells: {domain.num_cells()}", flush=True)
