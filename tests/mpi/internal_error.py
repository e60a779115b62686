"""Run the command line with a fault injected on one rank after level 1 (tests/test_cli.py).

    mpirun -n 2 python3 tests/mpi/internal_error.py RANK [command-line arguments]
"""
import sys

from mpi4py import MPI

from nc_dolfinx.cli import command_line as cli
from nc_dolfinx.cli.run import CaseRun

FAULTY_RANK = int(sys.argv[1])
original = CaseRun.on_level


def on_level(self, level):
    original(self, level)
    if level.number == 1 and MPI.COMM_WORLD.rank == FAULTY_RANK:
        raise RuntimeError("injected fault")


CaseRun.on_level = on_level
sys.exit(cli.main(sys.argv[2:]))
