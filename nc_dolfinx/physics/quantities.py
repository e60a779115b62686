"""Global quantities of a discrete solution: energy, contact force, the reactions of the supports and the
force balance, and errors against an exact solution."""
from dataclasses import dataclass

import numpy as np
import ufl
from mpi4py import MPI

from petsc4py import PETSc

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from .. import dolfinx_versions as versions
from ..pairs.quantities import pair_quantities
from . import elasticity, forms, friction

ERROR_DEGREE = 8


def integrate(expr, comm):
    """The integral of a UFL form of rank 0 (``expr``, e.g. ``u[0] * ufl.dx``) summed over the ranks of
    ``comm`` (``fem.assemble_scalar`` alone gives the rank's part)."""
    return comm.allreduce(fem.assemble_scalar(fem.form(expr)), MPI.SUM)


def solution_quantities(u, fields):
    """Global quantities of a solution ``u`` of (7), as a dict: ``elastic_energy`` ½a(u_h, u_h),
    ``contact_resultant`` ∫_Γ_C p with p = c_n (u_hn − g_0)_+^{m_n} = −σ_n the pressure of the law (4),
    ``contact_force`` −∫_Γ_C p ν (the vector the foundation exerts on the body), ``contact_length`` (2D)
    or ``contact_area`` (3D) the measure of {p > 0}, and ``max_contact_pressure`` / ``max_penetration``,
    the largest nodal values of p and (u_hn − g_0)_+ (lumped projections, :func:`contact_projection`);
    ``applied_load`` ∫_Ω f + ∫_Γ_N g, ``reaction_GROUP`` for every Dirichlet and symmetry group, with
    friction ``friction_force`` (:func:`residual_forces`: every force is the resultant of the residual's
    own assembled vector, so that they balance as the residual does) and ``force_balance``, the relative
    remainder of applied load + contact force + friction force + reactions = 0 (the solver's tolerance:
    the body is in equilibrium)."""
    comm = fields.domain.comm
    n = ufl.FacetNormal(fields.domain.mesh)
    p = forms.contact_pressure(u, fields, n)
    dC = forms.contact_measure(fields)
    forces = residual_forces(u, fields)
    penetration = contact_projection(forms.penetration(u, fields, n), fields, "penetration")
    n_owned = penetration.function_space.dofmap.index_map.size_local
    max_penetration = comm.allreduce(float(np.max(penetration.x.array[:n_owned], initial=0.0)), MPI.MAX)
    pressure = contact_projection(p, fields, "contact_pressure")
    max_pressure = comm.allreduce(float(np.max(pressure.x.array[:n_owned], initial=0.0)), MPI.MAX)
    frictional = friction_quantities(u, fields, forces) if fields.friction_on_foundation() else {}
    balanced = [forces.applied, forces.contact, *forces.reactions.values()]
    balanced += [forces.friction] if forces.friction is not None else []
    return {
        "max_contact_pressure": max_pressure,
        "elastic_energy": integrate(forms.elastic_energy(u, fields), comm),
        "contact_resultant": integrate(p * dC, comm),
        "contact_force": forces.contact,
        # the measure of {p > 0} on Γ_C: a length in 2D, an area in 3D
        "contact_length" if fields.dim == 2 else "contact_area":
            integrate(ufl.conditional(ufl.gt(p, 0), 1.0, 0.0) * dC, comm),
        "max_penetration": max_penetration,
        "applied_load": forces.applied,
        **{f"reaction_{name}": force for name, force in forces.reactions.items()},
        **frictional,
        **(pair_quantities(u, fields) if fields.pairs else {}),
        "force_balance": _balance(balanced),
    }


def friction_quantities(u, fields, forces=None):
    """With friction (:mod:`.friction`): ``friction_force``, the tangential force the foundation exerts on
    the body, −Σ_i j_t(u_h, φ_i) per component (:func:`residual_forces`; ``forces``: its result if already
    computed): the resultant of the j_t the residual carries, ∫_Γ_C s_t·(e_k)_t by the vertex rule (s_t the
    law's tangential traction, (e_k)_t the axis's part normal to the vertex normal N), so that it balances
    the load, the contact force and the reactions to the solver's tolerance. The rest, all with the law
    where it is evaluated, at the vertices of Γ_C (the vertex rule :func:`~.forms.law_measure`, the law's
    penetration (u·N − g̃_0)_+): ``slip_length``/``slip_area`` and ``stick_length``/``stick_area``,
    Σ_i m_i over the vertices in contact that slip by the law's own test |s| > ε_r (u·N − g̃_0)_+
    (:func:`~.friction.slipping`: there |s_t| = F, Coulomb's slip) and over those that stick (|s_t| ≤ F),
    m_i = ∫_Γ_C φ_i: the vertex field ``stick_slip`` integrated (as ε_r → 0, Coulomb's zones);
    ``max_slip``: the largest |Δu_t| at a vertex."""
    comm, law = fields.domain.comm, fields.friction
    forces = forces or residual_forces(u, fields)
    dL = forms.law_measure(fields)
    penetration = forms.law_penetration(u, fields, law.normal)
    slipping = friction.slipping(u, penetration, law)
    in_contact = ufl.conditional(ufl.gt(penetration, 0), 1.0, 0.0)
    measure = "length" if fields.dim == 2 else "area"
    slip = friction.at_vertices(friction.slip_increment(u, law), law)
    n_owned = slip.function_space.dofmap.index_map.size_local
    slip_size = np.linalg.norm(slip.x.array.reshape(-1, fields.dim)[:n_owned], axis=1)
    return {"friction_force": forces.friction,
            f"slip_{measure}": integrate(slipping * dL, comm),
            f"stick_{measure}": integrate((in_contact - slipping) * dL, comm),
            "max_slip": comm.allreduce(float(np.max(slip_size, initial=0.0)), MPI.MAX)}


@dataclass
class ResidualForces:
    """The forces on the body read from the assembled vectors of the residual of (7) (each a list of
    ``dim`` floats, the same on every rank): ``applied`` Σ_i L(φ_i), ``contact`` −Σ_i j_n(u_h, φ_i),
    ``friction`` −Σ_i j_t(u_h, φ_i) (None without friction) and ``reactions`` {group name: vector}."""
    applied: list
    contact: list
    friction: list
    reactions: dict


def residual_forces(u, fields):
    """Every force on the body, read from the assembled vectors of the residual of (7), r = a(u_h, ·) +
    j_n(u_h, ·) [+ j_t(u_h, ·)] − L: a :class:`ResidualForces`.

    The resultant of an assembled vector, Σ_i b(φ_i e_k) over all dofs (Dirichlet ones included), is
    b(e_k), the integral with the residual's own quadrature: ``applied`` = L(e_k) = ∫_Ω f + ∫_Γ_N g,
    ``contact`` = −j_n(u_h, e_k) = −∫_Γ_C p ν (the Gauss rule of j_n), ``friction`` = −j_t(u_h, e_k) (the
    vertex rule of the law, with the test function's tangential part: what the residual carries; with the
    bound of u_h itself, the consistent residual the solver's Newton finish converges). The force each
    Dirichlet and symmetry group exerts on the body is Σ r_i over the dofs it holds (the weak form with the
    reaction added is a + j_n + j_t = L + ∫_Γ_D t·v). At the free dofs r_i is Newton's residual, and
    Σ_i a(u_h, φ_i e_k) = a(u_h, e_k) = 0, so reactions, contact and friction forces and load sum to zero
    within the solver's tolerance, on curved and flat Γ_C alike (``force_balance``). (Before issue 48 the
    friction force was ∫_Γ_C s_t, which differs from −j_t(u_h, e_k) by s_t's part along N: 2e-5 of the
    forces on a coarse half-disc refined between frictional steps.)

    A dof that two groups hold counts for the first (the Dirichlet groups, then the symmetry planes, in the
    problem's order); a symmetry plane's force lies along its normal, and a roller's (a Dirichlet group
    with components of ``loads.u_D`` left free) along its held components only: a free component carries
    no reaction (its r_i is Newton's residual there)."""
    V, msh = u.function_space, fields.domain.mesh
    pieces = forms.normal_compliance_forms(u, fields)
    bs, n_owned = V.dofmap.index_map_bs, V.dofmap.index_map.size_local
    parts = {"load": pieces.L, "internal": ufl.action(pieces.a, u), "contact": pieces.j_n}
    if pieces.j_t is not None:
        parts["friction"] = ufl.replace(pieces.j_t, {pieces.frozen: u})
    blocks = {}
    for name, form in parts.items():
        vec = fem_petsc.assemble_vector(fem.form(form))
        blocks[name] = _owned_blocks(vec, n_owned, bs)
        vec.destroy()

    def resultant(values, sign=1.0):
        return [sign * float(x) for x in msh.comm.allreduce(values.sum(axis=0), MPI.SUM)]

    if pieces.operator_term is not None:  # [[pairs]]: their term of the residual (internal forces between bodies)
        vec = versions.petsc_vec(u).duplicate()
        vec.zeroEntries()
        pieces.operator_term.add_residual(vec)
        blocks["pairs"] = _owned_blocks(vec, n_owned, bs)
        vec.destroy()
    r = blocks["internal"] + blocks["contact"] - blocks["load"]
    if "pairs" in blocks:
        r += blocks["pairs"]
    if "friction" in blocks:
        r += blocks["friction"]
    taken = np.zeros_like(r, dtype=bool)
    names = {i: name for name, i in fields.domain.facet_groups.items()}
    tags, fdim = fields.domain.facet_tags, msh.topology.dim - 1
    held = [(i, fields.held_components(i)) for i in fields.ids["dirichlet"]]
    held += [(i, [a]) for i, a in fields.symmetry_axes.items()]
    reactions = {}
    for group, components in held:
        dofs = np.asarray(fem.locate_dofs_topological(V, fdim, tags.indices[tags.values == group]))
        mine = np.zeros_like(taken)
        mine[dofs[dofs < n_owned][:, None], list(components)] = True
        mine &= ~taken
        taken |= mine
        reactions[names.get(group, str(group))] = resultant(np.where(mine, r, 0.0))
    return ResidualForces(resultant(blocks["load"]), resultant(blocks["contact"], -1.0),
                          resultant(blocks["friction"], -1.0) if "friction" in blocks else None, reactions)


def support_forces(u, fields):
    """The resultant of the given loads, ∫_Ω f + ∫_Γ_N g, and the force each Dirichlet and symmetry group
    exerts on the body, {group name: vector}: :func:`residual_forces`' ``applied`` and ``reactions``."""
    forces = residual_forces(u, fields)
    return forces.applied, forces.reactions


def _owned_blocks(vec, n_owned, bs):
    """A copy of an assembled vector's owned entries (ghost contributions added in), (n_owned, bs)."""
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return vec.array[:n_owned * bs].reshape(-1, bs).copy()


def _balance(forces):
    """|Σ F| / Σ |F| of force vectors (0 when all vanish): how far they are from equilibrium, relatively."""
    total = np.sum(forces, axis=0)
    size = sum(float(np.linalg.norm(f)) for f in forces)
    return float(np.linalg.norm(total)) / size if size > 0 else 0.0


def contact_projection(expr, fields, name):
    """Lumped L² projection of a UFL quantity ``expr`` on Γ_C (the contact boundary of §2, e.g. the
    pressure of the law (4)) onto P1: q_i = ∫_Γ_C q φ_i / ∫_Γ_C φ_i, zero off Γ_C. Returns a P1
    ``fem.Function`` called ``name``, scalar or of ``expr``'s vector shape."""
    V = versions.p1_space(fields.domain.mesh, expr.ufl_shape)
    v = ufl.TestFunction(V)
    dC = forms.contact_measure(fields)
    first = v[0] if expr.ufl_shape else v  # (∫_Γ_C φ_i, the same for every component)
    num, den = (fem_petsc.assemble_vector(fem.form(form * dC)) for form in (ufl.inner(expr, v), first))
    for vec in (num, den):
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    out = fem.Function(V, name=name)
    bs, n_owned = V.dofmap.index_map_bs, V.dofmap.index_map.size_local
    d = den.array[:n_owned * bs].reshape(-1, bs)[:, :1]
    values = np.where(d > 0, num.array[:n_owned * bs].reshape(-1, bs) / np.where(d > 0, d, 1.0), 0.0)
    out.x.array[:n_owned * bs] = values.ravel()
    out.x.scatter_forward()
    num.destroy()
    den.destroy()
    return out


def errors(u, fields):
    """Errors of ``u`` against the problem's exact displacement ([exact] u), as a dict: ``l2_error``
    ‖u − u_h‖_0, ``h1_error`` ‖u − u_h‖_1 (the full H¹ norm of Theorem 6) and ``augmented_error`` ẽ of
    Remark 9, which adds (Σ_E h_E ‖σ_n(u − u_h)‖_E²)^{1/2} over Γ_C. Empty without an exact solution."""
    if fields.u_exact is None:
        return {}
    comm = fields.domain.comm
    e = fields.u_exact - u
    dx = ufl.dx(metadata={"quadrature_degree": ERROR_DEGREE})
    l2 = np.sqrt(integrate(ufl.inner(e, e) * dx, comm))
    h1 = np.sqrt(l2 ** 2 + integrate(ufl.inner(ufl.grad(e), ufl.grad(e)) * dx, comm))
    n = ufl.FacetNormal(fields.domain.mesh)
    sigma_n_err = elasticity.normal_stress(fields.sigma(e), n)
    h_E = ufl.FacetArea(fields.domain.mesh)
    contact = np.sqrt(integrate(h_E * sigma_n_err ** 2 * forms.contact_measure(fields, 16), comm))
    return {"l2_error": l2, "h1_error": h1, "augmented_error": h1 + contact}
