"""Self-sizing increments (``increments = "auto"``) and the secant predictor on a frictional load path, on any
number of ranks: a layer (1 x 1/2, 8 x 4 cells, E = 1) on a foundation with Coulomb friction
(c_n = 10, μ = 0.3), its top moved by a prescribed displacement: pressed by w in 2 increments, sheared by d
and sheared back, each shear step sizing its own increments with a small Newton target (so that it cuts).
Prints (rank 0, JSON) per row: load_time, increment_cuts, cut_reason, Newton steps and the global quantities
(elastic energy, contact and friction forces, largest slip), which do not depend on the partition."""
import json
import sys

from mpi4py import MPI

import nc_dolfinx as nc

LAYER = {"parameters": {"w": 0.0, "d": 0.0},
         "mesh": {"rectangle": [[0.0, 0.0], [1.0, 0.5]], "cells": [8, 4], "dirichlet": ["top"],
                  "neumann": ["left", "right"], "contact": ["bottom"]},
         "material": {"E": 1.0, "nu": 0.3},
         "loads": {"u_D": {"top": ["d", "-w"]}},
         "contact": {"c_n": 10.0, "m_n": 1, "friction": 0.3},
         "steps": [{"set": {"w": 0.02}, "increments": 2}, {"set": {"d": 0.03}, "increments": "auto"},
                   {"set": {"d": -0.01}, "increments": "auto"}],
         "solver": {"increment_newton_target": 4}}
QUANTITIES = ("elastic_energy", "contact_force", "friction_force", "max_slip")


def layer(**solver):
    """The layer's problem, with [solver] values changed (``predictor``, ``increment_newton_target``, ...)."""
    data = json.loads(json.dumps(LAYER))
    data["solver"].update(solver)
    return nc.Problem.from_dict(data, "layer")


def rows_of(result):
    return [{key: row.get(key) for key in ("load_time", "increment_cuts", "cut_reason", "newton_iterations",
                                           "step", "increment", *QUANTITIES)} for row in result.history]


if __name__ == "__main__":
    solver = json.loads(sys.argv[1]) if len(sys.argv) > 1 else {}
    result = nc.adapt(layer(**solver), nc.AdaptSettings(refine="none"), comm=MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        print(json.dumps(rows_of(result), default=list))
