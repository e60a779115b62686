"""What every output column and field means, with its sign convention.

One table serves ``summary.json`` (``columns``, ``sign_conventions``) and the reference's output
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
    "param_NAME": "load path only: the value at the row's state of the parameter NAME that [[steps]] set "
                  "(each step moves it linearly over its increments): e.g. param_dt, the x-axis of load_path.png "
                  "with output.load_path_x = \"dt\"",
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
    "contact_force_x": "x component of −∫_Γ_C p ν, the force of the foundation on the body (−Σ_i j_n(u_h, φ_i): "
                       "the resultant of the normal law's part of the residual of (7), with its Gauss rule)",
    "contact_force_y": "y component of −∫_Γ_C p ν",
    "contact_force_z": "z component of −∫_Γ_C p ν (3D)",
    "contact_length": "measure of {p > 0} on Γ_C (2D; contact_area in 3D)",
    "friction_force_x": "with friction: x component of the tangential force of the foundation on the body "
                        "(_y, _z alike), −Σ_i j_t(u_h, φ_i), the resultant of the friction part of the residual "
                        "of (7): ∫_Γ_C s_t·(e_x)_t by the vertex rule (the law at the vertices, (e_x)_t the axis "
                        "normal to the vertex normal N)",
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
    "force_balance": "|applied_load + contact_force [+ friction_force] + Σ reactions| / (|applied_load| + "
                     "|contact_force| [+ |friction_force|] + Σ |reaction|): 0 for a body in equilibrium, within "
                     "the solver's tolerance (every force is the resultant of its part of the residual of (7), "
                     "on curved and flat Γ_C alike)",
    "pairK_force_x": "with [[pairs]]: x component of the force the second face's body exerts on the first's, "
                     "pair K (_y, _z alike): the resultant of the pair's part of the residual of (7) on that body "
                     "(the other body gets its opposite)",
    "pairK_resultant": "with [[pairs]]: ∫ p over pair K's first face (its normal force)",
    "pairK_contact_length": "with [[pairs]]: measure of {p > 0} on pair K's first face (2D; _contact_area in 3D)",
    "pairK_max_pressure": "with [[pairs]]: the largest pressure of pair K at its integration points (both faces)",
    "pairK_max_penetration": "with [[pairs]]: the largest (u_n − g_0)_+ of pair K at its integration points",
    "pairK_friction_force_x": "with [[pairs]] friction: x component of the tangential force the second face's "
                              "body exerts on the first's, pair K (_y, _z alike; part of pairK_force): the law's "
                              "traction at the faces' vertices",
    "pairK_stick_length": "with [[pairs]] friction: measure of the first face's vertices in contact that stick, "
                          "pair K (2D; _stick_area in 3D)",
    "pairK_slip_length": "with [[pairs]] friction: measure of the first face's vertices in contact that slip, "
                         "pair K (2D; _slip_area in 3D)",
    "max_displacement": "max over the vertices of |u_h|",
    "l2_error": "‖u − u_h‖_0 (with an exact solution)",
    "h1_error": "‖u − u_h‖_1 (with an exact solution)",
    "augmented_error": "‖u − u_h‖_1 + ‖h^½ (σ_n(u) − σ_n(u_h))‖_Γ_C (Remark 9; with an exact solution)",
    "effectivity": "η / ‖u − u_h‖_1",
    "effectivity_augmented": "η / augmented_error",
    "marked": "cells marked for refinement (adaptive)",
    "increment_cuts": "on a step with increments = \"auto\": how many times this increment was halved before it "
                      "converged (0: solved whole)",
    "cut_reason": "on a step with increments = \"auto\": why each cut was made ('; '-separated: the solve "
                  "failed, or needed more than solver.increment_newton_target Newton steps); empty if none",
    "time_cut": "seconds: on a step with increments = \"auto\", the attempts discarded before this increment",
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
    "pair_pressure": "with [[pairs]]: P1 pressure on both faces of every pair (the mean of the pair's integration "
                     "points around each vertex), 0 elsewhere",
    "pair_traction": "with [[pairs]] friction: P1 tangential traction of the law at the faces' vertices (on each "
                     "face's own body), 0 elsewhere",
    "pair_stick_slip": "with [[pairs]] friction: at the faces' vertices 0 out of contact, 1 stick, 2 slip",
    "body": "with [[pairs]]: the body of the cell, 0, 1, … by its lowest vertex (VTU files)",
}


def describe(name):
    """The meaning of a column (None if undocumented: tests/test_output.py fails then)."""
    if name.startswith("param_"):
        return COLUMNS["param_NAME"].replace("NAME", repr(name[len("param_"):]), 1)
    if name.startswith("reaction_") and name[-2:] in ("_x", "_y", "_z"):
        return COLUMNS["reaction_GROUP_x"].replace("GROUP", repr(name[len("reaction_"):-2]), 1)
    if name.startswith("pair") and "_" in name and name[4:name.index("_")].isdigit():
        rest = name[name.index("_"):]
        rest = {"_force_y": "_force_x", "_force_z": "_force_x", "_contact_area": "_contact_length",
                "_friction_force_y": "_friction_force_x", "_friction_force_z": "_friction_force_x",
                "_stick_area": "_stick_length", "_slip_area": "_slip_length"}.get(rest, rest)
        return COLUMNS.get("pairK" + rest, "").replace("pair K", f"pair {name[4:name.index('_')]}") or None
    for vector in ("applied_load_", "friction_force_"):
        if name.startswith(vector):
            return COLUMNS[vector + "x"]
    return COLUMNS.get(ALIASES.get(name, name))


def markdown():
    """The column and field reference (docs: reference/output.md), as Markdown."""
    lines = ["| column | meaning |", "|---|---|"]
    lines += [f"| `{name}` | {doc} |" for name, doc in COLUMNS.items()]
    lines += ["", "| field | meaning |", "|---|---|"]
    lines += [f"| `{name}` | {doc} |" for name, doc in FIELDS.items()]
    lines += ["", "Sign conventions:", ""] + [f"- {text}" for text in SIGN_CONVENTIONS]
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(markdown(), end="")


AXES = "xyz"


class Row(dict):
    """A history row (what :func:`nc_dolfinx.adapt` returns in ``Result.history``): a dict whose vector
    quantities (``contact_force``, ``friction_force``, ``applied_load``, ``reaction_GROUP``) are lists, as in
    ``history.json``, and which also answers to the names of ``history.csv``'s columns: ``row["friction_force_x"]``
    is ``row["friction_force"][0]`` (``_y``, ``_z`` alike; ``in`` and ``get`` too). Iterating, ``keys()``,
    ``dict(row)`` and JSON give the stored keys only (the vectors as lists), so nothing is written twice."""

    def _component(self, key):
        """The (vector, index) a CSV column name ``NAME_x`` stands for, or None."""
        if not isinstance(key, str) or len(key) < 3 or key[-2] != "_" or key[-1] not in AXES:
            return None
        vector = dict.get(self, key[:-2])
        index = AXES.index(key[-1])
        return (vector, index) if isinstance(vector, (list, tuple)) and index < len(vector) else None

    def __missing__(self, key):
        found = self._component(key)
        if found is None:
            raise KeyError(key)
        return found[0][found[1]]

    def __contains__(self, key):
        return dict.__contains__(self, key) or self._component(key) is not None

    def get(self, key, default=None):
        return self[key] if key in self else default

    def __reduce__(self):  # (pickled as itself: MPI and copies keep the aliases)
        return (Row, (dict(self),))


def path_parameters(problem, row, ends=None):
    """The columns ``param_NAME`` of a history ``row`` of ``problem``'s load path: the value at the row's
    state of every parameter that the [[steps]] set (in the order they are first set), as the path moves it:
    within step k, the parameters k sets moved linearly from where step k − 1 left them to their values at
    the step's end (a fraction increment / increments of the way, or load_time − k + 1 on a step that
    sizes its own increments), the others as the step's end problem has them (one defined by an
    expression of a moved one follows it). Empty without [[steps]] or for a row without ``step``.
    ``ends``: the problems at each step's end, if already made (:meth:`Problem._step_ends`)."""
    steps = problem.values["steps"]
    if not steps or not row.get("step"):
        return {}
    names = list(dict.fromkeys(name for step in steps for name in step["set"]))
    ends = ends if ends is not None else problem._step_ends()
    number = row["step"]
    step, end = steps[number - 1], ends[number - 1]
    if isinstance(step["increments"], int):
        fraction = row["increment"] / step["increments"]
    else:  # ("auto": the state's own fraction of the step)
        fraction = row["load_time"] - (number - 1)
    if fraction >= 1.0:
        values = end.parameters
    else:
        start = (ends[number - 2] if number > 1 else problem).parameters
        moved = {name: start[name] + (value - start[name]) * fraction for name, value in step["set"].items()}
        values = end.at_parameters(moved).parameters
    return {f"param_{name}": float(values[name]) for name in names}
