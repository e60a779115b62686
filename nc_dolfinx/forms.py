"""The weak form (7) of the normal compliance problem, written once in UFL.

    a(u_h, v) + j_n(u_h, v) = L(v)   for all v in V_h,                                    (7)
    a(u, v)   = ∫_Ω σ(u) : ε(v),
    j_n(u, v) = ∫_Γ_C c_n (u_n − g_0)_+^{m_n} v_n,        (paper §2, with the optional gap g_0)
    L(v)      = ∫_Ω f·v + ∫_Γ_N g·v.

The Jacobian is the exact Gateaux derivative of the residual; for m_n = 1 the derivative of (·)_+ is the
Heaviside of the conditional, i.e. the generalized (semismooth Newton) Jacobian.
"""
from dataclasses import dataclass

import ufl

from .expressions import positive_part
from .problem import sigma

# Quadrature degree on Γ_C: the integrands contain (u_n − g_0)_+ whose kink may lie inside an edge.
CONTACT_QUADRATURE_DEGREE = 8


def normal_displacement(u, n):
    return ufl.dot(u, n)


def contact_pressure(u, fields, n=None):
    """p = c_n (u_n − g_0)_+^{m_n} = −σ_n(u) on Γ_C (law (4))."""
    n = ufl.FacetNormal(fields.domain.mesh) if n is None else n
    return fields.c_n * positive_part(normal_displacement(u, n) - fields.gap) ** fields.m_n


def contact_measure(fields, degree=CONTACT_QUADRATURE_DEGREE):
    return fields.ds_of("contact")(metadata={"quadrature_degree": degree})


@dataclass
class NonlinearForms:
    """The pieces of (7). The bulk form a is bilinear and constant, so the solver assembles it once and
    per Newton step only the Γ_C terms: F(u) = K u + j_n(u, ·) − λ L, J(u) = K + j_n'(u)."""
    a: ufl.Form            # a(du, v): the constant bulk stiffness
    L: ufl.Form            # L(v) at load factor 1
    j_n: ufl.Form          # j_n(u, v)
    j_n_jacobian: ufl.Form  # the Gateaux derivative of j_n(u, v) in u


def normal_compliance_forms(u, fields):
    """The forms of (7) on the space of ``u``: a, L, j_n and its Jacobian."""
    V = u.function_space
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    n = ufl.FacetNormal(fields.domain.mesh)
    a = ufl.inner(sigma(du, fields.lmbda, fields.mu), ufl.sym(ufl.grad(v))) * ufl.dx
    j_n = contact_pressure(u, fields, n) * normal_displacement(v, n) * contact_measure(fields)
    L = ufl.inner(fields.f, v) * ufl.dx
    for group_id, g in fields.g.items():
        L += ufl.inner(g, v) * fields.ds(group_id)
    return NonlinearForms(a, L, j_n, ufl.derivative(j_n, u, du))


def elastic_energy(u, fields):
    """½ a(u, u)."""
    return 0.5 * ufl.inner(sigma(u, fields.lmbda, fields.mu), ufl.sym(ufl.grad(u))) * ufl.dx


def energy(u, fields):
    """Π(u) = ½ a(u, u) − L(u) + ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1}: the convex, C¹ energy whose
    gradient is the residual of (7) (the solver's line search decreases it)."""
    n = ufl.FacetNormal(fields.domain.mesh)
    penetration = positive_part(normal_displacement(u, n) - fields.gap)
    load = ufl.inner(fields.f, u) * ufl.dx
    for group_id, g in fields.g.items():
        load += ufl.inner(g, u) * fields.ds(group_id)
    contact = fields.c_n / (fields.m_n + 1) * penetration ** (fields.m_n + 1) * contact_measure(fields)
    return elastic_energy(u, fields) - load + contact


def von_mises(u, fields):
    """Plane strain von Mises stress, with σ_zz = λ tr ε(u)."""
    s = sigma(u, fields.lmbda, fields.mu)
    s_zz = fields.lmbda * ufl.tr(ufl.sym(ufl.grad(u)))
    return ufl.sqrt(0.5 * ((s[0, 0] - s[1, 1]) ** 2 + (s[1, 1] - s_zz) ** 2 + (s_zz - s[0, 0]) ** 2)
                    + 3 * s[0, 1] ** 2)
