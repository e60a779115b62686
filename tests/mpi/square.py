"""The solver family's square (benchmarks/family.py): unit square, E = 1, ν = 0.3, clamped top, f = (0, −0.5),
contact at the bottom; shared by tests/test_solver.py and the MPI scripts beside this file."""
import nc_dolfinx as nc


def square_problem(c_n, m_n, cells=24, gap=0.0, preset=None):
    """The square as an :class:`nc.Problem` with c_n, m_n, the gap and, if given, the solver preset."""
    data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [cells, cells], "dirichlet": ["top"],
                     "neumann": ["left", "right"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "-0.5"]},
            "contact": {"c_n": c_n, "m_n": m_n, "gap": gap}}
    if preset is not None:
        data["solver"] = {"preset": preset}
    return nc.Problem.from_dict(data, "square")
