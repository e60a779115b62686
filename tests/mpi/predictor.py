"""The tangent predictor on the frictional layer of tests/mpi/load_increments.py (pressed in 2, sheared in 4 and
back in 4 fixed increments), on any number of ranks: the path solved with ``solver.predictor`` = none and
tangent, in one process (the secant one: tests/test_load_increments.py). Prints (rank 0, JSON) per
predictor: the Newton steps of the path, the increments the tangent prediction was kept on, and the largest differences to the run without a predictor over every state
(the quantities, relative to their largest size along the path) and of the final displacement (relative)."""
import json

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc
import load_increments

QUANTITIES = ("elastic_energy", "contact_force", "friction_force", "max_slip")


def fixed_layer(predictor):
    data = json.loads(json.dumps(load_increments.LAYER))
    for step in data["steps"][1:]:
        step["increments"] = 4
    data["solver"]["predictor"] = predictor
    return nc.Problem.from_dict(data, "layer-fixed")


def run(predictor):
    kept = []
    result = nc.adapt(fixed_layer(predictor), nc.AdaptSettings(refine="none"), comm=MPI.COMM_WORLD,
                      on_level=lambda level: kept.append(level.solution.stats.predictor == "tangent"))
    return result, kept


if __name__ == "__main__":
    comm = MPI.COMM_WORLD
    runs = {name: run(name) for name in ("none", "tangent")}
    reference, _ = runs["none"]
    u_ref = reference.final.u.x.array
    size = comm.allreduce(float(np.max(np.abs(u_ref))), op=MPI.MAX)
    out = {}
    for name, (result, kept) in runs.items():
        states = 0.0
        for key in QUANTITIES:
            scale = max(np.max(np.abs(np.atleast_1d(r[key]))) for r in reference.history)
            for r, o in zip(result.history, reference.history):
                states = max(states, float(np.max(np.abs(np.subtract(r[key], o[key])))) / scale)
        u = comm.allreduce(float(np.max(np.abs(result.final.u.x.array - u_ref))), op=MPI.MAX) / size
        out[name] = {"newton": sum(r["newton_iterations"] for r in result.history), "predicted": sum(kept),
                     "rows": len(result.history), "states": states, "u": u,
                     "max_slip": max(r["max_slip"] for r in result.history)}
    if comm.rank == 0:
        print(json.dumps(out))
