"""Indicators of every owned cell of a small 3D box problem with a prescribed P1 displacement, gathered on
rank 0 and printed as one line ``RESULT {json}`` (tests/test_estimator_3d.py compares 1, 2, 3 ranks).

The box has a symmetry plane (x = 0), Dirichlet (top), two Neumann groups with non-polynomial tractions,
contact faces on which u_hn − g_0 changes sign, m_n = 1.5 and c_n(x). Also reported: how many layers the
faces with varying traction take (``facet_layers``: a cell at the edge x = 1, y = 0 has two)."""
import json

import numpy as np
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh
import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.estimator.indicators import varying_traction_groups
from nc_dolfinx.estimator.geometry import facet_layers

PROBLEM = {
    "mesh": {"box": [[0, 0, 0], [1, 1, 0.5]], "cells": [4, 4, 2], "symmetry": ["left"], "dirichlet": ["top"],
             "neumann": ["right", "front", "back"], "contact": ["bottom"]},
    "material": {"E": 2.0, "nu": 0.3},
    "loads": {"f": ["sin(y)", "x*z", "-1 + cos(x)"],
              "g": {"right": ["0.1*y", "z", "exp(-x*y)"], "front": ["x", "0.2", "y*z"]}},
    "contact": {"c_n": "10*(1 + x*y)", "m_n": 1.5, "gap": "0.005 + 0.01*x"},
}


def displacement(x):
    return np.stack([0.01 * x[0] * x[1], 0.02 * x[1] * x[2] - 0.01 * x[0],
                     -0.02 * np.sin(6 * x[0] + 4 * x[1] - 3) - 0.005 + 0.03 * x[2] * x[0]])


comm = MPI.COMM_WORLD
problem = nc.Problem.from_dict(PROBLEM, "parallel box")
domain = nc.build_domain(problem, comm)
fields = nc.bind(problem, domain)
u = fem.Function(versions.p1_space(domain.mesh, (3,)))
u.interpolate(displacement)
est = nc.estimate(u, fields)

msh = domain.mesh
n = msh.topology.index_map(3).size_local
# kinked contact faces (owned): u_hn − g_0 = −u_z − g_0 on z = 0 takes both signs at the face's vertices
tags = domain.facet_tags
contact = tags.indices[np.isin(tags.values, fields.ids["contact"])]
contact = contact[contact < msh.topology.index_map(2).size_local]
nodes = versions.entities_to_geometry(msh, 2, contact)
X = msh.geometry.x[nodes.ravel()]
phi = (-displacement(X.T)[2] - (0.005 + 0.01 * X[:, 0])).reshape(-1, 3)
kinked = comm.allreduce(int(np.count_nonzero((phi.max(axis=1) > 0) & (phi.min(axis=1) < 0))), MPI.SUM)
layers = len(facet_layers(domain, varying_traction_groups(fields)))
mid = dmesh.compute_midpoints(msh, 3, np.arange(n, dtype=np.int32))
names = ["eta", "eta_1", "eta_2", "eta_3", "eta_4", "zeta"]
rows = np.column_stack([mid] + [est.fields[k].x.array[:n] for k in names]).tolist()
rows = comm.gather(rows, root=0)
cells = msh.topology.index_map(3).size_global
if comm.rank == 0:
    print("RESULT " + json.dumps({"rows": sum(rows, []), "totals": est.totals, "cells": cells,
                                  "kinked_faces": kinked, "neumann_layers": layers}))
