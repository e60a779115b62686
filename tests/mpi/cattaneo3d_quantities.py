"""The cattaneo3d case's numbers at the end of its load path, on any number of ranks: prints (rank 0) one
JSON line with P, Q, the contact, stick and slip areas and c/a (verification/cattaneo3d.py's measures)."""
import json
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "verification"))
from cattaneo3d import run  # noqa: E402

if __name__ == "__main__":
    rows, _, _ = run(sys.argv[1:])
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(rows[-1]))
