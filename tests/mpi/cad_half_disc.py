"""A half-disc built through gmsh's API (OpenCASCADE) on rank 0 and refined adaptively with the shape from its
CAD alone (tests/test_cad.py): no [mesh.shapes] in the problem.

    mpirun -n N python3 tests/mpi/cad_half_disc.py LEVELS

Prints, on rank 0, one JSON line: the largest | |x − c| − R | over the vertices of the arc's groups, and the
history rows (the same on every rank count to round-off)."""
import json
import sys

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions

H = 0.1


def half_disc(gmsh):
    """R = 1, centre (0, 1), y <= 1; the arc split into 'free' (|x| > 1/2) and 'contact', the top 'top'."""
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add("half_disc")
    occ = gmsh.model.occ
    centre, left, right, bottom = (occ.addPoint(*p, 0) for p in ((0, 1), (-1, 1), (1, 1), (0, 0)))
    y = 1 - np.sqrt(0.75)
    a, b = occ.addPoint(-0.5, y, 0), occ.addPoint(0.5, y, 0)
    arcs = [occ.addCircleArc(p, centre, q) for p, q in ((left, a), (a, bottom), (bottom, b), (b, right))]
    top = occ.addLine(right, left)
    occ.addPlaneSurface([occ.addCurveLoop([*arcs, top])])
    occ.synchronize()
    gmsh.model.addPhysicalGroup(2, [1], 1)
    for tag, name, curves in ((1, "top", [top]), (2, "free", [arcs[0], arcs[3]]), (3, "contact", arcs[1:3])):
        gmsh.model.setPhysicalName(1, gmsh.model.addPhysicalGroup(1, curves, tag), name)
    gmsh.option.setNumber("Mesh.MeshSizeMax", H)
    gmsh.option.setNumber("Mesh.MeshSizeMin", H)
    gmsh.model.mesh.generate(2)


problem = nc.Problem.from_dict({
    "parameters": {"E": 1e3},
    "mesh": {"dirichlet": ["top"], "neumann": ["free"], "contact": ["contact"]},
    "material": {"E": "E", "nu": 0.45}, "loads": {"u_D": ["0", "-0.009773"]},
    "contact": {"c_n": "1e3*E", "m_n": 1, "gap": "y"},
    "adapt": {"refine": "adaptive", "levels": int(sys.argv[1])}})
result = nc.adapt(problem, domain=nc.from_gmsh_model(MPI.COMM_WORLD, build=half_disc))
domain = result.final.solution.domain
tags = domain.facet_tags
arc = tags.indices[np.isin(tags.values, [domain.facet_groups["free"], domain.facet_groups["contact"]])]
x = domain.mesh.geometry.x[np.unique(versions.entities_to_geometry(domain.mesh, 1, arc))]
off = float(np.abs(np.linalg.norm(x[:, :2] - [0, 1], axis=1) - 1).max()) if len(x) else 0.0
off = MPI.COMM_WORLD.allreduce(off, MPI.MAX)
keys = ("dofs", "eta", "eta_geometry", "geometry_sag", "max_contact_pressure", "contact_resultant")
rows = [{k: row[k] for k in keys} for row in result.history]
if MPI.COMM_WORLD.rank == 0:
    print(json.dumps({"off_circle": off, "rows": rows, "curved": sorted(domain.shapes.given)}))
