"""Refine a two-region gmsh mesh adaptively three times; print measures per level as JSON (rank 0).

Usage: refine_check.py MESH.msh
"""
import json
import sys

import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh

from nc_dolfinx import meshes, refinement

comm = MPI.COMM_WORLD
domain = meshes.from_gmsh(comm, sys.argv[1])


def integrate(expr):
    return comm.allreduce(fem.assemble_scalar(fem.form(expr)), MPI.SUM)


def measures(domain):
    msh = domain.mesh
    ds = ufl.Measure("ds", domain=msh, subdomain_data=domain.facet_tags)
    one = fem.Constant(msh, 1.0)
    out = {f"group:{name}": integrate(one * ds(i)) for name, i in domain.facet_groups.items()}
    out["untagged"] = integrate(one * ds(meshes.UNTAGGED))
    for name, i in domain.cell_groups.items():
        out[f"region:{name}"] = integrate(ufl.conditional(ufl.eq(domain.region, i), 1.0, 0.0) * ufl.dx)
    out["interior_edges"] = integrate(one * ufl.dS(domain=msh))
    # every tagged facet lies on a level-0 segment of its own group
    a, b, ids = domain.segments
    tags = domain.facet_tags
    mids = dmesh.compute_midpoints(msh, 1, tags.indices)[:, :2]
    wrong = 0
    for group in np.unique(tags.values):
        sel = tags.values == group
        found = meshes.match_segments(mids[sel], (a[ids == group], b[ids == group], ids[ids == group]), 1e-10)
        wrong += int(np.count_nonzero(found != group)) if group != meshes.UNTAGGED else 0
    out["facets_off_their_group"] = comm.allreduce(wrong, MPI.SUM)
    out["cells"] = msh.topology.index_map(2).size_global
    return out


def transfer_error(parent, child):
    """Transfer of a P1 field that is linear in x is exact at every child vertex; also returns how many
    child vertices had to be located by point search (none: all match a parent vertex or edge midpoint)."""
    Vp = fem.VectorFunctionSpace(parent.mesh, ("CG", 1))
    Vc = fem.VectorFunctionSpace(child.mesh, ("CG", 1))
    linear = lambda x: np.stack([1 + 2 * x[0] - x[1], 3 * x[1] + 0.5 * x[0]])  # noqa: E731
    up = fem.Function(Vp)
    up.interpolate(linear)
    located = []
    search = refinement.evaluate
    refinement.evaluate = lambda f, points: located.append(len(points)) or search(f, points)
    try:
        uc = refinement.transfer(up, Vc)
    finally:
        refinement.evaluate = search
    exact = fem.Function(Vc)
    exact.interpolate(linear)
    error = comm.allreduce(float(np.max(np.abs(uc.x.array - exact.x.array), initial=0.0)), MPI.MAX)
    return error, comm.allreduce(sum(located), MPI.SUM)


levels = [measures(domain)]
for step in range(3):
    n = domain.mesh.topology.index_map(2).size_local
    mid = dmesh.compute_midpoints(domain.mesh, 2, np.arange(n, dtype=np.int32))
    # mark the cells near the point where the two regions and the bottom meet, and near a far corner
    near = (np.hypot(mid[:, 0] - 1.0, mid[:, 1]) < 0.5 / (step + 1)) | (np.hypot(mid[:, 0] - 2, mid[:, 1] - 1) < 0.3)
    child = refinement.refine(domain, np.flatnonzero(near).astype(np.int32))
    error, located = transfer_error(domain, child)
    levels.append(measures(child) | {"transfer_error": error, "transfer_located_points": located})
    domain = child
if comm.rank == 0:
    print(json.dumps(levels))
