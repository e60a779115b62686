"""What every output column and field means, with its sign convention.

One table serves ``summary.json`` (``columns``, ``sign_conventions``) and the user guide's output
section (generated at build time by ``docs/reference_tables.py``; ``python3 -m nc_dolfinx.output.columns``
prints it). ν is the outward unit normal of the body, u_n = u·ν, p the contact pressure.
"""

SIGN_CONVENTIONS = [
    "Coordinates and displacements are in the problem's own units, along the mesh axes (x, y[, z]).",
    "Stress is positive in tension; 2D is plane strain, so the 3×3 stress has σ_zz = λ tr ε.",
    "ν is the body's outward unit normal; u_n = u·ν > 0 moves Γ_C into the foundation.",
    "Penetration (u_n − g_0)_+ >= 0; contact pressure p = c_n (u_n − g_0)_+^m_n = −σ_n >= 0 (compression).",
    "contact_force = −∫_Γ_C p ν: the force the foundation exerts on the body (it points into the body).",
    "Friction: Δu_t is the tangential part of u − u_prev (u_prev the previous load state); the tangential "
    "traction s_t and friction_force are the foundation's on the body: they oppose the spring's slip "
    "s = Δu_t − (ε/F) s_t,prev (s_t·s <= 0; s_t,prev the previous state's traction), "
    "|s_t| <= F = μ p (Coulomb) or c_t (u_n − g_0)_+^m_t.",
    "reaction_GROUP: the force a support (Dirichlet group or symmetry plane) exerts on the body: a group moved "
    "outwards by loads.u_D, stretching the body, pulls it (its reaction points along the outward normal).",
]

# name (CSV header; the JSON files keep contact_force as a list) -> meaning
COLUMNS = {
    "level": "the row's number: refinement level, 0 = the initial mesh (on a load path, rows of every step in turn)",
    "step": "load path only: the step of [[steps]] (1, 2, …) the row solves",
    "increment": "load path only: the increment of that step (its last: the step's parameters in full)",
    "load_time": "load path only: step − 1 + increment / increments, the time step of solution.pvd",
    "dofs": "degrees of freedom: dimension × vertices (Dirichlet ones included)",
    "cells": "cells (triangles in 2D, tetrahedra in 3D)",
    "imbalance": "owned cells of the busiest rank over the mean (1 on one rank); a refined mesh above 1.05 is "
                 "partitioned anew",
    "eta_1": "η_1 = (Σ_K η_1K²)^½, η_1K = h_K ‖f_K‖_K (body force; Definition 5)",
    "eta_2": "η_2: jumps of σ(u_h)ν on interior facets and σ(u_h)ν − g on Γ_N (Definition 5)",
    "eta_3": "η_3: tangential stress σ_t(u_h) on Γ_C (Definition 5); with friction the residual of the "
             "friction law, σ_t(u_h) − s_t(u_h)",
    "eta_4": "η_4: residual of the law, c_n (u_hn − g_0)_+^m_n + σ_n(u_h) on Γ_C (Definition 5)",
    "eta": "the estimator η = (Σ_K η_K²)^½, η_K² = η_1K² + … + η_4K²",
    "zeta": "data oscillation ζ (§4.1)",
    "eta_geometry": "geometric term η_geo = (Σ_K η_geo,K²)^½, η_geo,K² = Σ δ_F ‖σ(u_h)‖²_F over the facets F of K on "
                    "Γ_C ∪ Γ_N: how far the mesh's boundary lies from the body's true shape (not in η; it joins "
                    "η_K² in the marking; see Theory)",
    "geometry_sag": "the largest δ_F on Γ_C ∪ Γ_N: the distance of a boundary facet from its group's true shape "
                    "(the chord's sag where the shape is given, the level-0 facets' sag where it is not, 0 on "
                    "flat groups)",
    "newton_iterations": "Newton (SNES) iterations of the level",
    "linear_iterations": "Krylov iterations summed over the level's Newton steps",
    "converged_reason": "PETSc SNES converged reason, or CONVERGED_ROUNDOFF (the residual within its round-off, see Solver)",
    "preconditioner_matrix": "matrix the preconditioner was built from at the end of the level (bulk | jacobian | auto)",
    "recoveries": "what the solver did after a failure: gmres (CG met an indefinite preconditioner), refresh, c_n_continuation, stronger_pc, continuation (fallbacks after a failed SNES solve; c_n_continuation first when the contact zone crept); empty if nothing failed",
    "max_contact_pressure": "max of the nodal contact pressure p >= 0 (lumped L² projection on Γ_C)",
    "elastic_energy": "½ a(u_h, u_h)",
    "contact_resultant": "∫_Γ_C p >= 0: the normal contact force",
    "contact_force_x": "x component of −∫_Γ_C p ν, the force of the foundation on the body",
    "contact_force_y": "y component of −∫_Γ_C p ν",
    "contact_force_z": "z component of −∫_Γ_C p ν (3D)",
    "contact_length": "measure of {p > 0} on Γ_C (2D; contact_area in 3D)",
    "friction_force_x": "with friction: x component of ∫_Γ_C s_t (vertex rule: the law at the vertices), the "
                        "tangential force of the foundation on the body (_y, _z alike)",
    "slip_length": "with friction: Σ m_i, m_i = ∫_Γ_C φ_i, over the vertices in contact that slip by the law's "
                   "test |s| > ε_r (u·N − g̃_0)_+, s the spring's slip (stick_slip = 2; 2D, slip_area in 3D)",
    "stick_length": "with friction: the same over the vertices in contact that stick, |s| <= ε_r (u·N − g̃_0)_+ "
                    "(stick_slip = 1; 2D, stick_area in 3D)",
    "max_slip": "with friction: the largest slip increment |Δu_t| at a vertex of Γ_C",
    "friction_passes": "with friction: passes of the fixed point on the friction bound (see Solver)",
    "friction_newton": "with friction: of newton_iterations, the steps of the consistent Newton finish (see Solver)",
    "max_penetration": "max of the nodal penetration (u_hn − g_0)_+ >= 0 on Γ_C",
    "applied_load_x": "x component of the resultant of the given loads, ∫_Ω f + ∫_Γ_N g (_y, _z alike)",
    "reaction_GROUP_x": "x component of the force the Dirichlet or symmetry group GROUP exerts on the body "
                          "(_y, _z alike): Σ of the residual of (7) at the dofs it constrains (a dof on two "
                          "groups counts for the first; a symmetry plane's force lies along its normal, a roller's along "
                          "the components loads.u_D holds: a free component carries none)",
    "force_balance": "|applied_load + contact_force + Σ reactions| / (|applied_load| + |contact_force| + "
                     "Σ |reaction|): 0 for a body in equilibrium, within the solver's tolerance",
    "max_displacement": "max over the vertices of |u_h|",
    "l2_error": "‖u − u_h‖_0 (with an exact solution)",
    "h1_error": "‖u − u_h‖_1 (with an exact solution)",
    "augmented_error": "‖u − u_h‖_1 + ‖h^½ (σ_n(u) − σ_n(u_h))‖_Γ_C (Remark 9; with an exact solution)",
    "effectivity": "η / ‖u − u_h‖_1",
    "effectivity_augmented": "η / augmented_error",
    "marked": "cells marked for refinement (adaptive)",
    "time_mesh": "seconds: building the level-0 mesh (level 0 only)",
    "time_refine": "seconds: the refinement that made this level's mesh",
    "time_solve": "seconds: bind the problem and solve (7)",
    "time_estimate": "seconds: the estimator",
    "time_mark": "seconds: marking",
    "time_output": "seconds: writing the level's files (rank 0's clock)",
}
ALIASES = {"contact_force": "contact_force_x", "contact_area": "contact_length", "friction_force": "friction_force_x",
           "slip_area": "slip_length", "stick_area": "stick_length"}

FIELDS = {
    "displacement": "P1 vector u_h (3 components in the VTU files: z = 0 in 2D)",
    "contact_pressure": "P1 p >= 0 on Γ_C (lumped L² projection), 0 elsewhere",
    "tangential_traction": "with friction: P1 s_t on Γ_C, the law's tangential traction at the vertices (where it is evaluated)",
    "friction_bound": "with friction: P1 F on Γ_C, the law's bound at the vertices: |s_t| = F where stick_slip = 2",
    "slip": "with friction: P1 slip increment Δu_t on Γ_C (at the vertices)",
    "stick_slip": "with friction: P1 on Γ_C, 0 no contact, 1 stick (|s| ≤ ε), 2 slip (|s| > ε): the law's test at the vertex",
    "stress": "DG0 3×3 Cauchy stress σ(u_h) (row-major xx, xy, xz, yx, …)",
    "von_mises": "DG0 von Mises stress of the 3×3 stress",
    "eta": "DG0 η_K (eta_1 … eta_4: its parts η_1K … η_4K)",
    "zeta": "DG0 oscillation ζ_K",
    "eta_geometry": "DG0 geometric term η_geo,K (how far the cell's Γ_C ∪ Γ_N facets lie from the true shape)",
    "region": "DG0 material region id of the cell (VTU files)",
}


def describe(name):
    """The meaning of a column (None if undocumented: tests/test_output.py fails then)."""
    if name.startswith("reaction_") and name[-2:] in ("_x", "_y", "_z"):
        return COLUMNS["reaction_GROUP_x"].replace("GROUP", repr(name[len("reaction_"):-2]), 1)
    for vector in ("applied_load_", "friction_force_"):
        if name.startswith(vector):
            return COLUMNS[vector + "x"]
    return COLUMNS.get(ALIASES.get(name, name))


def markdown():
    """The column and field reference of the user guide, as Markdown."""
    lines = ["| column | meaning |", "|---|---|"]
    lines += [f"| `{name}` | {doc} |" for name, doc in COLUMNS.items()]
    lines += ["", "| field | meaning |", "|---|---|"]
    lines += [f"| `{name}` | {doc} |" for name, doc in FIELDS.items()]
    lines += ["", "Sign conventions:", ""] + [f"- {text}" for text in SIGN_CONVENTIONS]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(markdown(), end="")
