"""The friction law's history from one load state to the next (:mod:`.friction`): the displacement u_prev
from which the next increment's slip Δu_t is measured, and the tangential traction σ_t,prev there.

At the end of each load increment the state moves on to u_h by the return map of the elastoplastic analogy
of the regularised law (Wriggers' and Laursen's books, as cited in :mod:`.friction`), at each vertex of Γ_C:

    s = Δu_t − (ε/F) σ_t,prev,   σ_t,prev ← −F s / max(|s|, ε),   u_prev ← u_h,

the law itself where it is evaluated: the friction law is integrated with the vertex rule
(:func:`~nc_dolfinx.physics.forms.law_measure`) and its F, ε, s and N are nodal values there, so the new
σ_t,prev is the traction the law had at those points, exactly, and a P1 function holds it exactly. A stuck
vertex keeps its traction, a slipping one the bound F along its slip, so that a reversal must first unload
the spring. Out of contact, or where F = 0, σ_t,prev = 0. Without this memory (each increment's spring
starting unstretched) a stuck point carrying a tangential traction T had to stretch its spring anew in
every increment: it crept by ε T/F per increment under a constant load. (Before issue 50 the law was
evaluated at Gauss points and the memory was a lumped projection of it, not the law's traction: cattaneo3d
pressed with friction on, then sheared, had c/a = 0.464 against 0.532–0.539 in an independent solution;
now 0.536.) On a refined mesh the state moves
as P1 functions do: exactly at the old vertices, linearly at the new ones
(:func:`nc_dolfinx.mesh.refinement.transfer`)."""
from dataclasses import dataclass

from dolfinx import fem

from . import forms, friction


@dataclass
class SlipState:
    """A load state of the friction law, whose bound is μ times the pressure of law (4) (Coulomb's case):
    ``displacement`` u_prev and ``traction`` σ_t,prev (P1 vector Functions on one mesh; σ_t,prev zero off
    Γ_C), as the return map leaves them (:mod:`nc_dolfinx.physics.slip_state`). ``SlipState.after(u,
    fields)`` is the state at the end of an increment that ended at ``u``: what ``solve(previous_state=)``
    takes to solve the next increment of a load path by hand, as :func:`~nc_dolfinx.adapt` does."""
    displacement: fem.Function
    traction: fem.Function

    @classmethod
    def after(cls, u, fields):
        """The state at the end of a load increment that ended at ``u`` (``Solution.u``, ``Solution.fields``):
        the return map of this module, for the next increment's ``solve(previous_state=)`` (copies)."""
        return state_after(u, fields)


def _at_vertices(u, fields):
    """(F, ε, stretch, s) at the vertices of u's mesh, the law's own values there (zero off Γ_C): the bound
    F and the slip length ε of (u·N − g̃_0)_+, the stretch (ε/F) σ_t,prev and the spring's slip
    s = Δu_t − (ε/F) σ_t,prev (:func:`~.friction.spring_slip`), as arrays (ghosts included)."""
    law, dim = fields.friction, fields.dim
    depth = forms.law_penetration(u, fields, law.normal)
    slip = friction.at_vertices(friction.spring_slip(u, depth, law), law).x.array.reshape(-1, dim)
    stretch = friction.at_vertices(friction.slip_increment(u, law), law).x.array.reshape(-1, dim) - slip
    bound = friction.at_vertices(friction.friction_bound(depth, law), law).x.array
    length = friction.at_vertices(law.epsilon * depth, law).x.array
    return bound, length, stretch, slip


def traction_at(u, fields):
    """σ_t at the end of the increment that ends at u (the return map above): the law's tangential traction
    :func:`~.friction.tangential_traction` at the vertices of Γ_C, as an array of P1 values (ghosts
    included)."""
    law = fields.friction
    depth = forms.law_penetration(u, fields, law.normal)
    traction = friction.at_vertices(friction.tangential_traction(u, depth, law), law)
    pairs = fields.pair_coupling(u).friction if fields.pairs else None
    if pairs is not None:  # (the faces of frictional [[pairs]]: their law's traction at their vertices)
        pairs.write_traction(traction)
    return traction.x.array.copy()


def state_after(u, fields):
    """The :class:`SlipState` at the end of the increment that ends at u (copies: u and the law are left
    as they are)."""
    displacement, traction = fem.Function(u.function_space), fem.Function(u.function_space)
    displacement.x.array[:] = u.x.array
    traction.x.array[:] = traction_at(u, fields)
    return SlipState(displacement, traction)


def advance(u, fields):
    """Move the law's state on to u, the end of a load increment, in place (the next increment's start)."""
    law = fields.friction
    law.previous_traction.x.array[:] = traction_at(u, fields)
    law.previous.x.array[:] = u.x.array


def start_state(law):
    """The state the law's current increment started from (its own Functions, not copies)."""
    return SlipState(law.previous, law.previous_traction)


def spring_stretch(u, fields):
    """(ε/F) σ_t,prev at the vertices of Γ_C (ε = ε_r (u·N − g̃_0)_+ and F = c_t (u·N − g̃_0)_+^{m_t}, the
    pressure of law (4) times μ in Coulomb's case, at u: the law's values there), the part of the spring's
    slip s = Δu_t − (ε/F) σ_t,prev that the previous state's traction leaves (the return map's memory): a
    P1 Function, for post-processing that evaluates the law at the vertices."""
    stretch = fem.Function(u.function_space, name="spring_stretch")
    stretch.x.array[:] = _at_vertices(u, fields)[2].ravel()
    return stretch
