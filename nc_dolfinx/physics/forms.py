"""The weak form (7) of the normal compliance problem, written once in UFL for 2D and 3D.

    a(u_h, v) + j_n(u_h, v) = L(v)   for all v in V_h,                                    (7)
    a(u, v)   = ∫_Ω σ(u) : ε(v),
    j_n(u, v) = ∫_Γ_C c_n (u_n − g_0)_+^{m_n} v_n,        (paper §2, with the optional gap g_0)
    L(v)      = ∫_Ω f·v + ∫_Γ_N g·v.

(7) is the optimality condition of the convex, C¹ energy
    Π(u) = ½ a(u, u) − L(u) + ∫_Γ_C c_n/(m_n + 1) (u_n − g_0)_+^{m_n+1},
which the solver gives SNES as its objective. The Jacobian is the exact Gateaux derivative of the
residual; for m_n = 1 the derivative of (·)_+ is the Heaviside of the conditional, i.e. the generalized
(semismooth Newton) Jacobian.
"""
from dataclasses import dataclass

import ufl

from ..problem.expressions import positive_part
from . import elasticity, friction

# Quadrature degree on Γ_C: the integrands contain (u_n − g_0)_+ whose kink may lie inside a facet.
CONTACT_QUADRATURE_DEGREE = 8


def normal_displacement(u, n):
    return ufl.dot(u, n)


def penetration(u, fields, n=None):
    """(u_n − g_0)_+ on Γ_C: how far u moves the boundary into the foundation beyond the gap g_0 (law (4));
    ``n`` the unit normal (default: the facet normal)."""
    n = ufl.FacetNormal(fields.domain.mesh) if n is None else n
    return positive_part(normal_displacement(u, n) - fields.gap)


def contact_pressure(u, fields, n=None, c_n=None):
    """p = c_n (u_n − g_0)_+^{m_n} = −σ_n(u) on Γ_C (law (4)); ``c_n``: another coefficient than the
    problem's (the solver's continuation in c_n)."""
    return (fields.c_n if c_n is None else c_n) * penetration(u, fields, n) ** fields.m_n


def contact_measure(fields, degree=CONTACT_QUADRATURE_DEGREE):
    """The measure of Γ_C, where j_n of (7) is integrated, with a Gauss rule of ``degree`` (high: the
    integrands hold (u_n − g_0)_+, whose kink may lie inside a facet)."""
    return fields.ds_of("contact")(metadata={"quadrature_degree": degree})


def law_measure(fields):
    """The measure of Γ_C with which the friction law is integrated: the vertex rule (the trapezoidal rule
    on a 2D facet, the vertices of a 3D facet with a third of its area each), so that the law is evaluated
    at the vertices of Γ_C only. Why: there every quantity the law needs is a nodal value (u, u_prev, the
    vertex normal N, the memory σ_t,prev, all P1), so the traction carried from one load state to the next
    (:mod:`.slip_state`) and the stick/slip state written for output are the law's own, not projections of
    it (issue 50: lumped projections of a law solved at Gauss points reported stuck vertices as slipping).
    Its weights make j_t(u, φ_i) = −m_i σ_t(x_i)·φ_i, m_i = ∫_Γ_C φ_i (a lumped, first order rule; the
    normal law j_n keeps its Gauss rule, :func:`contact_measure`)."""
    points, weights = VERTEX_RULES[fields.dim]
    return fields.ds_of("contact")(metadata={"quadrature_rule": "custom", "quadrature_degree": 1,
                                             "quadrature_points": points, "quadrature_weights": weights})


# The vertex rule on the reference facet (an interval in 2D, a triangle in 3D), by dimension. Written out as a
# custom rule: FFCx 0.5's "vertex" scheme takes the cell's vertices for a facet integral (an assertion).
# (tuples: UFL hashes the metadata of a measure, and would turn arrays into their str())
VERTEX_RULES = {2: (((0.0,), (1.0,)), (0.5, 0.5)),
                3: (((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)), (1.0 / 6.0,) * 3)}


def law_penetration(u, fields, normal):
    """(u·N − g̃_0)_+, the penetration that gives the friction law its bound F and slip length ε at the
    vertices of Γ_C: with the vertex normal N (``normal``, :func:`.friction.vertex_normal`) instead of the
    facet normal ν, which jumps at a vertex of a curved Γ_C, so that at a vertex the law has one value for
    all the facets around it (on a flat Γ_C, N = ν), and with the gap g̃_0 of :func:`vertex_gap`."""
    return positive_part(normal_displacement(u, normal) - vertex_gap(fields))


def vertex_gap(fields):
    """g̃_0 = I g_0 − (∫_Γ_C (I g_0 − g_0) φ_i / ∫_Γ_C φ_i): the gap the friction law sees at the vertices
    (P1, made once per mesh; I the P1 interpolant). Why not g_0(x_i) = I g_0 alone: the Gauss rule of the
    normal law (7) sees the exact g_0 inside each facet, below its interpolant on a convex gap by about
    h²/(8R) (R its radius of curvature), and the discrete u_h fits the pressure to that: its penetration at
    the vertices is that much below the facet's mean, which under a stiff foundation is of the penetration's
    own size (cattaneo3d, c_n = 1e3 E, h = R/100: Σ_i m_i μ c_n (u·N − g_0)_+(x_i) = 0.77 μP). g̃_0 takes
    the lumped interpolation error off the gap, so that the vertex penetration is the lumped one of the
    normal law where u_n curves like g_0 (in contact), and Σ_i m_i (u·N − g̃_0)_i = ∫ (I(u·N) − g_0)."""
    law = fields.friction
    if law.gap is None:
        from .quantities import contact_projection  # (quantities imports this module)
        from .friction import at_vertices
        interpolant = at_vertices(fields.gap, law)
        law.gap = contact_projection(interpolant - fields.gap, fields, "vertex_gap")
        law.gap.x.array[:] = interpolant.x.array - law.gap.x.array
    return law.gap


@dataclass
class NonlinearForms:
    """The pieces of (7). The bulk form a is bilinear and constant, so the solver assembles it once and
    per Newton step only the Γ_C terms: F(u) = K u + j_n(u, ·) − λ L, J(u) = K + j_n'(u)."""
    a: ufl.Form            # a(du, v): the constant bulk stiffness
    L: ufl.Form            # L(v) at load factor 1
    j_n: ufl.Form          # j_n(u, v)
    j_n_jacobian: ufl.Form  # the Gateaux derivative of j_n(u, v) in u
    contact_energy: ufl.Form  # ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1}: Π(u) = ½uᵀKu − Lᵀu + this
    # For m_n = 1 (else None), the law with all of Γ_C in contact, c_n (u_n − g_0) without (·)_+, for the
    # solver's bilateral predictor: its Jacobian ∫ c_n du_n v_n and its constant part −∫ c_n g_0 v_n
    bilateral_jacobian: ufl.Form = None
    gap_load: ufl.Form = None     # ∫_Γ_C c_n g_0 v_n
    separation: ufl.Form = None   # ∫_Γ_C (g_0 − u_n)_+: zero iff u closes the gap everywhere on Γ_C
    # For the solver's continuation in c_n: ∫_Γ_C c_n du_n v_n (c_n's size against the body's stiffness),
    # and these forms again with c_n replaced by scale·c_n (``scale`` a fem.Constant)
    c_n_mass: ufl.Form = None
    with_c_n_scale: object = None
    # With friction (fields.friction, :mod:`.friction`): j_t(u, v) = −∫_Γ_C σ_t(u)·v_t with the bound F(ū),
    # ε(ū) of the iterate ``frozen`` ū, the derivative of ∫_Γ_C F̄ ψ_ε̄(Δu_t) (added to contact_energy), and
    # the law's state at the previous load state (Δu_t = (u − u_prev)_t, :mod:`.slip_state`). The solver
    # moves ū to u until they agree (the fixed point), and the state on between its load increments.
    j_t: ufl.Form = None
    j_t_jacobian: ufl.Form = None
    frozen: object = None
    previous: object = None  # u at the previous load state (Δu = u − previous)
    epsilon: object = None  # the regularisation's ε_r (a Constant: the solver's continuation sets it)
    # The consistent Jacobian of the Γ_C residual, the bound F(u), ε(u) of u itself (ū = u): not symmetric
    consistent_jacobian: ufl.Form = None
    # Added to j_t_jacobian on some of the passes' Newton steps (friction.slip_stiffening, newton._newton_jacobian)
    slip_stiffening: ufl.Form = None
    # A term of (7) that is not a UFL form: contact between two bodies ([[pairs]], nc_dolfinx.pairs.coupling),
    # with widen(K, bcs), add_residual(vector), add_jacobian(matrix, kind), energy() at the current u
    operator_term: object = None

    @property
    def contact_residual(self):
        """The Γ_C part of the residual of (7): j_n(u, v), plus j_t(u, v) with friction."""
        return self.j_n if self.j_t is None else self.j_n + self.j_t

    @property
    def contact_jacobian(self):
        """Its Gateaux derivative in u; with friction that of the frozen bound's problem (symmetric)."""
        return self.j_n_jacobian if self.j_t is None else self.j_n_jacobian + self.j_t_jacobian


def normal_compliance_forms(u, fields, c_n_scale=None, operator_term=None):
    """The forms of (7) on the space of ``u``: a, L, j_n, its Jacobian and the contact part of Π
    (``c_n_scale``: a fem.Constant s, the law's coefficient then s·c_n); with [[pairs]], the pairs' term
    (``operator_term``: one already made for this u, else made here: :class:`~nc_dolfinx.pairs.coupling.PairCoupling`)."""
    V = u.function_space
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    n = ufl.FacetNormal(fields.domain.mesh)
    c_n = fields.c_n if c_n_scale is None else c_n_scale * fields.c_n
    a = ufl.inner(fields.sigma(du), elasticity.strain(v)) * ufl.dx
    dC = contact_measure(fields)
    j_n = contact_pressure(u, fields, n, c_n) * normal_displacement(v, n) * dC
    L = ufl.inner(fields.f, v) * ufl.dx
    for group_id, g in fields.g.items():
        L += ufl.inner(g, v) * fields.ds(group_id)
    m = fields.m_n
    contact_energy = c_n / (m + 1) * penetration(u, fields, n) ** (m + 1) * dC
    pieces = NonlinearForms(a, L, j_n, ufl.derivative(j_n, u, du), contact_energy)
    if fields.friction is not None:  # the frozen bound's inner problem (see physics.friction)
        law, dL = fields.friction, law_measure(fields)  # (the law at the vertices of Γ_C: law_measure)
        bound = law_penetration(law.frozen, fields, law.normal)
        frictional_energy = friction.dissipation(u, bound, law) * dL
        pieces.contact_energy = pieces.contact_energy + frictional_energy
        pieces.j_t = ufl.derivative(frictional_energy, u, v)
        pieces.j_t_jacobian = ufl.derivative(pieces.j_t, u, du)
        pieces.slip_stiffening = friction.slip_stiffening(u, du, v, bound, law) * dL
        pieces.frozen, pieces.previous, pieces.epsilon = law.frozen, law.previous, law.epsilon
        consistent = ufl.replace(pieces.contact_residual, {law.frozen: u})
        pieces.consistent_jacobian = ufl.derivative(consistent, u, du)
    mass = c_n * normal_displacement(du, n) * normal_displacement(v, n) * dC
    # (the law is linear where in contact: see NonlinearForms. Not with friction: the creeping check these forms
    # enable took the stick zone's creeping for the contact zone's, 121 Newton steps instead of 65 on 1e4-1-mu0.3
    # of benchmarks/family.py)
    if fields.pairs:
        pieces.operator_term = operator_term or fields.pair_coupling(u)
    if float(m.value) == 1.0 and pieces.j_t is None and not fields.pairs:  # (the bilateral predictor: the foundation's)
        pieces.bilateral_jacobian = mass
        pieces.gap_load = c_n * fields.gap * normal_displacement(v, n) * dC
        pieces.separation = positive_part(fields.gap - normal_displacement(u, n)) * dC
    pieces.c_n_mass = mass
    pieces.with_c_n_scale = lambda scale: normal_compliance_forms(u, fields, scale, pieces.operator_term)
    return pieces


def energy(u, fields):
    """Π(u) = ½ a(u, u) − L(u) + ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1}: the convex, C¹ energy whose
    gradient is the residual of (7) (the solver's line search decreases it)."""
    pieces = normal_compliance_forms(u, fields)
    return elastic_energy(u, fields) - ufl.replace(pieces.L, {ufl.TestFunction(u.function_space): u}) \
        + pieces.contact_energy


def elastic_energy(u, fields):
    """½ a(u, u)."""
    return 0.5 * ufl.inner(fields.sigma(u), elasticity.strain(u)) * ufl.dx
