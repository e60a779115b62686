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
contact facets (or computed from the cell geometry: |K|, h_K), so it is parallel with ghost cells on facets
only. The integrals are grouped into as few assemblies as possible (one for cells and Γ_C, one for interior
edges, one per Neumann slot below): each assembly has a fixed cost of a form and a cell-sized vector.
Two per-edge quantities need care:
- g_E: the means are per *edge*, and a cell may have two or three Neumann edges. Each Neumann facet is
  tagged with its local index i ∈ {0, 1, 2} in its cell (its *slot*), so ``ds`` over one slot sees at most
  one edge per cell and the per-edge integrals ∫_E g, ∫_E (σν − g), ∫_E |g|², |E| come out separately;
  slots used on no rank are skipped.
- the patch sum over ω_K: with o_K = ‖f − f_K‖_K², vertex sums S_x = Σ_{K ∋ x} o_K give by
  inclusion–exclusion Σ_{K' ⊂ ω_K} o_K' = Σ_{x ∈ K} S_x − 2 o_K − Σ_{N ~ K} o_N (N: the edge neighbours),
  which needs only facet ghosts (:func:`patch_sum`).
The contact integrand has the kink of (·)_+ inside an edge: it is integrated with a high-degree Gauss
rule (``contact_degree``).
"""
import time
from dataclasses import dataclass, field

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx
from dolfinx import fem, mesh as dmesh
from dolfinx.fem import petsc as fem_petsc

from . import forms

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

    @property
    def comm(self):
        return self.fields["eta"].function_space.mesh.comm


def assemble_cellwise(form, space):
    """Owned-cell values (n_owned, bs) of a linear ``form`` whose test function is in the DG0 ``space``."""
    vec = fem_petsc.assemble_vector(fem.form(form))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    n_owned = space.dofmap.index_map.size_local * space.dofmap.index_map_bs
    values = vec.array[:n_owned].copy()
    vec.destroy()
    return values.reshape(-1, space.dofmap.index_map_bs)


def neumann_slot_tags(fields):
    """Neumann facets tagged 1 + 3k + i: k the Neumann group's position, i the facet's local index in its
    cell (the same on every rank that holds the cell, whoever owns the facet)."""
    msh, tags = fields.domain.mesh, fields.domain.facet_tags
    msh.topology.create_connectivity(1, 2)
    msh.topology.create_connectivity(2, 1)
    f2c, c2f = msh.topology.connectivity(1, 2), msh.topology.connectivity(2, 1)
    groups = fields.ids["neumann"]
    mask = np.isin(tags.values, groups)
    facets, group_of = tags.indices[mask], tags.values[mask]
    cells = f2c.array[f2c.offsets[facets]]  # an exterior facet has one cell
    local_index = np.argmax(c2f.array.reshape(-1, 3)[cells] == facets[:, None], axis=1)
    k = np.searchsorted(groups, group_of)
    return dmesh.meshtags(msh, 1, facets, (1 + 3 * k + local_index).astype(np.int32))


def cell_geometry(msh):
    """|K| and h_K (longest edge) of the owned cells, from the vertex coordinates (P1 triangles)."""
    n_owned = msh.topology.index_map(2).size_local
    nodes = msh.geometry.dofmap.array.reshape(-1, 3)[:n_owned]
    x, y = msh.geometry.x[:, 0], msh.geometry.x[:, 1]
    ex = x[nodes[:, [1, 2, 0]]] - x[nodes]  # the three edge vectors of each cell
    ey = y[nodes[:, [1, 2, 0]]] - y[nodes]
    area = 0.5 * np.abs(ex[:, 0] * ey[:, 1] - ey[:, 0] * ex[:, 1])
    return area, np.sqrt(np.max(ex * ex + ey * ey, axis=1))


def estimate(u, fields, contact_degree=CONTACT_DEGREE, cell_degree=CELL_DEGREE):
    """Indicators of Definition 5 and ζ (§4.1) for the discrete solution ``u``."""
    start = time.perf_counter()
    msh, comm = fields.domain.mesh, fields.domain.comm
    Q = fem.FunctionSpace(msh, ("DG", 0))
    Qv = fem.VectorFunctionSpace(msh, ("DG", 0), dim=6)  # for the assemblies of several quantities at once
    w, wv = ufl.TestFunction(Q), ufl.TestFunction(Qv)
    h = ufl.CellDiameter(msh)
    n = ufl.FacetNormal(msh)
    s = fields.sigma(u)
    f = fields.f
    dx = ufl.dx(metadata={"quadrature_degree": cell_degree})
    dS = ufl.dS
    area, h_K = cell_geometry(msh)

    # Cells: ∫_K f, ∫_K |f|²; contact edges: σ_t and the compliance-law residual
    # c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h) (one assembly).
    t = ufl.as_vector([-n[1], n[0]])
    sigma_t, sigma_n = ufl.dot(s * n, t), ufl.dot(s * n, n)
    dC = forms.contact_measure(fields, contact_degree)
    law = forms.contact_pressure(u, fields, n) + sigma_n
    values = assemble_cellwise((f[0] * wv[0] + f[1] * wv[1] + ufl.inner(f, f) * wv[2]) * dx
                               + h * (sigma_t ** 2 * wv[3] + law ** 2 * wv[4]) * dC, Qv)
    f_int, f_sq, eta_3_sq, eta_4_sq = values[:, 0:2], values[:, 2], values[:, 3], values[:, 4]
    f_mean_sq = np.sum(f_int ** 2, axis=1) / area  # ‖f_K‖_K² = |∫_K f|² / |K|
    eta_1_sq = h_K ** 2 * f_mean_sq
    osc_f = np.maximum(f_sq - f_mean_sq, 0.0)

    # Interior edges: the full jump, each side weighted by its own h_K.
    jump = s("+") * n("+") + s("-") * n("-")
    eta_2_sq = assemble_cellwise(ufl.inner(jump, jump) * (h("+") * w("+") + h("-") * w("-")) * dS, Q)[:, 0]

    # Neumann edges, one slot at a time: per-edge means of g and of σν − g.
    eta_2_neumann, osc_g = _neumann_edge_terms(fields, s, n, Qv, cell_degree)
    eta_2_sq += h_K * eta_2_neumann

    zeta_sq = h_K ** 2 * patch_sum(osc_f, Q) + osc_g
    squares = {"eta_1": eta_1_sq, "eta_2": eta_2_sq, "eta_3": eta_3_sq, "eta_4": eta_4_sq,
               "zeta": zeta_sq}
    squares["eta"] = eta_1_sq + eta_2_sq + eta_3_sq + eta_4_sq
    out, totals = {}, {}
    for name in NAMES:
        out[name] = _dg0(Q, name, np.sqrt(np.maximum(squares[name], 0.0)))
        totals[name] = float(np.sqrt(comm.allreduce(float(np.sum(squares[name])), MPI.SUM)))
    return Estimate(out, totals, time.perf_counter() - start, squares["eta"])


def _neumann_edge_terms(fields, s, n, Qv, degree):
    """Per cell: Σ_E |E| |σν − g_E|² (η_2's Neumann part) and Σ_E h_E ‖g − g_E‖_E² (ζ's Neumann part)."""
    msh = fields.domain.mesh
    groups = fields.ids["neumann"]
    n_owned = Qv.dofmap.index_map.size_local
    eta, osc = np.zeros(n_owned), np.zeros(n_owned)
    if not groups:
        return eta, osc
    tags = neumann_slot_tags(fields)
    used = msh.comm.allreduce(int(sum(1 << int(i) for i in np.unique((tags.values - 1) % 3))), MPI.BOR)
    slots = [i for i in range(3) if used >> i & 1]
    ds = ufl.Measure("ds", domain=msh, subdomain_data=tags, metadata={"quadrature_degree": degree})
    wv = ufl.TestFunction(Qv)
    zero = ufl.as_vector([0.0, 0.0])
    for j in slots:
        form = 0
        for k, group in enumerate(groups):
            g = fields.g.get(group, zero)
            r = s * n - g
            form += (r[0] * wv[0] + r[1] * wv[1] + g[0] * wv[2] + g[1] * wv[3] + ufl.inner(g, g) * wv[4]
                     + wv[5]) * ds(1 + 3 * k + j)
        values = assemble_cellwise(form, Qv)
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


def patch_sum(o, Q):
    """Σ_{K' ⊂ ω_K} o_K' for every owned K (ω_K: the cells sharing a vertex with K), from owned-cell ``o``.

    Vertex sums S_x = Σ_{K ∋ x} o_K are added up over the owned cells of every rank (reverse scatter to
    the vertex owners, forward scatter back), then Σ_{x ∈ K} S_x − 2 o_K − Σ_{N ~ K} o_N, the neighbours'
    o_N coming from the facet ghosts.
    """
    msh = Q.mesh
    n_owned = len(o)
    msh.topology.create_connectivity(2, 0)
    msh.topology.create_connectivity(1, 2)
    cell_vertices = msh.topology.connectivity(2, 0).array.reshape(-1, 3)[:n_owned]
    vertex_map = msh.topology.index_map(0)
    S = dolfinx.la.vector(vertex_map)
    S.array[:] = np.bincount(cell_vertices.ravel(), weights=np.repeat(o, 3), minlength=len(S.array))
    S.scatter_reverse(dolfinx.la.ScatterMode.add)
    S.scatter_forward()
    o_all = _dg0(Q, "o", o).x.array  # with the ghost cells' values
    f2c = msh.topology.connectivity(1, 2)
    interior = np.flatnonzero(np.diff(f2c.offsets) == 2)
    pairs = f2c.array[f2c.offsets[interior][:, None] + np.arange(2)]
    neighbours = (np.bincount(pairs[:, 0], weights=o_all[pairs[:, 1]], minlength=len(o_all))
                  + np.bincount(pairs[:, 1], weights=o_all[pairs[:, 0]], minlength=len(o_all)))
    return S.array[cell_vertices].sum(axis=1) - 2 * o - neighbours[:n_owned]
