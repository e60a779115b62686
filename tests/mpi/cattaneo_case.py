"""Run the built-in case ``cattaneo`` (Cattaneo–Mindlin partial slip) on any number of ranks and print
(rank 0, JSON, last line) the numbers tests/test_cattaneo.py compares: P, Q, a, c and Hertz's a."""
import json
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "verification"))
from cattaneo import case_problem, measure  # noqa: E402

if __name__ == "__main__":
    result = measure(case_problem())
    result.pop("profile")
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(result))
