"""Coulomb friction with normal compliance on Γ_C (Martins & Oden 1987; Klarbring, Mikelić & Shillor 1988),
regularised, in UFL for 2D and 3D.

On Γ_C, with the pressure p = c_n (u_n − g_0)_+^{m_n} of the law (4) and the slip increment Δu_t over the
load increment (the tangential part of u − u_prev, u_prev the previous load state), Coulomb's law with
normal compliance reads

    |σ_t| ≤ F,   F = c_t (u_n − g_0)_+^{m_t}            (Coulomb: c_t = μ c_n, m_t = m_n, F = μ p)
    σ_t = −F Δu_t / |Δu_t|   where the body slips (Δu_t ≠ 0),   |σ_t| < F where it sticks (Δu_t = 0).

The regularisation solved here is the tangential penalty (an elastic pre-slip, as in Wriggers' and
Laursen's books):

    σ_t = −F Δu_t / max(|Δu_t|, ε),   ε = ε_r (u_n − g_0)_+,   ε_r = ``contact.slip_regularisation``:

a stiff tangential spring F/ε where |Δu_t| < ε (stick), Coulomb's law itself beyond (slip). Why this one:
it is piecewise smooth with one kink, like (·)_+ in the normal law, and it is the gradient in Δu_t of the
convex Huber function F ψ_ε(Δu_t), ψ_ε(s) = |s|²/(2ε) (|s| ≤ ε), |s| − ε/2 (beyond); the smooth
alternative F Δu_t/(|Δu_t|² + ε²)^{1/2} is a sigmoid on which Newton overshoots. Why ε ∝ (u_n − g_0)_+: the
stick spring F/ε = c_t (u_n − g_0)_+^{m_t − 1}/ε_r then stands to the normal one, c_n m_n (u_n −
g_0)_+^{m_n − 1}, as μ/(ε_r m_n) in Coulomb's case, whatever the units, loads or foundation: ε_r is a
dimensionless pre-slip (in units of the penetration) and one default serves every problem; as ε_r → 0 the
law tends to Coulomb's.

The spring remembers the traction it carried: the law is applied to s = Δu_t − (ε/F) σ_t,prev, this
increment's slip plus the stretch that carries the previous load state's traction σ_t,prev
(:func:`spring_slip`; the return map of elastoplasticity moves σ_t,prev on, :mod:`.slip_state`), so that a
stuck point keeps its traction from one increment to the next instead of stretching its spring anew (a
stuck, loaded point then crept by up to ε an increment).

How it is solved: a fixed point on the friction bound (the scheme behind the existence proofs of Klarbring,
Mikelić & Shillor and of Andersson). With F̄ = F(ū), ε̄ = ε(ū) frozen at an iterate ū, the increment minimises
the convex, C¹ energy

    Π(u) + ∫_Γ_C F̄ ψ_ε̄(Δu_t(u)),

whose gradient is (7) plus j_t(u, v) = −∫_Γ_C σ_t(u) · v_t with the frozen bound: the solver of (7) (SPD
Jacobian, energy line search) solves it unchanged; then ū = u and again. It contracts for small enough μ
(the uniqueness condition of those proofs); the first pass from u = 0 is the frictionless solve (F̄ = 0).
Once a pass is near the solution, Newton's method on the full residual (the bound of u itself, the
consistent and non-symmetric Jacobian) finishes the increment (:mod:`nc_dolfinx.solver.fixed_point`).

Where the law is evaluated: at the vertices of Γ_C (the vertex rule, :func:`~.forms.law_measure`), with the
bound and slip length of (u·N − g̃_0)_+ (:func:`~.forms.law_penetration`: the vertex normal N, and the gap
g̃_0 that the vertex rule must see, :func:`~.forms.vertex_gap`). Every quantity the law needs is
then a nodal value of a P1 function, so the memory σ_t,prev is a P1 function that holds the law's traction
exactly where the law is evaluated (:mod:`.slip_state`), and the stick/slip state reported at a vertex is the
law's own test there (:func:`slipping`, :func:`at_vertices`). j_t(u, φ_i) = −m_i σ_t(x_i)·(φ_i)_t with
m_i = ∫_Γ_C φ_i: a lumped traction, as in node-to-surface contact.

The tangential direction. Δu_t and the test function's v_t are projections on the plane normal to N, the
normalised P1 average of the facet normals of Γ_C at each vertex (:func:`vertex_normal`). With the facet
normal ν itself, which jumps at every vertex of a curved P1 boundary, a vertex shared by two facets would
have to stick in both facets' tangent planes, i.e. in every direction: as ε_r → 0 the stick zone of a
curved Γ_C locks its vertices (normal included). N is continuous, so a vertex sticks in one plane only.
On a flat Γ_C, N = ν. The normal law keeps ν (μ = 0 is the frictionless problem exactly).
"""
from dataclasses import dataclass

import numpy as np
import ufl
from petsc4py import PETSc

from dolfinx import fem
import dolfinx.fem.petsc as fem_petsc

from .. import dolfinx_versions as versions


@dataclass
class FrictionLaw:
    """The friction law's data on one mesh: F = c_t (u_n − g_0)_+^{m_t} (UFL, a Constant), the regularisation
    ε_r (a Constant), and four P1 vector functions: ``previous`` u at the previous load state (Δu = u −
    previous), ``frozen`` the iterate ū whose bound F(ū), ε(ū) the solver's inner problem uses, ``normal``
    N (:func:`vertex_normal`) and ``previous_traction`` σ_t at the previous load state (:func:`spring_slip`);
    ``key`` the problem's key that gives the bound (for messages)."""
    c_t: object
    m_t: object
    epsilon: object
    previous: fem.Function
    frozen: fem.Function
    normal: fem.Function
    previous_traction: fem.Function  # σ_t at the previous load state (see spring_slip)
    key: str = "contact.friction"
    gap: fem.Function = None  # g̃_0, the gap at the vertices of Γ_C (forms.vertex_gap makes it when first needed)


def tangential(w, N):
    """The part of a vector w normal to N (the tangent plane of Γ_C at each point)."""
    return w - ufl.dot(w, N) * N


def slip_increment(u, friction):
    """Δu_t = (u − u_prev)_t, the tangential displacement's increment over the load increment, on the plane
    normal to the vertex normal N: the slip of Coulomb's law on Γ_C, beside the penetration of law (4)."""
    return tangential(u - friction.previous, friction.normal)


def spring_slip(u, penetration, friction):
    """s = Δu_t − (ε/F) σ_t,prev: the slip the regularised law sees, this increment's slip Δu_t
    (:func:`slip_increment`) plus the stretch of this increment's spring F/ε that carries the previous load
    state's traction σ_t,prev (``previous_traction``): the traction is the law's memory, not the stretch, so
    that a friction coefficient switched on, or a pressure that changes F/ε, leaves the traction where it
    was. No stretch where F = 0 (``penetration``: (u_n − g_0)_+ of the bound's displacement)."""
    bound = friction_bound(penetration, friction)
    compliance = ufl.conditional(ufl.le(bound, 0), 0, friction.epsilon * penetration / bound)
    return slip_increment(u, friction) - compliance * friction.previous_traction


def slipping(u, penetration, friction):
    """The law's own test: 1 where the spring's slip exceeds its slip length, |s| > ε = ε_r (u_n − g_0)_+
    (:func:`spring_slip`: there |σ_t| = F, Coulomb's slip), 0 where it does not (stick: |σ_t| = F|s|/ε ≤ F)
    or out of contact. The output's stick/slip state and the stick and slip areas are this expression at
    the vertices of Γ_C, where the law is evaluated (``penetration``: the law's, (u·N − g̃_0)_+)."""
    slip = spring_slip(u, penetration, friction)
    beyond = ufl.conditional(ufl.gt(ufl.dot(slip, slip), (friction.epsilon * penetration) ** 2), 1.0, 0.0)
    return ufl.conditional(ufl.gt(penetration, 0), beyond, 0.0)


def at_vertices(expr, friction, name=None):
    """A UFL quantity of the law (built of P1 functions and x, no facet normal) evaluated at the vertices of
    Γ_C: a P1 Function (scalar or of ``expr``'s shape, on the law's mesh) with those values, 0 at every
    other vertex (where the vertex normal N vanishes). Its nodal values are the law's where the law is
    evaluated (:func:`~.forms.law_measure`): not a projection."""
    msh = friction.normal.function_space.mesh
    space = versions.p1_space(msh, expr.ufl_shape)
    out = fem.Function(space, name=name) if name else fem.Function(space)
    out.interpolate(fem.Expression(expr, versions.interpolation_points(space)))
    values = out.x.array.reshape(-1, int(np.prod(expr.ufl_shape, dtype=int)))
    values[~on_contact(friction)] = 0.0
    return out


def on_contact(friction):
    """Which vertices (P1 dofs, ghosts included) lie on Γ_C: those where the vertex normal N is set."""
    N = friction.normal
    return np.any(N.x.array.reshape(-1, N.function_space.dofmap.index_map_bs) != 0, axis=1)


def friction_bound(penetration, friction):
    """F = c_t (u_n − g_0)_+^{m_t} (``penetration``: (u_n − g_0)_+)."""
    return friction.c_t * penetration ** friction.m_t


def tangential_traction(u, penetration, friction):
    """σ_t = −F Δu_t / max(‖Δu_t‖, ε_r (u_n − g_0)_+) of the regularised Coulomb law, F = c_t (u_n − g_0)_+^{m_t}
    (μ times the pressure of law (4) in Coulomb's case), 0 out of contact
    (``penetration``: (u_n − g_0)_+ of the displacement whose bound is used), Δu_t here the spring's slip
    s (:func:`spring_slip`). A conditional guards the points out of contact, where the other branch would be
    0/0."""
    slip = spring_slip(u, penetration, friction)
    size = ufl.max_value(ufl.sqrt(ufl.dot(slip, slip)), friction.epsilon * penetration)
    return -ufl.conditional(ufl.le(penetration, 0), 0, friction_bound(penetration, friction) / size) * slip


# The stiffening's factor κ (see slip_stiffening). Newton steps of the cold solve / of the nested level summed
# over benchmarks/family.py's nine 2D friction members at 128 cells, the stiffened Jacobian on every step of
# the passes: κ = 0 (the exact Hessian) 213 / 55, 0.1 183 / 49, 0.3 162 / 43, 1 170 / 55; κ = 3 needed 530
# steps on 1e4-1-mu0.3 and failed (the slip then converges linearly, at a rate that grows with κ).
SLIP_STIFFENING = 0.3


def slip_stiffening(u, du, v, penetration, friction):
    """κ F ε/|s|⁴ (s·du_t)(s·v_t) where the body slips (|s| > ε), 0 elsewhere (s the spring's slip,
    :func:`spring_slip`; κ = SLIP_STIFFENING; ``penetration``: the frozen bound's): a stiffness along the
    slip that the solver's passes add to the exact Hessian of ∫ F ψ_ε(s) (:func:`dissipation`) on a pass's
    first Newton step and after a step the line search cut
    (:meth:`~nc_dolfinx.solver.newton.NonlinearSolver._newton_jacobian`).

    That Hessian, F/|s| times the projection across the slip, has no stiffness along it (none at all in
    2D): Newton's linear model lets a slipping point move along its slip at a constant traction, also back
    through zero, where the law turns it into a stiff stick spring F/ε, so the energy line search cut the
    step to λ ~ ε (4e-6 at ε_r = 1e-3) and every pass of the ε-continuation began with 5–6 such creeping
    steps (benchmarks/family.py, 1e4-1-mu0.3: 49 Newton steps, 38 preconditioner set-ups from a cold
    start). The added stiffness is F/ε at the kink (the stick spring's: the Jacobian is continuous across
    it) and falls like ε/|s|² into the slip zone, so that far into it the step is Newton's own (at a slip of
    10ε: 1/300 of the stick spring). The Jacobian stays SPD, so the step remains a descent direction of the
    frozen problem's energy; the residual, and the solution, are unchanged (25 Newton steps, 16 set-ups on
    that member)."""
    slip = spring_slip(u, penetration, friction)
    squared, length = ufl.dot(slip, slip), friction.epsilon * penetration
    along = ufl.dot(slip, tangential(du, friction.normal)) * ufl.dot(slip, tangential(v, friction.normal))
    stiffness = SLIP_STIFFENING * friction_bound(penetration, friction) * length / squared ** 2
    # (le, not gt: closed_jacobian closes the kinks written as gt, which would take 0/0 at |s| = ε = 0)
    return ufl.conditional(ufl.le(squared, length ** 2), 0, stiffness) * along


def dissipation(u, penetration, friction):
    """F ψ_ε(Δu_t), ψ_ε(s) = |s|²/(2ε) for |s| ≤ ε, |s| − ε/2 beyond (ε = ε_r (u_n − g_0)_+): for a given
    ``penetration`` (the frozen bound's) a convex, C¹ function of u whose derivative along v is
    −σ_t · v_t (:func:`tangential_traction`; Δu_t: the spring's slip s)."""
    slip = spring_slip(u, penetration, friction)
    squared, length = ufl.dot(slip, slip), friction.epsilon * penetration
    huber = ufl.conditional(ufl.le(squared, length ** 2), squared / (2 * length), ufl.sqrt(squared) - length / 2)
    return ufl.conditional(ufl.le(penetration, 0), 0, friction_bound(penetration, friction) * huber)


def vertex_normal(V, ds_contact):
    """N: at each vertex of Γ_C the normalised ∫_Γ_C ν φ_i (the facet normals averaged with the weights of
    the P1 hat function), 0 elsewhere; a P1 function of the vector space V."""
    N = fem.Function(V)
    vec = versions.petsc_vec(N)
    fem_petsc.assemble_vector(vec, fem.form(ufl.inner(ufl.FacetNormal(V.mesh), ufl.TestFunction(V)) * ds_contact))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    bs = V.dofmap.index_map_bs
    owned = N.x.array[:V.dofmap.index_map.size_local * bs].reshape(-1, bs)
    lengths = np.linalg.norm(owned, axis=1)
    on_contact = lengths > 0
    owned[on_contact] /= lengths[on_contact, None]
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return N
