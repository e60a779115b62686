"""The friction law's history from one load state to the next (:mod:`.friction`): the displacement u_prev
from which the next increment's slip Δu_t is measured, and the tangential traction σ_t,prev there.

At the end of each load increment the state moves on to u_h by the return map of the elastoplastic analogy
of the regularised law (Wriggers' and Laursen's books, as cited in :mod:`.friction`), vertex by vertex on Γ_C:

    s = Δu_t − (ε/F) σ_t,prev,   σ_t,prev ← −F s / max(|s|, ε),   u_prev ← u_h,

(the law itself at the vertex; ε = ε_r (u_n − g_0)_+ and F lumped there, as the output's stick/slip field
lumps them, s, Δu_t and N the vertex's own): a stuck vertex keeps its traction, a slipping one the bound
F along its slip, so that a reversal must first unload the spring. Out of contact, or where F = 0,
σ_t,prev = 0. Without this memory (each increment's spring starting unstretched) a stuck point carrying a
tangential traction T had to stretch its spring anew in every increment: it crept by ε T/F per increment
under a constant load. On a refined mesh the state moves as P1 functions do: exactly
(:func:`nc_dolfinx.mesh.refinement.transfer`)."""
from dataclasses import dataclass

import numpy as np
import ufl

from dolfinx import fem

from . import forms, friction
from .quantities import contact_projection


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
    """(F, ε, stretch, s) at the vertices of u's mesh: the bound and the slip length lumped (zero off Γ_C),
    the stretch (ε/F) σ_t,prev and the spring's slip s = Δu_t − (ε/F) σ_t,prev (with the vertex normal)."""
    law, dim = fields.friction, fields.dim
    depth = forms.penetration(u, fields, ufl.FacetNormal(fields.domain.mesh))
    bound = contact_projection(friction.friction_bound(depth, law), fields, "bound").x.array
    length = float(law.epsilon.value) * contact_projection(depth, fields, "penetration").x.array
    compliance = np.where(bound > 0, length / np.where(bound > 0, bound, 1.0), 0.0)
    stretch = compliance[:, None] * law.previous_traction.x.array.reshape(-1, dim)
    N = law.normal.x.array.reshape(-1, dim)
    increment = (u.x.array - law.previous.x.array).reshape(-1, dim)
    slip = increment - np.sum(increment * N, axis=1)[:, None] * N - stretch
    return bound, length, stretch, slip


def traction_at(u, fields):
    """σ_t at the end of the increment that ends at u (the return map above), as an array of P1 values
    (ghosts included)."""
    bound, length, _, slip = _at_vertices(u, fields)
    size = np.linalg.norm(slip, axis=1)
    stiffness = np.where(bound > 0, bound / np.maximum(np.maximum(size, length), 1e-300), 0.0)
    return (-stiffness[:, None] * slip).ravel()


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
    """(ε/F) σ_t,prev at the vertices (ε = ε_r (u_n − g_0)_+ and F = c_t (u_n − g_0)_+^{m_t}, the pressure of
    law (4) times μ in Coulomb's case, lumped at u), the part of the spring's slip s = Δu_t − (ε/F) σ_t,prev
    that the previous state's traction leaves (the return map's memory): a P1 Function, for post-processing
    that evaluates the law pointwise."""
    stretch = fem.Function(u.function_space, name="spring_stretch")
    stretch.x.array[:] = _at_vertices(u, fields)[2].ravel()
    return stretch
