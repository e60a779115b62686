"""A body that only the foundation holds along some rigid motions: its cold start, decided before Newton.

Where the supports (Dirichlet components, symmetry planes) leave rigid motions free (:mod:`nc_dolfinx.
physics.rigid`), only the foundation can hold them, and only once pressed: at u = 0 with g_0 ≥ 0 the law
c_n (u_n − g_0)_+^{m_n} has no stiffness, so the Jacobian of (7) is singular along those motions and
Newton has no first step. :func:`settle` lets the body settle *rigidly* onto the foundation first: with
the free motions ρ_1 … ρ_m as P1 functions (exact: a rigid motion is linear) it minimises the energy Π of
(7) over u_0 + Σ a_j ρ_j. Since a(·, ρ) = 0 for a rigid ρ, along them

    E(a) = ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1} − λ L(Σ a_j ρ_j),     u = u_0 + Σ a_j ρ_j,

is convex, with gradient g_j = j_n(u, ρ_j) − λ L(ρ_j) (the residual of (7) along ρ_j) and Hessian
H_jk = j_n'(u)(ρ_k, ρ_j). Three outcomes are refused, each naming the motions, before any Newton step:
- the foundation does not move under them (∫_Γ_C c_n (ρ·ν)² = 0: sliding along a frictionless foundation,
  or c_n = 0 where they move it): nothing holds them;
- E decreases without bound along them (the loads pull the body off the foundation);
- at the minimum H is singular along them (nothing presses the body onto the foundation: its position
  along them is not determined, e.g. a body loaded by nothing but a prescribed displacement).
Otherwise the settled u_0 + Σ a_j ρ_j, where the foundation has its stiffness, is Newton's initial guess.

With friction (:mod:`nc_dolfinx.physics.friction`) the motions the foundation does not move normally — the
tangential ones τ, sliding along Γ_C — are held by the friction of the pressed contact: the stick spring
F/ε of the regularised law. They are not settled but kept at zero amplitude (u_0 is the previous load
state: the body sticks where it was, Δu_t = 0 along them); only the others are, chosen to slide as little
as possible along Γ_C (each made orthogonal to the τ in ∫_Γ_C ρ_t·τ_t, e.g. a rotation about the contact
zone's middle instead of the body's), so that what settles is the normal part. Then, at the settled u,
friction holds the τ only if ∫_Γ_C F (ρ_t·ρ_t) > 0 along each (F = c_t (u_n − g_0)_+^{m_t}, the bound that
the solver's first pass freezes: without it the first Jacobian is singular along them), and three more
outcomes are refused:
- nothing presses the body where they slide it (∫_Γ_C (u_n − g_0)_+ |ρ_t|² = 0);
- the friction bound is zero where it is pressed (μ = 0 there, or c_t = 0);
- the loads pull the body along them harder than friction holds it (:func:`_check_friction_limit`).
"""
import copy

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx.fem.petsc as fem_petsc
from dolfinx import fem

from ..errors import InputError
from ..physics import forms as nc_forms, friction, rigid

SETTLED = 1e-3    # |g| at most this fraction of |λ L(ρ)|: settled enough for Newton to take over
FARTHEST = 1e3    # a move of this many body sizes with E still decreasing: the loads pull the body off
MAX_STEPS = 50
HOLD = "hold it with mesh.dirichlet components (loads.u_D) or mesh.symmetry planes"


def settle(u, fields, load_factor=1.0):
    """Move ``u`` (in place) by the rigid motions in ``fields.free_motions`` to where the foundation holds
    ``load_factor`` times the loads (see the module's docstring); returns their amplitudes (with friction,
    zero along the motions friction holds). Raises :class:`InputError` naming the motions the foundation
    cannot hold."""
    along = _Motions(u, fields, load_factor)
    normal_stiffness = along.matrix(along.mass_action, np.zeros(along.count))
    if fields.friction is None:
        along.refuse("the foundation does not move under it (a frictionless foundation holds only what moves "
                     "it normally)", normal_stiffness)
        return _settle(along)
    sliding = rigid.null_space(normal_stiffness)  # (m, s): the motions only friction can hold
    if not sliding.shape[1]:
        return _settle(along)
    sliding_along = along.on(sliding)
    tangential = along.matrix(along.tangent_action, np.zeros(along.count))  # [∫_Γ_C ρ_j,t·ρ_k,t]
    sliding_along.refuse("the foundation does not move under it (it moves Γ_C neither normally nor "
                         "tangentially)", sliding.T @ tangential @ sliding)
    pressing = rigid.null_space(normal_stiffness, complement=True)
    # the normal part: each pressing motion minus its ∫_Γ_C ρ_t·τ_t-projection on the sliding ones
    pressing = pressing - sliding @ np.linalg.solve(sliding.T @ tangential @ sliding, sliding.T @ tangential @ pressing)
    a = _settle(along.on(pressing)) if pressing.shape[1] else np.zeros(0)
    sliding_along.refuse("nothing presses the body onto the foundation, whose friction would hold it",
                         sliding_along.matrix(sliding_along.pressed_action))
    sliding_along.refuse(f"its friction does not hold it ({fields.friction.key} = 0 where the body is pressed)",
                         sliding_along.matrix(sliding_along.friction_action))
    _check_friction_limit(sliding_along, fields.friction.key)
    return pressing @ a


def _check_friction_limit(along, key):
    """Refuse loads beyond what friction holds: along a sliding motion τ the first pass's energy (the bound
    F̄ of the settled u frozen) grows like t (∫_Γ_C F̄ |τ_t| − λ L(τ)) as the body slides by t τ, so it has no
    minimum if λ L(τ) > C(τ) = ∫_Γ_C F̄ |τ_t| for some τ. Searched as min C(τ) over λ L(τ) = 1 (convex; exact
    for one sliding motion, Nelder–Mead over the others' 1–2 amplitudes in 3D: on 16 loads of a 3D block,
    shear and twist, the ratio of a zoomed brute-force grid to 3 digits, also at 1.002 times the limit);
    a τ found with C(τ) < 1 is a witness, named in the error. (On a flat Γ_C, C of a translation is μ times
    the pressure's resultant, which the settling has already balanced with the normal load: Coulomb's limit
    of the exact problem.)"""
    load = along.load
    if np.linalg.norm(load) == 0.0:
        return
    base = load / (load @ load)  # λ L(base) = 1
    others = rigid.null_space(np.outer(load, load))  # λ L = 0 along them
    if others.shape[1]:
        from scipy import optimize  # here: importing it costs every run 0.06 s at start-up
        found = optimize.minimize(lambda z: along.capacity(base + others @ z), np.zeros(others.shape[1]),
                                  method="Nelder-Mead", options={"xatol": 1e-6 * np.linalg.norm(base), "fatol": 1e-9,
                                                                 "initial_simplex": _simplex(others.shape[1], base)})
        witness = base + others @ found.x
    else:
        witness = base
    capacity = along.capacity(witness)
    capacity = along.u.function_space.mesh.comm.bcast(capacity, root=0)  # one decision on every rank
    if capacity < 1.0:
        names = ", ".join(rigid.describe_all(rigid.readable(along.free @ witness[:, None]), along.centre, along.scale))
        raise InputError(f"the body is free to move: {names}; the loads pull it along the foundation with {_beyond_one(1 / capacity)} "
                         f"times the most its friction holds ({key} times the pressure): {HOLD}")


def _beyond_one(ratio):
    """A ratio above 1 with the digits that show it is above 1 (1.001, not 1)."""
    digits = 3 if ratio >= 1.01 else 2 + int(np.ceil(-np.log10(ratio - 1))) if ratio > 1 else 3
    return f"{ratio:.{min(digits, 12)}g}"


def _simplex(n, base):
    """Nelder–Mead's first simplex in n amplitudes: 0 and steps of |base| along each."""
    return np.vstack([np.zeros(n), np.linalg.norm(base) * np.eye(n)])


def _settle(along):
    """Minimise E along ``along``'s motions from zero amplitude; leave u at the minimum, return a."""
    a = np.zeros(along.count)
    target = SETTLED * np.linalg.norm(along.load)
    for _ in range(MAX_STEPS):
        g = along.gradient(a)
        if np.linalg.norm(g) <= target:
            break
        a = _line_minimum(along, a, *_descent(along, a, g))
    along.refuse("nothing presses the body onto the foundation", along.matrix(along.hessian_action, a))
    along.at(a)
    return a


class _Motions:
    """The free rigid motions as P1 functions, and (7) measured along them."""

    def __init__(self, u, fields, load_factor):
        self.u, V = u, u.function_space
        self.free, self.centre, self.scale = fields.free_motions
        self.count = self.free.shape[1]
        bs = V.dofmap.index_map_bs
        unit = rigid.rigid_motions((V.tabulate_dof_coordinates()[:, :bs] - self.centre) / self.scale)
        self.modes = np.einsum("nki,km->mni", unit, self.free).reshape(self.count, -1)  # (m, dofs)
        self.base = u.x.array.copy()
        self.n_owned = V.dofmap.index_map.size_local * bs
        pieces = nc_forms.normal_compliance_forms(u, fields)
        self.direction = fem.Function(V)
        self.j_n = fem.form(pieces.j_n)
        self.hessian_action = fem.form(ufl.action(pieces.j_n_jacobian, self.direction))
        self.mass_action = fem.form(ufl.action(pieces.c_n_mass, self.direction))
        self.load = load_factor * self._along(fem.form(pieces.L))
        if fields.friction is not None:  # [∫_Γ_C w ρ_j,t·ρ_k,t] for w = 1, (u·N − g̃_0)_+ and F
            # where and as the law is evaluated (the vertices of Γ_C): the limit checked is the law's own
            law, v, dC = fields.friction, ufl.TestFunction(V), nc_forms.law_measure(fields)
            slide = ufl.dot(friction.tangential(self.direction, law.normal), friction.tangential(v, law.normal))
            pressed = nc_forms.law_penetration(u, fields, law.normal)
            self.tangent_action, self.pressed_action, self.friction_action = (
                fem.form(weight * slide * dC) for weight in (1.0, pressed, friction.friction_bound(pressed, law)))
            sliding = friction.tangential(self.direction, law.normal)
            self.friction_capacity = fem.form(friction.friction_bound(pressed, law) * ufl.sqrt(ufl.dot(sliding, sliding)) * dC)

    def capacity(self, a):
        """∫_Γ_C F |ρ_t| at u as it is, ρ = Σ a_j ρ_j: the friction force's most work per unit of sliding along ρ."""
        self.direction.x.array[:] = a @ self.modes
        return self.u.function_space.mesh.comm.allreduce(fem.assemble_scalar(self.friction_capacity), MPI.SUM)

    def on(self, coefficients):
        """The same, along the motions Σ_j c_jl ρ_j (the columns of ``coefficients``, (m, l)): E, its
        gradient and the matrices then have the l amplitudes of those."""
        other = copy.copy(self)
        other.free, other.modes = self.free @ coefficients, coefficients.T @ self.modes
        other.load, other.count = coefficients.T @ self.load, coefficients.shape[1]
        return other

    def _along(self, vector_form):
        """[F(ρ_j)] for an assembled vector form F: its owned entries against each motion, over all ranks."""
        vec = fem_petsc.assemble_vector(vector_form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        local = self.modes[:, :self.n_owned] @ vec.array[:self.n_owned]
        vec.destroy()
        return self.u.function_space.mesh.comm.allreduce(local, MPI.SUM)

    def at(self, a):
        """u = u_0 + Σ a_j ρ_j."""
        self.u.x.array[:] = self.base + a @ self.modes
        return self

    def gradient(self, a):
        return self.at(a)._along(self.j_n) - self.load

    def matrix(self, action, a=None):
        """[ρ_jᵀ A ρ_k] at a (None: at u as it is), for the operator A whose action on ``self.direction`` is
        the form ``action``."""
        if a is not None:
            self.at(a)
        columns = []
        for mode in self.modes:
            self.direction.x.array[:] = mode
            columns.append(self._along(action))
        return np.array(columns)

    def largest_move(self, d):
        """The largest nodal displacement of the motion Σ d_j ρ_j (the same on every rank)."""
        local = np.max(np.abs(d @ self.modes), initial=0.0)
        return self.u.function_space.mesh.comm.allreduce(local, MPI.MAX)

    def refuse(self, why, matrix):
        """Raise naming the motions on which the positive semi-definite ``matrix`` vanishes, if any."""
        unheld = rigid.readable(self.free @ rigid.null_space(matrix))
        if unheld.shape[1]:
            names = ", ".join(rigid.describe_all(unheld, self.centre, self.scale))
            raise InputError(f"the body is free to move: {names}; {why}: {HOLD}")


def _descent(along, a, g):
    """Newton's direction where the foundation is pressed along every motion, else the steepest one."""
    H = along.matrix(along.hessian_action, a)
    try:
        np.linalg.cholesky(H)
        return -np.linalg.solve(H, g), 1.0
    except np.linalg.LinAlgError:
        d = -g / np.linalg.norm(g)
        return d, 1e-3 * along.scale / along.largest_move(d)  # first try: a thousandth of the body's size


def _line_minimum(along, a, d, first):
    """The minimiser of the convex E along a + t d, t > 0 (``first``: the first t tried): bracketed by
    doubling t until E's slope turns, then bisected to 1e-4. A slope still negative FARTHEST body sizes
    away: the loads pull the body off along d."""
    def slope(t):
        return along.gradient(a + t * d) @ d
    unit = along.largest_move(d)  # the largest nodal move for t = 1
    low, high = 0.0, first
    while slope(high) < 0:
        low, high = high, 2 * high
        if high * unit > FARTHEST * along.scale:
            names = ", ".join(rigid.describe_all(rigid.readable(along.free @ d[:, None]), along.centre, along.scale))
            raise InputError(f"the body is free to move: {names}; the loads pull it off the foundation: {HOLD}")
    while high - low > 1e-4 * high:
        middle = 0.5 * (low + high)
        low, high = (middle, high) if slope(middle) < 0 else (low, middle)
    return a + high * d
