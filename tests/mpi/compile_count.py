"""Count FFCx compilations over a parameter sweep through the public API (run with an empty cache).

Prints one JSON line (rank 0): the compilations of the first adaptive run and of each later run with
new values of c_n, m_n, E, ν, the gap, the loads and a [parameters] entry.
"""
import json
import time

import ffcx.codegeneration.jit as ffcx_jit
from mpi4py import MPI

import nc_dolfinx as nc

compiled = [0]
original = ffcx_jit._compile_objects


def counting(*args, **kwargs):
    compiled[0] += 1
    return original(*args, **kwargs)


ffcx_jit._compile_objects = counting

base = nc.load_problem("block", ["mesh.cells=[8,4]", "parameters.p=20", 'loads.g={top = ["0", "-p*x"]}',
                                 'contact.gap="0.0005*(2 - x)"'])
settings = nc.AdaptSettings(refine="adaptive", levels=2)
sweep = [{}, {"contact.c_n": "1234*(1 + x)"}, {"contact.c_n": "1235*(1 + x)"}, {"contact.m_n": 2},
         {"contact.m_n": 3}, {"material.E": 2000.0, "material.nu": 0.25}, {"contact.gap": "0.001*(2 - x)"},
         {"contact.gap": "0.002*(2 - x)"}, {"loads.f": ["1", "-20"]}, {"parameters.p": 25}]
rows = []
for change in sweep:
    before, start = compiled[0], time.perf_counter()
    nc.adapt(base.replace(change), settings)
    rows.append({"change": change, "compiled": compiled[0] - before, "seconds": time.perf_counter() - start})
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps(rows))
