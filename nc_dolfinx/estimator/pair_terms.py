"""Definition 5's contact terms on the faces of [[pairs]] (two deformable bodies), on both faces of each pair.

On a facet F of either face, with ν its outward normal and p the pair's pressure at its points (the law (4)
with the normal jump across the pair, :mod:`nc_dolfinx.pairs.coupling`: on the second face the pressure of
its own points projected onto the first, i.e. the same pressure carried through Π),

    η_3K² += h_K ‖(σ(u_h)ν − t)_t‖²_F,      η_4K² += h_K ‖(σ(u_h)ν − t)·ν‖²_F,   t = −p n + σ_t

(n the law's normal, :func:`nc_dolfinx.pairs.faces.pair_normal`; on flat faces n = ν and these are
‖σ_t(u_h) − σ_t‖ and ‖p + σ_n(u_h)‖) — the terms of the foundation's Γ_C (σ_t the law's tangential traction: 0 without friction; with
``pairs.friction`` the law's traction at the face's vertices, P1 between them, :mod:`nc_dolfinx.pairs.friction`,
as the foundation's law is read on Γ_C), taken with the pair's
integration points (the facets cut where the other face's vertices project, :mod:`nc_dolfinx.pairs.segments`).
What is proved: Theorem 6's upper bound for one body on a foundation; for two bodies the same argument runs on
each body with the other's trace as data (the residual estimators for contact interfaces of Belhachmi & Hecht,
and of Chouly, Fabre, Hild, Pousin, Renard for Nitsche's method, have this form), but the consistency term of
the projection Π between non-matching faces is not bounded by them: no theorem covers the two-body estimator,
and tests/test_pairs.py measures what it does.
"""
import numpy as np
import dolfinx
from dolfinx import fem

from .. import dolfinx_versions as versions


def pair_terms(u, fields, coupling):
    """Per owned cell, without the factor h_K: (Σ_F ‖σ_t‖²_F, Σ_F ‖p + σ_n‖²_F) over its facets on pair faces."""
    msh = fields.domain.mesh
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    cell_map = msh.topology.index_map(tdim)
    sigma = _cellwise_stress(u, fields)
    pressure = coupling.pressure()
    per_cell = dolfinx.la.vector(cell_map, bs=2)
    terms = per_cell.array.reshape(-1, 2)
    law = _frictional_traction(u, fields, coupling)
    for rows, where in coupling.by_rows():
        cells = rows.face.cells[rows.facet]
        # σ(u_h)ν against the contact's traction −p n + σ_t (n the law's normal, σ_t the friction law's)
        residual = np.einsum("nij,nj->ni", sigma[cells], rows.normal) + pressure[where][:, None] * rows.direction
        if law is not None:  # (the law's traction P1 between the face's vertices)
            residual -= np.einsum("nk,nkd->nd", rows.bary, law[rows.face.local_dofs[rows.facet]])
        normal_part = np.einsum("ni,ni->n", residual, rows.normal)
        tangential = residual - normal_part[:, None] * rows.normal
        np.add.at(terms[:, 0], cells, rows.measure * np.einsum("ni,ni->n", tangential, tangential))
        np.add.at(terms[:, 1], cells, rows.measure * normal_part ** 2)
    per_cell.scatter_reverse(versions.SCATTER_ADD)
    return terms[:cell_map.size_local, 0].copy(), terms[:cell_map.size_local, 1].copy()


def _frictional_traction(u, fields, coupling):
    """With friction between the faces: the law's traction σ_t at every local vertex (n_vertices, gdim),
    0 off the frictional faces (:meth:`~nc_dolfinx.pairs.friction.PairFriction.write_traction`); else None."""
    if coupling.friction is None:
        return None
    return coupling.friction.write_traction(fem.Function(u.function_space)).x.array.reshape(-1, fields.dim)


def _cellwise_stress(u, fields):
    """σ(u_h) on every local cell (n, gdim, gdim): constant per cell for P1 and a cellwise constant material."""
    msh = fields.domain.mesh
    gdim = msh.geometry.dim
    space = versions.dg0_space(msh, (gdim, gdim))
    sigma = fem.Function(space)
    sigma.interpolate(fem.Expression(fields.sigma(u), versions.interpolation_points(space)))
    n = msh.topology.index_map(msh.topology.dim).size_local + msh.topology.index_map(msh.topology.dim).num_ghosts
    dofs = versions.cell_dofs(space.dofmap)[:n, 0]
    return sigma.x.array.reshape(-1, gdim * gdim)[dofs].reshape(n, gdim, gdim)
