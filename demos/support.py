"""Plumbing shared by the demos, not part of nc_dolfinx: run options, printing and checking on rank 0,
and drawing a DG0 field of a 2D mesh with matplotlib from every rank's cells.

Each demo imports it from its own directory (``python3 demos/demo_X.py``, ``python3 -m mpi4py
demos/demo_X.py`` and a notebook opened in ``demos/`` all find it).
"""
import os
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
from mpi4py import MPI

from nc_dolfinx import dolfinx_versions as versions

comm = MPI.COMM_WORLD

# Two warnings of the stack, not of the demos, would stop a demo under `python3 -W error`: FFCx 0.5 leaves
# a file open when it compiles a new form, and pyparsing, seeing -W, switches on self-checks of grammars
# that matplotlib's mathtext grammar (tick labels such as 10⁻²) trips.
warnings.filterwarnings("ignore", message=r"unclosed file .*libffcx_", category=ResourceWarning)
warnings.filterwarnings("ignore", message=r"warn_\w+: |Forward defined here", category=UserWarning)

SMALL = "--small" in sys.argv or os.environ.get("NC_DEMO_SMALL") == "1"
"""The small size (CI): ``--small`` on the command line or ``NC_DEMO_SMALL=1``."""


def output_directory():
    """Where a demo writes its files: ``--out DIR``, else ``$NC_DEMO_OUT``, else a new temporary
    directory (the same on every rank). Created if needed."""
    given = sys.argv[sys.argv.index("--out") + 1] if "--out" in sys.argv else os.environ.get("NC_DEMO_OUT")
    path = Path(given or comm.bcast(tempfile.mkdtemp(prefix="nc_demo_") if comm.rank == 0 else None))
    if comm.rank == 0:
        path.mkdir(parents=True, exist_ok=True)
    return path


def say(text):
    """Print on rank 0 only."""
    if comm.rank == 0:
        print(text, flush=True)


def check(condition, text):
    """Stop the demo if a property it computed does not hold; say ``checked: TEXT`` if it does.

    The demos compute every checked number from global (all-rank) values, so all ranks agree."""
    if not condition:
        raise AssertionError(text)
    say(f"checked: {text}")


def gather_cells(field):
    """(vertices (n, 3, 2), values (n,)) of a DG0 field on a triangle mesh: every rank's owned cells, on
    rank 0 (None elsewhere). A DG0 field has one dof per cell."""
    msh = field.function_space.mesh
    n_owned = msh.topology.index_map(2).size_local
    nodes = versions.geometry_nodes(msh)[:n_owned]
    values = field.x.array[versions.cell_dofs(field.function_space.dofmap)[:n_owned, 0]]
    parts = msh.comm.gather((msh.geometry.x[nodes][:, :, :2], values), root=0)
    if parts is None:
        return None, None
    return np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts])


def draw_cells(ax, field, title, **tripcolor_options):
    """Colour the cells of a 2D mesh by a DG0 field with matplotlib's ``tripcolor`` on rank 0 (call it on
    every rank: the cells are gathered). Returns the artist (None on the other ranks)."""
    vertices, values = gather_cells(field)
    if comm.rank != 0:
        return None
    triangles = np.arange(3 * len(values)).reshape(-1, 3)
    artist = ax.tripcolor(vertices[:, :, 0].ravel(), vertices[:, :, 1].ravel(), triangles, facecolors=values,
                          **tripcolor_options)
    ax.set_title(title)
    ax.set_aspect("equal")
    return artist
