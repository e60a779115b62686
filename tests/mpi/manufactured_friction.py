"""The manufactured frictional case (nc_dolfinx/cases/manufactured_friction.toml, or ...3d.toml with DIM = 3)
on any number of ranks: ``manufactured_friction.py DIM LEVELS [REFINE]`` prints (rank 0, JSON) the last
level's η, its parts, the H¹ error and the friction force. Shared by tests/test_friction_manufactured.py."""
import json
import sys

from mpi4py import MPI

import nc_dolfinx as nc

KEYS = ("dofs", "eta", "eta_1", "eta_2", "eta_3", "eta_4", "h1_error", "l2_error", "friction_force", "max_slip")


def run(dim, levels, refine="uniform"):
    case = "manufactured_friction" if dim == 2 else "manufactured_friction3d"
    cells = "[4,4]" if dim == 2 else "[3,3,3]"
    problem = nc.load_problem(case, [f"adapt.levels={levels}", f"adapt.refine=\"{refine}\"", f"mesh.cells={cells}"])
    result = nc.adapt(problem)
    return [{key: row[key] for key in KEYS} for row in result.history]


if __name__ == "__main__":
    rows = run(int(sys.argv[1]), int(sys.argv[2]), *(sys.argv[3:4]))
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(rows))
