"""The contact cap of a cattaneo3d solution, sampled inside its facets: stick, slip or no contact, as the
solver's friction_quantities classify them (nc_dolfinx/physics/quantities.py), for docs/render_cattaneo3d.py,
verification/cattaneo3d.py and tests/test_cattaneo3d.py.

At a point of a Γ_C facet the law's quantities are those of the UFL forms: u, u_prev (the previous load
state, ``fields.friction.previous``), the spring's stretch w = (ε/F) σ_t,prev that carries the previous
state's traction (nc_dolfinx/physics/slip_state.py; ε/F = ε_r/(μ c_n) is constant here, m_n = 1) and the
vertex normal N (``fields.friction.normal``) are linear in the facet; the penetration is (u·ν − g_0)_+
with ν the facet's outward normal and g_0 the sphere's height R − sqrt(R² − x² − y²) (the case's gap);
s = (u − u_prev) − ((u − u_prev)·N) N − w, and the point slips where |s| > ε_r (u·ν − g_0)_+. Each facet
is cut into n² similar triangles, each classified at its
centroid: the areas then approximate the history's stick_area / slip_area (a quadrature of the same
indicator), and the pieces draw the zones.
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
             values(nc.spring_stretch(u, fields)))
    gathered = comm.gather(local, root=0)
    if comm.rank != 0:
        return None
    return tuple(np.concatenate([g[i] for g in gathered]) for i in range(5))


def _subdivision(n):
    """Barycentric coordinates of the centroids of the n² similar sub-triangles of a triangle, and the
    barycentric corners of each (for drawing)."""
    corners = []
    for i in range(n):
        for j in range(n - i):
            a, b, c = (i, j), (i + 1, j), (i, j + 1)
            corners.append([a, b, c])
            if j < n - i - 1:
                corners.append([(i + 1, j), (i + 1, j + 1), (i, j + 1)])
    corners = np.array(corners, dtype=float) / n  # (n², 3, 2): (λ1, λ2) of each corner
    bary = lambda l12: np.stack([1 - l12[..., 0] - l12[..., 1], l12[..., 0], l12[..., 1]], axis=-1)
    return bary(corners.mean(axis=1)), bary(corners)


def classify(patch, R, epsilon_r, n=4):
    """(pieces (k, 3, 3) corner coordinates, state (k,) NO_CONTACT/STICK/SLIP, area (k,), traction ratio
    |σ_t|/F (k,)) of the n² sub-triangles of every facet of ``patch`` (:func:`contact_facets`)."""
    X, U, P, N, W = patch
    centroid_bary, corner_bary = _subdivision(n)
    normal = np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0])
    area = 0.5 * np.linalg.norm(normal, axis=1)
    normal /= 2 * area[:, None]
    centre = np.array([0.0, 0.0, R])
    normal *= np.sign(np.einsum("fi,fi->f", normal, X.mean(axis=1) - centre))[:, None]  # outward
    at = lambda A: np.einsum("sv,fvi->fsi", centroid_bary, A)  # (facets, n², 3)
    x, u, du, nv, w = at(X), at(U), at(U - P), at(N), at(W)
    gap = R - np.sqrt(np.maximum(R ** 2 - x[..., 0] ** 2 - x[..., 1] ** 2, 0.0))
    penetration = np.maximum(np.einsum("fsi,fi->fs", u, normal) - gap, 0.0)
    slip = du - np.einsum("fsi,fsi->fs", du, nv)[..., None] * nv - w
    size = np.linalg.norm(slip, axis=-1)
    length = epsilon_r * penetration
    state = np.where(penetration > 0, np.where(size > length, SLIP, STICK), NO_CONTACT)
    ratio = np.where(penetration > 0, size / np.maximum(np.maximum(size, length), 1e-300), 0.0)
    pieces = np.einsum("scv,fvi->fsci", corner_bary, X)
    return (pieces.reshape(-1, 3, 3), state.ravel(), np.repeat(area / n ** 2, n ** 2), ratio.ravel())
