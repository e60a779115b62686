"""The residual a posteriori error estimator of Fernández & Hild, Definition 5, and the oscillation ζ.

    η_1K = h_K ‖f_K‖_K,                        f_K = mean of f over K
    η_2K = h_K^{1/2} (Σ_{E ∈ E_K^int ∪ E_K^N} ‖J_{E,n}(u_h)‖_E²)^{1/2}      with J from (15):
           J = [σ(u_h) ν_E]_E on interior edges (the full jump; each edge counts for both triangles),
           J = σ(u_h) ν − g_E on Neumann edges, g_E = mean of g over E
    η_3K = h_K^{1/2} (Σ_{E ∈ E_K^C} ‖σ_t(u_h)‖_E²)^{1/2}
    η_4K = h_K^{1/2} (Σ_{E ∈ E_K^C} ‖c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h)‖_E²)^{1/2}
    η_K  = (Σ_i η_iK²)^{1/2},  η = (Σ_K η_K²)^{1/2}
    ζ_K  = (h_K² Σ_{K' ⊂ ω_K} ‖f − f_K'‖_K'² + Σ_{E ∈ E_K^N} h_E ‖g − g_E‖_E²)^{1/2},  ζ = (Σ_K ζ_K²)^{1/2}

h_K is the diameter of K (longest edge), h_E = |E|, ω_K the cells sharing a vertex with K.

Every quantity is assembled against DG0 test functions over cells, interior facets, Neumann facets and
contact facets, so it is parallel with ghost cells on facets only. Two per-edge quantities need care:
- g_E: the means are per *edge*, and a cell may have two or three Neumann edges. Neumann facets are tagged
  by their local index i ∈ {0, 1, 2} in their cell, so ``ds(i)`` sees at most one edge per cell and the
  per-edge integrals ∫_E g, ∫_E (σν − g), ∫_E |g|², |E| come out separately.
- the patch sum over ω_K: with o_K = ‖f − f_K‖_K², vertex sums S_x = Σ_{K ∋ x} o_K (P1 assembly) give by
  inclusion–exclusion Σ_{K' ⊂ ω_K} o_K' = Σ_{x ∈ K} S_x − 2 o_K − Σ_{N ~ K} o_N (N: the edge neighbours),
  which needs only facet ghosts.
The contact integrand has the kink of (·)_+ inside an edge: it is integrated with a high-degree Gauss
rule (``contact_degree``).
"""
import time
from dataclasses import dataclass, field

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem, mesh as dmesh
from dolfinx.fem import petsc as fem_petsc

from . import forms
from .problem import sigma

NAMES = ("eta_1", "eta_2", "eta_3", "eta_4", "eta", "zeta")
CELL_DEGREE = 8
CONTACT_DEGREE = 24


@dataclass
class Estimate:
    """Cellwise indicators (DG0 functions named as in NAMES) and their global values."""
    fields: dict
    totals: dict
    time: float = 0.0
    squares: np.ndarray = field(default=None, repr=False)  # η_K² on the owned cells (for marking)


def _assemble_dg0(form, space):
    vec = fem_petsc.assemble_vector(fem.form(form))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    n_owned = space.dofmap.index_map.size_local * space.dofmap.index_map_bs
    values = vec.array[:n_owned].copy()
    vec.destroy()
    return values.reshape(-1, space.dofmap.index_map_bs)


def local_facet_tags(fields):
    """Neumann facets tagged 1 + 3k + i: k the Neumann group's position, i the facet's index in its cell."""
    msh, tags = fields.domain.mesh, fields.domain.facet_tags
    msh.topology.create_connectivity(1, 2)
    msh.topology.create_connectivity(2, 1)
    f2c, c2f = msh.topology.connectivity(1, 2), msh.topology.connectivity(2, 1)
    groups = fields.ids["neumann"]
    mask = np.isin(tags.values, groups)
    facets, group_of = tags.indices[mask], tags.values[mask]
    cells = np.array([f2c.links(f)[0] for f in facets], dtype=np.int32)
    cell_facets = c2f.array.reshape(-1, 3)[cells]
    local_index = np.argmax(cell_facets == facets[:, None], axis=1)
    k = np.searchsorted(groups, group_of)
    return dmesh.meshtags(msh, 1, facets, (1 + 3 * k + local_index).astype(np.int32))


def estimate(u, fields, contact_degree=CONTACT_DEGREE, cell_degree=CELL_DEGREE):
    """Indicators of Definition 5 and ζ (§4.1) for the discrete solution ``u``."""
    start = time.perf_counter()
    msh, comm = fields.domain.mesh, fields.domain.comm
    Q = fem.FunctionSpace(msh, ("DG", 0))
    w = ufl.TestFunction(Q)
    h = ufl.CellDiameter(msh)
    n = ufl.FacetNormal(msh)
    s = sigma(u, fields.lmbda, fields.mu)
    f = fields.f
    dx = ufl.dx(metadata={"quadrature_degree": cell_degree})
    dS = ufl.dS

    # Cells: |K|, ∫_K f, ∫_K |f|², ∫_K h_K  ->  h_K, η_1K and o_K = ‖f − f_K‖_K² (one assembly).
    Qv = fem.VectorFunctionSpace(msh, ("DG", 0), dim=5)
    wv = ufl.TestFunction(Qv)
    cell = _assemble_dg0((wv[0] + f[0] * wv[1] + f[1] * wv[2] + ufl.inner(f, f) * wv[3] + h * wv[4]) * dx, Qv)
    area, f_int, f_sq = cell[:, 0], cell[:, 1:3], cell[:, 3]
    h_K = cell[:, 4] / area
    f_mean_sq = np.sum(f_int ** 2, axis=1) / area  # ‖f_K‖_K² = |∫_K f|² / |K|
    eta_1_sq = h_K ** 2 * f_mean_sq
    osc_f = np.maximum(f_sq - f_mean_sq, 0.0)

    # Interior edges: the full jump, each side weighted by its own h_K.
    jump = s("+") * n("+") + s("-") * n("-")
    eta_2_sq = _assemble_dg0(ufl.inner(jump, jump) * (h("+") * w("+") + h("-") * w("-")) * dS, Q)[:, 0]

    # Neumann edges, one local facet index at a time: per-edge means of g and of σν − g.
    eta_2_neumann, osc_g = _neumann_edge_terms(fields, s, n, Q, cell_degree)
    eta_2_sq += h_K * eta_2_neumann

    # Contact edges: σ_t and the compliance-law residual c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h).
    t = ufl.as_vector([-n[1], n[0]])
    sigma_t, sigma_n = ufl.dot(s * n, t), ufl.dot(s * n, n)
    dC = forms.contact_measure(fields, contact_degree)
    law = forms.contact_pressure(u, fields, n) + sigma_n
    Qc = fem.VectorFunctionSpace(msh, ("DG", 0), dim=2)
    wc = ufl.TestFunction(Qc)
    contact = _assemble_dg0(h * (sigma_t ** 2 * wc[0] + law ** 2 * wc[1]) * dC, Qc)
    eta_3_sq, eta_4_sq = contact[:, 0], contact[:, 1]

    zeta_sq = h_K ** 2 * _patch_sum(osc_f, area, Q) + osc_g
    squares = {"eta_1": eta_1_sq, "eta_2": eta_2_sq, "eta_3": eta_3_sq, "eta_4": eta_4_sq,
               "zeta": zeta_sq}
    squares["eta"] = eta_1_sq + eta_2_sq + eta_3_sq + eta_4_sq
    out, totals = {}, {}
    for name in NAMES:
        out[name] = _dg0(Q, name, np.sqrt(np.maximum(squares[name], 0.0)))
        totals[name] = float(np.sqrt(comm.allreduce(float(np.sum(squares[name])), MPI.SUM)))
    return Estimate(out, totals, time.perf_counter() - start, squares["eta"])


def _neumann_edge_terms(fields, s, n, Q, degree):
    """Per cell: Σ_E |E| |σν − g_E|² (η_2's Neumann part) and Σ_E h_E ‖g − g_E‖_E² (ζ's Neumann part)."""
    msh = fields.domain.mesh
    groups = fields.ids["neumann"]
    n_owned = Q.dofmap.index_map.size_local
    eta, osc = np.zeros(n_owned), np.zeros(n_owned)
    if not groups:
        return eta, osc
    ds = ufl.Measure("ds", domain=msh, subdomain_data=local_facet_tags(fields),
                     metadata={"quadrature_degree": degree})
    Qv = fem.VectorFunctionSpace(msh, ("DG", 0), dim=6)
    wv = ufl.TestFunction(Qv)
    zero = ufl.as_vector([0.0, 0.0])
    for i in range(3):
        form = 0
        for k, group in enumerate(groups):
            g = fields.g.get(group, zero)
            r = s * n - g
            form += (r[0] * wv[0] + r[1] * wv[1] + g[0] * wv[2] + g[1] * wv[3] + ufl.inner(g, g) * wv[4]
                     + wv[5]) * ds(1 + 3 * k + i)
        values = _assemble_dg0(form, Qv)
        length = values[:, 5]
        has_edge = length > 0
        L = np.where(has_edge, length, 1.0)
        eta += np.where(has_edge, np.sum(values[:, 0:2] ** 2, axis=1) / L, 0.0)
        g_norm_sq = np.maximum(values[:, 4] - np.sum(values[:, 2:4] ** 2, axis=1) / L, 0.0)
        osc += np.where(has_edge, length * g_norm_sq, 0.0)
    return eta, osc


def _dg0(Q, name, owned_values):
    fn = fem.Function(Q, name=name)
    fn.x.array[:len(owned_values)] = owned_values
    fn.x.scatter_forward()
    return fn


def _patch_sum(o, area, Q):
    """Σ_{K' ⊂ ω_K} o_K' for every owned K (ω_K: the cells sharing a vertex with K)."""
    msh = Q.mesh
    o_fn = _dg0(Q, "o", o)
    area_fn = _dg0(Q, "area", area)
    V1 = fem.FunctionSpace(msh, ("CG", 1))
    # S_x = Σ_{K ∋ x} o_K: ∫_K φ_x = |K|/3 for P1 hat functions.
    S = fem.Function(V1)
    vec = fem_petsc.assemble_vector(fem.form(3 * o_fn / area_fn * ufl.TestFunction(V1) * ufl.dx))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.copy(S.vector)
    vec.destroy()
    S.x.scatter_forward()
    w = ufl.TestFunction(Q)
    vertex_sum = 3 * _assemble_dg0(S * w * ufl.dx, Q)[:, 0] / area  # Σ_{x ∈ K} S_x
    e = ufl.FacetArea(msh)
    neighbours = _assemble_dg0((o_fn("-") * w("+") + o_fn("+") * w("-")) / e("+") * ufl.dS, Q)[:, 0]
    return vertex_sum - 2 * o - neighbours
