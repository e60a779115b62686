"""The material law and the stress quantities of the model (paper §2), for any dimension.

Isotropic linear elasticity σ(u) = 2μ ε(u) + λ tr ε(u) I. On a 2D mesh this is plane strain (ε_zz = 0),
so the out-of-plane stress σ_zz = λ tr ε(u) is not zero: :func:`stress_3x3` and :func:`von_mises` include it.
On Γ_C with outward unit normal ν: σ_n = σν·ν and the tangential stress vector σ_t = σν − σ_n ν
(in 2D its only component is σν·t with t = (−ν_2, ν_1), the paper's σ_t).
"""
import ufl


def lame(E, nu):
    """Lamé coefficients (λ, μ) of Hooke's law (§2) from Young's modulus E and Poisson's ratio ν:
    λ = Eν / ((1 + ν)(1 − 2ν)), μ = E / (2(1 + ν)) (plane strain and 3D alike). Numbers, Constants or
    UFL expressions."""
    return E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))


def strain(u):
    """ε(u) = sym ∇u."""
    return ufl.sym(ufl.grad(u))


def sigma(u, lmbda, mu):
    """Hooke's law σ(u) = 2μ ε(u) + λ tr ε(u) I (paper §2, isotropic a_ijhk) as a UFL expression, in the
    dimension of ``u`` (2D: plane strain)."""
    eps = strain(u)
    return 2 * mu * eps + lmbda * ufl.tr(eps) * ufl.Identity(len(u))


def stress_3x3(u, lmbda, mu):
    """The full 3×3 stress tensor; in 2D (plane strain) with σ_zz = λ tr ε(u) and σ_xz = σ_yz = 0."""
    s = sigma(u, lmbda, mu)
    if len(u) == 3:
        return s
    s_zz = lmbda * ufl.tr(strain(u))
    return ufl.as_matrix([[s[0, 0], s[0, 1], 0], [s[1, 0], s[1, 1], 0], [0, 0, s_zz]])


def von_mises(u, lmbda, mu):
    """von Mises stress sqrt(3/2 dev σ : dev σ) of the full (3×3) stress."""
    s = stress_3x3(u, lmbda, mu)
    dev = s - ufl.tr(s) / 3 * ufl.Identity(3)
    return ufl.sqrt(1.5 * ufl.inner(dev, dev))


def normal_stress(s, n):
    """σ_n = σν·ν, the normal stress of the law (4), for a stress ``s`` and a unit normal ``n``
    (e.g. ``ufl.FacetNormal(mesh)``)."""
    return ufl.dot(s * n, n)


def tangential_stress(s, n):
    """σ_t = σν − σ_n ν (a vector tangent to the boundary)."""
    traction = s * n
    return traction - ufl.dot(traction, n) * n
