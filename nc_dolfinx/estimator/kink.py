"""η_4's integrand on a contact facet, split where u_hn − g_0 changes sign (Definition 5).

On a contact facet F the law residual c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h) has a kink where φ = u_hn − g_0
changes sign; in 3D that is a line across the face, and an unsplit Gauss rule converges slowly there
(measured: degree 24, 112 points per face, up to 3e-3 relative error in η_4K on random kinked
triangles). Instead F is cut along the zero set of φ_I, the affine interpolant of φ on F (φ itself when
g_0 is affine), into the sub-simplices S_j of {φ_I > 0} and {φ_I ≤ 0}, and

    ∫_F r²  =  Σ_j |S_j|/|F| ∫_F r(T_j(x))² dx,      T_j: F → S_j affine,

so the facet's own Gauss rule integrates, on each S_j, a function that is smooth there (a polynomial for
m_n = 1, polynomial c_n and affine g_0). Everything is written in UFL at the quadrature point and
needs no data beyond the cell: the cell's vertices V_k (``CellVertices``), the barycentric coordinates
λ_k(x) (the opposite vertex has λ_k = 0 on F, so it drops out of every map T_j(x) = Σ_k λ_k(x) T_j(V_k)),
φ at the vertices (u_h(V_k) = u_h(x) + ∇u_h (V_k − x) is exact for P1; g_0(V_k) by substituting V_k for
x), and c_n, g_0 at T_j(x) by the same substitution. The residual itself is evaluated exactly at T_j(x)
(with its (·)_+), so a non-affine g_0 is still integrated consistently, only with its kink near, not on,
the cut.

Pieces of the part of F spanned by a vertex set S (S = {φ > 0} or its complement C on F): with a the
first vertex of S and z_ak the zero of φ_I on the edge a–k, t_ak = φ_a / (φ_a − φ_k):
- piece 1 = F with every vertex k ∈ C moved to z_ak; |piece 1|/|F| = Π_{k ∈ C} t_ak (S = F: F itself);
- on a triangle with S = {a, b}, C = {c} (a quadrilateral), piece 2 = (z_ac, b, z_bc) with
  |piece 2|/|F| = (1 − t_ac) t_bc.
"""
import operator
from functools import reduce

import ufl

from ..physics.elasticity import normal_stress
from ..problem.expressions import positive_part

ON_FACET = 1e-8  # λ_k above this at a quadrature point: vertex k belongs to the facet (the opposite one has 0)


def _indicator(condition):
    return ufl.conditional(condition, 1.0, 0.0)


def _safe(denominator):
    """The denominator, or 1 where it is 0 (only in branches that the conditionals discard)."""
    return ufl.conditional(ufl.eq(denominator, 0), 1.0, denominator)


def _product(factors):
    return reduce(operator.mul, factors)


def law_residual_squared(u, fields, n):
    """(c_n (u_hn − g_0)_+^{m_n} + σ_n(u_h))², written so that its integral over a contact facet with the
    facet's quadrature rule is Σ_j over the pieces described in the module docstring."""
    msh = fields.domain.mesh
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    x = ufl.SpatialCoordinate(msh)
    corners = ufl.geometry.CellVertices(msh)
    V = [ufl.as_vector([corners[k, i] for i in range(gdim)]) for k in range(tdim + 1)]
    X = ufl.JacobianInverse(msh) * (x - V[0])
    lam = [1 - sum(X[i] for i in range(tdim))] + [X[i] for i in range(tdim)]
    grad_u = ufl.grad(u)
    sigma_n = normal_stress(fields.sigma(u), n)

    def at(expression, y):  # the expression (of x) evaluated at the point y
        return ufl.replace(ufl.as_ufl(expression), {x: y})

    def phi(y):
        return ufl.dot(u + grad_u * (y - x), n) - at(fields.gap, y)

    def residual_squared(y):
        return (at(fields.c_n, y) * positive_part(phi(y)) ** fields.m_n + sigma_n) ** 2

    phi_v = [phi(v) for v in V]
    on = [ufl.gt(lk, ON_FACET) for lk in lam]
    positive = [ufl.And(o, ufl.gt(p, 0)) for o, p in zip(on, phi_v)]
    rest = [ufl.And(o, ufl.le(p, 0)) for o, p in zip(on, phi_v)]
    integrand = 0
    for inside, outside in ((positive, rest), (rest, positive)):
        for weight, images in _pieces(inside, outside, V, phi_v):
            y = sum((lk * image for lk, image in zip(lam, images)), ufl.zero(gdim))
            integrand += ufl.conditional(ufl.gt(weight, 0), weight * residual_squared(y), 0.0)
    return integrand


def _pieces(inside, outside, V, phi_v):
    """[(|S_j|/|F|, images of the cell's vertices under T_j)] for the part of F spanned by the vertices
    ``inside`` (conditions per cell vertex; ``outside`` the other facet vertices)."""
    count = sum(_indicator(c) for c in inside)
    first, seen = [], 0
    for c in inside:  # the first vertex of the set, in local order
        first.append(_indicator(c) * (1 - seen))
        seen = seen + _indicator(c) * (1 - seen)
    a = sum((w * v for w, v in zip(first, V)), ufl.zero(len(V[0])))
    phi_a = sum(w * p for w, p in zip(first, phi_v))

    def t(phi_from, phi_to):  # fraction of the edge from → to where φ_I vanishes
        return phi_from / _safe(phi_from - phi_to)

    def zero_on_edge(p, phi_p, q, phi_q):
        return p + t(phi_p, phi_q) * (q - p)

    images = [ufl.conditional(c_out, zero_on_edge(a, phi_a, v, p), v) for c_out, v, p in zip(outside, V, phi_v)]
    ratio = _product([ufl.conditional(c_out, t(phi_a, p), 1.0) for c_out, p in zip(outside, phi_v)])
    pieces = [(ufl.conditional(ufl.gt(count, 0.5), ratio, 0.0), images)]
    if len(V) > 3:  # triangular facets: {a, b} ∪ {c} needs a second triangle for its quadrilateral
        second = [_indicator(c) * (1 - w) for c, w in zip(inside, first)]
        b = sum((w * v for w, v in zip(second, V)), ufl.zero(len(V[0])))
        phi_b = sum(w * p for w, p in zip(second, phi_v))
        out = [_indicator(c) for c in outside]
        c_point = sum((w * v for w, v in zip(out, V)), ufl.zero(len(V[0])))
        phi_c = sum(w * p for w, p in zip(out, phi_v))
        z_ac, z_bc = zero_on_edge(a, phi_a, c_point, phi_c), zero_on_edge(b, phi_b, c_point, phi_c)
        images = [ufl.conditional(c_out, z_bc, ufl.conditional(ufl.gt(w, 0.5), z_ac, v))
                  for c_out, w, v in zip(outside, first, V)]
        ratio = (1 - t(phi_a, phi_c)) * t(phi_b, phi_c)
        two_and_one = ufl.And(ufl.gt(count, 1.5), ufl.lt(count, 2.5))
        pieces.append((ufl.conditional(two_and_one, ratio, 0.0), images))
    return pieces
