"""Refine meshes adaptively three times; print measures per level as JSON (rank 0), {mesh: [level, ...]}.

Usage: refine_check.py MESH [MESH ...], each MESH one of
  gmsh=PATH  a .msh file read with gmsh_io.from_gmsh
  gmsh3d     [0,2]x[0,1]x[0,1] split at x = 1 into volumes 'soft'/'hard', surface groups left (x = 0),
             bottom (z = 0, both halves), top (z = 1), the rest untagged; built in memory on rank 0 by the
             gmsh API and read with gmsh_io.from_gmsh_model
  box        builtin.box on [0,2]x[0,1]x[0,1]
  dolfinx    tagged.from_dolfinx on a dolfinx box [0,2]x[0,1]x[0,1]: facets x = 0 tag 1 'left', z = 0 tag 5
             (unnamed), a named tag 9 on no facet; cells x < 1 tag 3 'soft', the rest untagged
All domains lie in [0,2]x[0,1](x[0,1]); cells are marked near (1, 0, 0) and near (2, 1, 1).
"""
import json
import sys

import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem, mesh as dmesh

from nc_dolfinx.mesh import builtin, domain as mesh_domain, gmsh_io, tagged
from nc_dolfinx.mesh import refinement
from nc_dolfinx import dolfinx_versions as versions

from boundary_oracle import gather_boundary

comm = MPI.COMM_WORLD


def gmsh3d():
    import gmsh
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    if comm.rank == 0:
        occ, model = gmsh.model.occ, gmsh.model
        occ.fragment([(3, occ.addBox(0, 0, 0, 1, 1, 1))], [(3, occ.addBox(1, 0, 0, 1, 1, 1))])
        occ.synchronize()
        centre = {(dim, tag): occ.getCenterOfMass(dim, tag) for dim, tag in model.getEntities()}
        surfaces = {"left": lambda c: abs(c[0]) < 1e-9, "bottom": lambda c: abs(c[2]) < 1e-9,
                    "top": lambda c: abs(c[2] - 1) < 1e-9}
        for dim, groups in ((2, surfaces), (3, {"soft": lambda c: c[0] < 1, "hard": lambda c: c[0] > 1})):
            for name, inside in groups.items():
                tags = [tag for d, tag in model.getEntities(dim) if inside(centre[(d, tag)])]
                model.setPhysicalName(dim, model.addPhysicalGroup(dim, tags), name)
        for option in ("Mesh.MeshSizeMin", "Mesh.MeshSizeMax"):
            gmsh.option.setNumber(option, 0.5)
        model.mesh.generate(3)
        # DOLFINx 0.5's Plaza breaks a tie between the longest edges of a face by (partition-dependent)
        # global vertex numbers. Moving the nodes a little (each coordinate that puts a node on one of the
        # planes x = 0, 1, 2, y = 0, 1, z = 0, 1 stays) leaves no ties: the same refinement on any number of
        # ranks.
        nodes, x, _ = model.mesh.getNodes()
        x = x.reshape(-1, 3)
        on_plane = np.isclose(x[..., None], [0, 1, 2]).any(axis=-1)
        x = np.where(on_plane, x, x + np.random.default_rng(0).uniform(-0.02, 0.02, x.shape))
        for node, xyz in zip(nodes, x):
            model.mesh.setNode(node, xyz, [])
    try:
        return gmsh_io.from_gmsh_model(comm)
    finally:
        gmsh.finalize()


def user_box():
    msh = dmesh.create_box(comm, [[0, 0, 0], [2, 1, 1]], [4, 2, 2])
    tdim = msh.topology.dim
    left = dmesh.locate_entities_boundary(msh, tdim - 1, lambda x: np.isclose(x[0], 0))
    bottom = dmesh.locate_entities_boundary(msh, tdim - 1, lambda x: np.isclose(x[2], 0))
    facets, order = np.unique(np.concatenate([left, bottom]), return_index=True)
    values = np.concatenate([np.full(len(left), 1), np.full(len(bottom), 5)])[order]
    soft = dmesh.locate_entities(msh, tdim, lambda x: x[0] < 1 + 1e-12)
    return tagged.from_dolfinx(msh, dmesh.meshtags(msh, tdim - 1, facets, values.astype(np.int32)),
                               {1: "left", 9: "nowhere"},
                               dmesh.meshtags(msh, tdim, soft, np.full(len(soft), 3, dtype=np.int32)), {3: "soft"})


def integrate(expr):
    return comm.allreduce(fem.assemble_scalar(fem.form(expr)), MPI.SUM)


def facets_off_their_group(domain, boundary):
    """Tagged facets whose centroid is not in a level-0 boundary simplex (``boundary``) of their group, and
    untagged facets whose centroid is in a tagged one."""
    msh, tags = domain.mesh, domain.facet_tags
    vertices, ids = boundary
    centroids = dmesh.compute_midpoints(msh, msh.topology.dim - 1, tags.indices)[:, :msh.geometry.dim]
    wrong = 0
    for group in np.unique(tags.values):
        sel = tags.values == group
        if group == mesh_domain.UNTAGGED:
            found = mesh_domain.match_simplices(centroids[sel], (vertices[ids != group], ids[ids != group]), 1e-10)
        else:
            found = mesh_domain.match_simplices(centroids[sel], (vertices[ids == group], ids[ids == group]), 1e-10)
        wrong += int(np.count_nonzero(found != group))
    return comm.allreduce(wrong, MPI.SUM)


def measures(domain, boundary):
    msh = domain.mesh
    ds = ufl.Measure("ds", domain=msh, subdomain_data=domain.facet_tags)
    one = fem.Constant(msh, 1.0)
    out = {f"group:{name}": integrate(one * ds(i)) for name, i in domain.facet_groups.items()}
    out["untagged"] = integrate(one * ds(mesh_domain.UNTAGGED))
    for name, i in domain.cell_groups.items():
        out[f"region:{name}"] = integrate(ufl.conditional(ufl.eq(domain.region, i), 1.0, 0.0) * ufl.dx)
    out["interior_facets"] = integrate(one * ufl.dS(domain=msh))
    out["facets_off_their_group"] = facets_off_their_group(domain, boundary)
    out["cells"] = domain.num_cells()
    return out


def transfer_error(parent, child):
    """Transfer of P1 fields linear in x (a vector of gdim and one of gdim + 1 components) is exact at
    every child vertex; also returns how many child vertices had to be located by point search (none:
    all match a parent vertex or edge midpoint)."""
    gdim = parent.mesh.geometry.dim
    errors, located = [], []
    search = refinement.evaluate
    refinement.evaluate = lambda f, points: located.append(len(points)) or search(f, points)
    try:
        for bs in (gdim, gdim + 1):
            coefficients = np.arange(1.0, 1 + bs * (gdim + 1)).reshape(bs, gdim + 1) % 5 - 2
            linear = lambda x: coefficients[:, :1] + coefficients[:, 1:] @ x[:gdim]  # noqa: E731
            Vp, Vc = (versions.p1_space(d.mesh, (bs,)) for d in (parent, child))
            up, exact = fem.Function(Vp), fem.Function(Vc)
            up.interpolate(linear)
            exact.interpolate(linear)
            errors.append(float(np.max(np.abs(refinement.transfer(up, Vc).x.array - exact.x.array), initial=0)))
    finally:
        refinement.evaluate = search
    return comm.allreduce(max(errors), MPI.MAX), comm.allreduce(sum(located), MPI.SUM)


def refine_three_times(domain):
    level0 = gather_boundary(domain.mesh, domain.facet_tags)  # the groups' facets, as simplices
    levels = [measures(domain, level0)]
    gdim = domain.mesh.geometry.dim
    a, b = np.array([1.0, 0, 0])[:gdim], np.array([2.0, 1, 1])[:gdim]
    for step in range(3):
        n = domain.mesh.topology.index_map(domain.mesh.topology.dim).size_local
        mid = dmesh.compute_midpoints(domain.mesh, domain.mesh.topology.dim, np.arange(n, dtype=np.int32))
        near = (np.linalg.norm(mid[:, :gdim] - a, axis=1) < 0.5 / (step + 1)) | \
            (np.linalg.norm(mid[:, :gdim] - b, axis=1) < 0.3)
        child = refinement.refine(domain, np.flatnonzero(near).astype(np.int32))
        error, located = transfer_error(domain, child)
        levels.append(measures(child, level0) | {"transfer_error": error, "transfer_located_points": located})
        domain = child
    return levels


def domain_of(spec):
    kind, _, path = spec.partition("=")
    if kind == "gmsh":
        return gmsh_io.from_gmsh(comm, path)
    if kind == "box":
        return builtin.box(comm, [[0, 0, 0], [2, 1, 1]], [4, 2, 2])
    return {"gmsh3d": gmsh3d, "dolfinx": user_box}[kind]()


result = {spec.partition("=")[0]: refine_three_times(domain_of(spec)) for spec in sys.argv[1:]}
if comm.rank == 0:
    print(json.dumps(result))
