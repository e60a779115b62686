"""The contact cap of a cattaneo3d solution: stick, slip or no contact at the vertices of Γ_C, where the
friction law is evaluated (the vertex rule: nc_dolfinx/physics/forms.py, law_measure), for
docs/render_cattaneo3d.py.

At a vertex the law's quantities are nodal values: u, u_prev (the previous load state,
``fields.friction.previous``), the spring's stretch w = (ε/F) σ_t,prev that carries the previous state's
traction (nc.spring_stretch), the vertex normal N (``fields.friction.normal``) and the law's gap g̃_0
(``fields.friction.gap``); the penetration is (u·N − g̃_0)_+, s = (u − u_prev) − ((u − u_prev)·N) N − w,
and the vertex slips where |s| > ε_r (u·N − g̃_0)_+ — the rule of the output's stick_slip, recomputed here
from the inputs. The vertex rule gives each vertex of a facet a third of it: the quadrilateral between the
vertex, the midpoints of its two edges and the centroid, which is what is drawn (so the drawn areas are
the history's stick_area / slip_area).
"""
import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

NO_CONTACT, STICK, SLIP = 0, 1, 2


def _vertex_maps(msh, V):
    """vertex -> dof of the scalar block of V, vertex -> geometry node (P1: cell-local vertex i is dof i)."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim, 0)
    c2v = msh.topology.connectivity(tdim, 0).array.reshape(-1, tdim + 1)
    nverts = msh.topology.index_map(0).size_local + msh.topology.index_map(0).num_ghosts
    to_dof, to_geom = np.empty(nverts, dtype=np.int64), np.empty(nverts, dtype=np.int64)
    to_dof[c2v] = V.dofmap.list.array.reshape(-1, tdim + 1)
    to_geom[c2v] = msh.geometry.dofmap.array.reshape(-1, tdim + 1)
    return to_dof, to_geom


def contact_facets(solution, comm=MPI.COMM_WORLD):
    """On rank 0: arrays (facets, 3 vertices, 3) of the coordinates, u, u_prev, N and w at the vertices of the
    owned Γ_C facets of every rank (None on the other ranks)."""
    fields, u = solution.fields, solution.u
    msh, V = fields.domain.mesh, u.function_space
    tags = fields.domain.facet_tags
    facets = tags.indices[np.isin(tags.values, fields.ids["contact"])]
    msh.topology.create_connectivity(2, 0)
    f2v = msh.topology.connectivity(2, 0)
    verts = np.array([f2v.links(f) for f in facets], dtype=np.int64).reshape(-1, 3)
    to_dof, to_geom = _vertex_maps(msh, V)
    dofs = to_dof[verts]
    law = fields.friction

    def values(function):
        return function.x.array.reshape(-1, 3)[dofs]

    local = (msh.geometry.x[to_geom[verts]], values(u), values(law.previous), values(law.normal),
             values(nc.spring_stretch(u, fields)), law.gap.x.array[dofs])
    gathered = comm.gather(local, root=0)
    if comm.rank != 0:
        return None
    return tuple(np.concatenate([g[i] for g in gathered]) for i in range(6))


def classify(patch, epsilon_r):
    """(pieces (k, 4, 3) corner coordinates, state (k,) NO_CONTACT/STICK/SLIP, area (k,), traction ratio
    |σ_t|/F (k,)): each facet of ``patch`` (:func:`contact_facets`) cut into its vertices' thirds (vertex,
    edge midpoint, centroid, edge midpoint), each with its vertex's state."""
    X, U, P, N, W, G = patch
    du = U - P
    penetration = np.maximum(np.einsum("fvi,fvi->fv", U, N) - G, 0.0)
    slip = du - np.einsum("fvi,fvi->fv", du, N)[..., None] * N - W
    size, length = np.linalg.norm(slip, axis=-1), epsilon_r * penetration
    state = np.where(penetration > 0, np.where(size > length, SLIP, STICK), NO_CONTACT)
    ratio = np.where(penetration > 0, size / np.maximum(np.maximum(size, length), 1e-300), 0.0)
    centroid = X.mean(axis=1)
    pieces = np.stack([np.stack([X[:, v], (X[:, v] + X[:, (v + 1) % 3]) / 2, centroid,
                                 (X[:, v] + X[:, (v + 2) % 3]) / 2], axis=1) for v in range(3)], axis=1)
    area = 0.5 * np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
    return pieces.reshape(-1, 4, 3), state.ravel(), np.repeat(area / 3, 3), ratio.ravel()
