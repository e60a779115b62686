"""The residual a posteriori error estimator of Fernández & Hild, Definition 5, and the oscillation ζ,
for P1 triangles (2D, plane strain) and tetrahedra (3D) alike; "facet" is an edge in 2D, a face in 3D.

    η_1K = h_K ‖f_K‖_K,                        f_K = mean of f over K
    η_2K = h_K^{1/2} (Σ_{F ∈ F_K^int ∪ F_K^N} ‖J_{F,n}(u_h)‖_F² + Σ_{F ∈ F_K^S} ‖σ_t(u_h)‖_F²)^{1/2},
           J from (15): J = [σ(u_h) ν_F]_F on interior facets (the full jump; each facet counts for both
           cells), J = σ(u_h) ν − g_F on Neumann facets, g_F = mean of g over F; F_K^S: symmetry facets
           (and rollers: the free components of σ(u_h)ν)
    η_3K = h_K^{1/2} (Σ_{F ∈ F_K^C} ‖σ_t(u_h) − s_t(u_h)‖_F²)^{1/2},   σ_t = σν − σ_n ν (a vector); s_t the
           tangential traction of the friction law (:mod:`nc_dolfinx.physics.friction`), 0 without friction
    η_4K = h_K^{1/2} (Σ_{F ∈ F_K^C} ‖c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h)‖_F²)^{1/2}
    η_K  = (Σ_i η_iK²)^{1/2},  η = (Σ_K η_K²)^{1/2}
    ζ_K  = (h_K² Σ_{K' ⊂ ω_K} ‖f − f_K'‖_K'² + Σ_{F ∈ F_K^N} h_F ‖g − g_F‖_F²)^{1/2},  ζ = (Σ_K ζ_K²)^{1/2}

and beside them, not in η, the geometric term η_geo,K (:mod:`.geometric`: how far Γ_C ∪ Γ_N of the mesh
lies from the body's true shape), which joins η_K² in the marking.

h_K is the diameter of K (its longest edge), h_F the diameter of F (|E| in 2D, the longest edge of a face
in 3D), ω_K the cells sharing a vertex with K.

Symmetry facets (an extension of Definition 5). On a symmetry plane u·ν = 0 and the tangential traction
vanishes; the normal traction is the unknown reaction, so the residual is σ_t(u_h) alone. In the proof of
Theorem 6 the boundary term of such a facet is ∫_F σ(u_h)ν·(u − v_h) = ∫_F σ_t(u_h)·(u − v_h), since
(u − v_h)·ν = 0 there (the plane is normal to a coordinate axis, so π_h of (17) can treat that displacement
component as Dirichlet data on it); it is bounded like the σ_t term on Γ_C, and h_K ‖σ_t‖_F² joins η_2K.
Equivalently, mirroring the body across the plane makes F interior, with the jump [σν] = 2σ_t (tangential)
and 0 (normal): the same term up to the factor 4.

Prescribed displacements (loads.u_D, (2) generalised to u = u_D on Γ_D). No term of η or ζ is taken where
Γ_D holds every component (the Neumann ids exclude Γ_D), and none is needed where u_D is linear on each
facet of Γ_D: u_h = I_h u_D = u_D there, u − u_h vanishes on Γ_D as for u = 0, and the proof of Theorem 6 is
unchanged. A u_D that is not linear on the facets would add the data oscillation of u_D − I_h u_D on Γ_D,
which η does not hold. On a roller (a group with components "free") the free components are traction-free:
their traction Σ_i free ‖(σ(u_h)ν)_i‖²_F joins η_2K like a symmetry facet's σ_t (:func:`_roller_components`).

Every quantity is assembled against DG0 test functions (:func:`~nc_dolfinx.mesh.domain.cell_space`: cell i's
values at entries i·dim …) over cells, interior facets, Neumann facets and contact/symmetry facets (or
computed from the vertex coordinates: h_F, and h_K when f = 0), so it is parallel with ghost cells on
facets only. The integrals are grouped into few assemblies, each with a fixed cost: one over the cells
(h_K = ∫_K h / |K|, and f's terms; none when f = 0), one over the facets (the interior facets, the
largest loop, Γ_C, the symmetry planes and the Neumann facets where g is constant), one per layer below
where g varies. The cells' assembly is separate so that u is not packed for it. Every facet term of η_K²
carries the factor h_K of its cell, applied after assembly. The interior facets' jumps, and σν − g on a
Neumann facet with constant g, are constant on each facet (P1, cellwise constant material) and use a
one-point rule, which lets the interior facets' assembly skip the facet permutations (:func:`compile_form`).
Constant data have no oscillation: a constant f skips the patch sum, a constant g its facets' part of ζ
(both would otherwise add round-off).
- g_F where g varies: the means are per *facet*, and a cell may have up to tdim + 1 Neumann facets. The
  facets are dealt into layers with at most one facet per cell (:func:`facet_layers`; one layer unless a
  cell has two facets there), so ``ds`` over one layer gives the per-facet integrals ∫_F g, ∫_F (σν − g),
  ∫_F |g|², |F| cell by cell; they are combined per facet before the ghost cells' sums go to their owners.
- the patch sum over ω_K: by inclusion–exclusion over the sub-simplices of K (:func:`patch_sum`).
- η_4: the kink of (·)_+ inside a facet. On edges (2D) the residual is integrated unsplit with a Gauss rule
  of degree CONTACT_DEGREE = 24 (13 points; measured ≤ 3.2e-4 relative in η_4K on kinked edges, the
  verified 2D numbers). On faces (3D) an unsplit rule is much worse (degree 24, 112 points: up to 3e-3 on
  random kinked triangles), so the face is cut along the zero set of u_hn − g_0 (:mod:`.kink`)
  and a rule of degree CONTACT_DEGREE_SPLIT = 16 (55 points) is applied on each piece: exact for m_n = 1
  with polynomial c_n and affine g_0 (measured 5e-15), ≤ 2e-7 relative for m_n = 1.5
  (tests/test_estimator_3d.py). ``split_kinks`` and ``contact_degree`` override both choices.
"""
import time
from dataclasses import dataclass, field

import numpy as np
import ufl
from mpi4py import MPI

import dolfinx
from dolfinx import fem

from .. import dolfinx_versions as versions
from ..mesh.domain import cell_space
from ..physics import elasticity, forms, friction
from .geometric import geometric_term
from .geometry import cell_diameters, diameters, facet_layers, owned_values_with_ghosts, patch_sum
from .kink import law_residual_squared
from .pair_terms import pair_terms

__all__ = ["NAMES", "CELL_DEGREE", "CONTACT_DEGREE", "CONTACT_DEGREE_SPLIT", "Estimate", "assemble_cellwise",
           "compile_form", "estimate", "patch_sum"]

NAMES = ("eta_1", "eta_2", "eta_3", "eta_4", "eta", "zeta")  # Definition 5's
GEOMETRY = "eta_geometry"  # the geometric term beside them (:mod:`.geometric`)
CELL_DEGREE = 8
CONTACT_DEGREE = 24        # Γ_C on unsplit edges (2D): 13 Gauss points
CONTACT_DEGREE_SPLIT = 16  # Γ_C on each piece of a split face (3D): 55 points


@dataclass
class Estimate:
    """What :func:`estimate` returns: the indicators of Definition 5 and the oscillation ζ (§4.1).

    ``fields``: DG0 functions ``eta_1`` … ``eta_4``, ``eta`` and ``zeta`` holding η_iK, η_K and ζ_K
    on every cell; ``totals``: their global values η_i = (Σ_K η_iK²)^{1/2}, η and ζ (the same on every
    rank), and ``geometry_sag``, the largest δ_F of :mod:`.geometric`; ``squares``: η_K² + η_geo,K² on the
    owned cells (what :func:`mark` reads); ``time``: seconds spent."""
    fields: dict
    totals: dict
    time: float = 0.0
    squares: np.ndarray = field(default=None, repr=False)  # η_K² + η_geo,K² on the owned cells (for marking)

    @property
    def comm(self):
        """The communicator of the mesh the indicators live on."""
        return self.fields["eta"].function_space.mesh.comm


def assemble_cellwise(form, space):
    """Owned-cell values (n_owned, bs) of a linear ``form`` whose test function is in the DG0 ``space``:
    assembled against a DG0 test function, a form's integrand summed cell by cell — how the local
    indicators of Definition 5 are computed (a cell's value includes what its facets' integrals give it;
    ghost contributions are added to the owners). Interior-facet integrals with a one-point rule
    (``quadrature_degree`` 0) skip the facet permutations (:func:`compile_form`)."""
    bs = space.dofmap.index_map_bs
    vec = dolfinx.la.vector(space.dofmap.index_map, bs)  # zeros; no PETSc object, no copy of its values
    fem.assemble_vector(vec.array, compile_form(form))
    vec.scatter_reverse(versions.SCATTER_ADD)
    return vec.array[:space.dofmap.index_map.size_local * bs].reshape(-1, bs)  # (a view keeps vec alive)


def compile_form(form):
    """``fem.form(form)``; if every interior-facet integral of ``form`` has a one-point rule
    (``quadrature_degree`` 0), DOLFINx is told that they need no facet permutations.

    FFCx marks every interior-facet integrand restricted to both sides as needing the permutation that
    maps the quadrature points of the reference facet seen from one cell onto those seen from the other,
    and DOLFINx 0.5 then builds, on the first such assembly on a mesh, the mesh's edges and the entity
    permutations (3D, 1.0e6 cells: 0.47 s, a third of a first estimate). A one-point rule has one point,
    the facet's midpoint, which every permutation of the facet's vertices keeps: the permutation cannot
    change the value. The flag is cleared in the compiled form before DOLFINx reads it; ``fem.form``
    then finds that compiled form in the JIT cache (the same parameters, so the same module, which
    keeps the cleared flag for every later form of the same signature: one-point rules too)."""
    msh = form.ufl_domain().ufl_cargo()
    interior = form.integrals_by_type("interior_facet")
    if interior and all(i.metadata().get("quadrature_degree") == 0 for i in interior):
        for integral in versions.interior_facet_integrals(msh.comm, form, dict(versions.FORM_COMPILER)):
            integral.needs_facet_permutations = False
    return versions.compile_form(form, dict(versions.FORM_COMPILER))


def estimate(u, fields, contact_degree=None, cell_degree=CELL_DEGREE, split_kinks=None):
    """Indicators of Definition 5 and ζ (§4.1) for the discrete solution ``u``.

    ``split_kinks``: integrate η_4 piecewise on each side of the zero set of u_hn − g_0 inside a contact
    facet (default: on faces, i.e. in 3D; in 2D the unsplit 13-point rule). ``contact_degree``: the Gauss
    degree on Γ_C (on each piece when split); default CONTACT_DEGREE, or CONTACT_DEGREE_SPLIT when split.
    """
    start = time.perf_counter()
    msh, comm = fields.domain.mesh, fields.domain.comm
    if split_kinks is None:
        split_kinks = msh.topology.dim > 2  # faces; edges keep their verified unsplit rule
    if contact_degree is None:
        contact_degree = CONTACT_DEGREE_SPLIT if split_kinks else CONTACT_DEGREE
    Q = fields.domain.region.function_space  # the scalar DG0 space (:func:`cell_space`) of η_K, ζ_K

    h_K, f_mean_sq, f_sq = _cell_terms(fields, cell_degree)
    varying = varying_traction_groups(fields)  # these Neumann groups need per-facet means g_F
    facet_terms = _facet_terms(u, fields, contact_degree, split_kinks, varying)
    eta_2_varying_g, osc_g = _varying_neumann_terms(u, fields, cell_degree, varying)
    # Every square below is a sum of nonnegative terms; in place, since each array is 8 bytes a cell.
    eta_1_sq = np.multiply(h_K, h_K)
    eta_1_sq *= f_mean_sq
    eta_2_sq = np.add(facet_terms[:, 0], eta_2_varying_g)
    eta_2_sq *= h_K
    eta_3_sq, eta_4_sq = h_K * facet_terms[:, 1], h_K * facet_terms[:, 2]
    if fields.pairs:  # both faces of each pair of two bodies (:mod:`.pair_terms`)
        pair_3, pair_4 = pair_terms(u, fields, fields.pair_coupling(u))
        eta_3_sq += h_K * pair_3
        eta_4_sq += h_K * pair_4
    zeta_sq = osc_g
    if f_sq is not None:  # a constant f equals its means f_K: no oscillation (nor patch sum)
        # (an alternating sum: kept from going below 0 by round-off)
        zeta_sq = zeta_sq + h_K ** 2 * np.maximum(patch_sum(np.maximum(f_sq - f_mean_sq, 0.0), Q), 0.0)
    eta_sq = eta_1_sq + eta_2_sq
    eta_sq += eta_3_sq
    eta_sq += eta_4_sq
    geometry_sq, sag = geometric_term(u, fields)
    squares = {"eta_1": eta_1_sq, "eta_2": eta_2_sq, "eta_3": eta_3_sq, "eta_4": eta_4_sq, "eta": eta_sq,
               "zeta": zeta_sq, GEOMETRY: geometry_sq}
    fields_out = {name: owned_values_with_ghosts(Q, squares[name], name, np.sqrt) for name in (*NAMES, GEOMETRY)}
    sums = comm.allreduce(np.array([np.sum(squares[name]) for name in (*NAMES, GEOMETRY)]), MPI.SUM)
    totals = {name: float(np.sqrt(total)) for name, total in zip((*NAMES, GEOMETRY), sums)}
    totals["geometry_sag"] = sag
    marking = eta_sq if sag == 0.0 else eta_sq + geometry_sq  # the geometry is refined where it is coarse too
    return Estimate(fields_out, totals, time.perf_counter() - start, marking)


def _against(vector, wv, first):
    """Σ_i vector_i wv_{first+i}: the components of ``vector`` into consecutive slots of a DG0 test function."""
    return sum((vector[i] * wv[first + i] for i in range(1, len(vector))), vector[0] * wv[first])


def _constant(expression):
    """Whether a UFL expression is the same on every cell (no coordinates, no functions in it)."""
    return not (ufl.algorithms.extract_type(expression, ufl.SpatialCoordinate)
                or ufl.algorithms.extract_coefficients(expression))


def _cell_terms(fields, degree):
    """Per owned cell: h_K, ‖f_K‖²_K = |∫_K f|² / |K| (η_1K²/h_K²) and ‖f‖²_K (None for a constant f: no
    oscillation). One assembly over the cells of |K| and ∫_K h (h_K = ∫_K h / |K|), and where f varies of
    ∫_K f and ∫_K |f|²; a constant f needs none of its own (‖f_K‖²_K = |f|² |K|), and f = 0 no assembly at
    all (η_1 = 0; h_K from the vertices)."""
    f, msh = fields.f, fields.domain.mesh
    gdim, constant = msh.geometry.dim, _constant(f)
    with np.errstate(over="ignore"):  # an f beyond double precision: inf, refused with the level's row
        f_squared = float(np.sum(_value(f) ** 2)) if constant else None
    if f_squared == 0.0:
        return cell_diameters(msh), np.zeros(msh.topology.index_map(msh.topology.dim).size_local), None
    Qv = cell_space(msh, 2 if constant else gdim + 3)
    w = ufl.TestFunction(Qv)
    integrand = w[0] + ufl.CellDiameter(msh) * w[1]
    if not constant:
        integrand += _against(f, w, 2) + ufl.inner(f, f) * w[gdim + 2]
    values = assemble_cellwise(integrand * ufl.dx(metadata={"quadrature_degree": 0 if constant else degree}), Qv)
    area, h_K = values[:, 0], values[:, 1] / values[:, 0]
    if constant:
        return h_K, f_squared * area, None
    return h_K, sum(values[:, 2 + i] ** 2 for i in range(gdim)) / area, values[:, gdim + 2]


def _facet_terms(u, fields, contact_degree, split_kinks, varying):
    """One assembly, per owned cell, of its facet terms without the factor h_K (columns): η_2K²/h_K but for
    the Neumann facets where g varies — over its interior facets Σ ‖[σ(u_h) ν_F]‖²_F (the full jump), over
    its symmetry facets Σ ‖σ_t‖²_F, over its Neumann facets with constant g (groups not in ``varying``)
    Σ ‖σν − g‖²_F —, η_3K²/h_K = Σ ‖σ_t‖²_F and η_4K²/h_K = Σ ‖c_n (u_hn − g_0)_+^{m_n} + σ_n‖²_F over its
    contact facets."""
    msh = fields.domain.mesh
    gdim = msh.geometry.dim
    Qv = cell_space(msh, 3)
    wv = ufl.TestFunction(Qv)
    n, s = ufl.FacetNormal(msh), fields.sigma(u)
    sigma_t = elasticity.tangential_stress(s, n)
    if split_kinks:
        law_squared = law_residual_squared(u, fields, n)
    else:
        law_squared = (forms.contact_pressure(u, fields, n) + elasticity.normal_stress(s, n)) ** 2
    eta_2, eta_3, eta_4 = 0, 1, 2  # components of wv
    dC = forms.contact_measure(fields, contact_degree)
    tangential_residual = sigma_t if fields.friction is None else \
        sigma_t - friction.tangential_traction(u, forms.penetration(u, fields, n), fields.friction)
    form = (ufl.inner(tangential_residual, tangential_residual) * wv[eta_3] + law_squared * wv[eta_4]) * dC
    symmetry = tuple(fields.symmetry_axes)
    if symmetry:
        form += ufl.inner(sigma_t, sigma_t) * wv[eta_2] * fields.ds(symmetry)
    for group, free in _roller_components(fields).items():
        form += sum((s * n)[i] ** 2 for i in free) * wv[eta_2] * fields.ds(group)
    one_point = {"quadrature_degree": 0}
    for group in (group for group in fields.ids["neumann"] if group not in varying):
        residual = s * n - fields.g.get(group, ufl.zero(gdim))  # constant on the facet: one point
        form += ufl.inner(residual, residual) * wv[eta_2] * fields.ds(group, metadata=one_point)
    jump = s("+") * n("+") + s("-") * n("-")
    dS = ufl.dS(metadata={"quadrature_degree": 0})  # P1: the jump is constant on a facet; see compile_form
    form += ufl.inner(jump, jump) * (wv("+")[eta_2] + wv("-")[eta_2]) * dS
    return assemble_cellwise(form, Qv)


def _roller_components(fields):
    """{Dirichlet group id: its free components} for the groups of loads.u_D with a component "free" (rollers).
    There u_i is free and traction-free for each free component i, and the held ones are Cartesian
    components, which π_h of (17) can hold componentwise: the boundary term of Theorem 6's proof is
    Σ_i free ∫_F (σ(u_h)ν)_i (u − v_h)_i, bounded like a symmetry plane's σ_t term (on a roller in a
    coordinate plane holding its normal component, Σ_i free (σν)_i² = |σ_t|²)."""
    free = {group: [i for i, c in enumerate(components) if c is None] for group, components in fields.u_D.items()}
    return {group: components for group, components in free.items() if components}


def _value(expression):
    """The value (an array of its shape) of a UFL expression that is the same everywhere (:func:`_constant`:
    numbers and ``fem.Constant``s)."""
    constants = {c: c.value for c in ufl.algorithms.extract_type(expression, ufl.Constant)}
    domain = ufl.domain.extract_unique_domain(expression)
    origin = (0.0,) * versions.geometric_dimension(domain) if domain else ()
    return np.array([float(expression[i](origin, constants)) for i in np.ndindex(expression.ufl_shape)])


def varying_traction_groups(fields):
    """The Neumann groups (sorted ids) whose traction g varies in space: those need per-facet means g_F;
    where g is constant, g_F = g (a group without g is traction-free)."""
    return sorted(group for group in fields.ids["neumann"]
                  if group in fields.g and not _constant(fields.g[group]))


def _varying_neumann_terms(u, fields, degree, varying):
    """Per owned cell, over its Neumann facets where g varies: Σ_F |F| |σν − g_F|² (η_2K²'s part without
    h_K) and Σ_F h_F ‖g − g_F‖²_F (ζ_K²'s part), one assembly per layer of :func:`facet_layers`; ``varying``:
    the groups where g varies (:func:`varying_traction_groups`)."""
    msh = fields.domain.mesh
    gdim, tdim = msh.geometry.dim, msh.topology.dim
    n_owned = msh.topology.index_map(tdim).size_local
    if not varying:  # the same on every rank
        return np.zeros(n_owned), np.zeros(n_owned)
    per_cell = dolfinx.la.vector(msh.topology.index_map(tdim), bs=2)  # η_2 and ζ parts, ghosts included
    terms = per_cell.array.reshape(-1, 2)
    Qv = cell_space(msh, 2 * gdim + 2)
    wv, s, n = ufl.TestFunction(Qv), fields.sigma(u), ufl.FacetNormal(msh)
    for tags, facets, cells in facet_layers(fields.domain, varying):
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tags, metadata={"quadrature_degree": degree})
        form = sum((_against(s * n - fields.g[group], wv, 0) + _against(fields.g[group], wv, gdim)
                    + ufl.inner(fields.g[group], fields.g[group]) * wv[2 * gdim] + wv[2 * gdim + 1])
                   * ds(1 + k) for k, group in enumerate(varying))
        # Not sent to the owners yet: each cell's values are those of its one facet in the layer. (np.zeros
        # leaves the pages of the cells without a facet here untouched: no pass over the whole mesh.)
        values = np.zeros((Qv.dofmap.index_map.size_local + Qv.dofmap.index_map.num_ghosts, 2 * gdim + 2))
        fem.assemble_vector(values.reshape(-1), compile_form(form))
        values = values[cells]
        F = values[:, 2 * gdim + 1]
        g_mean_sq = np.sum(values[:, gdim:2 * gdim] ** 2, axis=1) / F  # |∫_F g|² / |F|
        terms[cells, 0] += np.sum(values[:, :gdim] ** 2, axis=1) / F  # a cell is once in a layer
        h_F = diameters(msh, tdim - 1, facets)
        terms[cells, 1] += h_F * np.maximum(values[:, 2 * gdim] - g_mean_sq, 0.0)
    per_cell.scatter_reverse(versions.SCATTER_ADD)
    return terms[:n_owned, 0], terms[:n_owned, 1]
