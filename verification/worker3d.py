"""The computations of the 3D verification studies (issue 10), run under MPI by verify.py:

    mpirun -n N /usr/bin/python3 verification/worker3d.py STUDY --mode quick|full --out RESULT.json

Like worker.py (whose helpers it uses): only the public API (``import nc_dolfinx as nc``), one JSON file per
run (rank 0); the checks, tables and plots are verify.py's business.
"""
import math
import sys
import time

import ufl

from checks3d import EFF_SETTLE, fitted_levels
from common import spread
from worker import COMM, clean_row, main, penalty_limit, say, uniform_settings

import nc_dolfinx as nc

CONFIG = {
    "quick": {
        "manufactured3d": {"cells": 4, "levels": 3, "m": [1, 1.5, 2, 3], "c": [0.1, 100]},
        "hertz3d": {"levels": 5},
        "fichera": {"adaptive_levels": 5, "uniform_levels": 2, "reference_extra": 2, "reference_uniform": False},
        "penalty3d": {"cells": [8, 4, 4], "eps": [1e-5, 1e-6, 1e-7, 1e-8, 1e-9]},
        "parallel3d": {"manufactured_cells": 3, "manufactured_levels": 3, "fichera_levels": 4,
                       "hertz_levels": 3},
    },
    "full": {
        "manufactured3d": {"cells": 4, "levels": 4, "max_levels": 5, "m": [1, 1.5, 2, 3],
                           "c": [0.1, 1, 10, 100, 1000]},
        "hertz3d": {"levels": 6},
        "fichera": {"adaptive_levels": 8, "uniform_levels": 3, "reference_extra": 1, "reference_uniform": False},
        "penalty3d": {"cells": [16, 8, 8], "eps": [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]},
        "parallel3d": {"manufactured_cells": 3, "manufactured_levels": 4, "fichera_levels": 6,
                       "hertz_levels": 4},
    },
}
EXTRA_KEYS = ("contact_area", "time_solve", "time_estimate")

# the penalty study in 3D: the box (block in 3D) pressed by a traction on the half x < 1 of its top only,
# no weight, flat foundation, no gap: contact on part of the base (as PENALTY_SET does for the 2D block)
PENALTY_SET_3D = ['loads.f=["0","0","0"]', 'loads.g={top=["0","0","-40*pos(1-x)"]}', 'contact.gap="0"']


def row_of(row):
    out = clean_row(row)
    out.update({k: float(row[k]) for k in EXTRA_KEYS if k in row})
    return out


# --- manufactured3d on uniform meshes --------------------------------------------------------------------

def study_manufactured3d(cfg):
    """Every (m_n, c_n) on cfg["levels"] uniform levels, and one more (up to cfg["max_levels"]) while the
    effectivity has not settled over the last three: where c_n (u_n)_+^{m_n} is large it is still moving on
    meshes that suffice elsewhere (the next level costs 8 times the dofs, so only where needed)."""
    runs = []
    for m in cfg["m"]:
        for c in cfg["c"]:
            t = time.perf_counter()
            cells = cfg["cells"]
            problem = nc.load_problem("manufactured3d", [f"parameters.m={m}", f"parameters.c={c}",
                                                         f"mesh.cells=[{cells},{cells},{cells}]"])
            levels = cfg["levels"]
            history = nc.adapt(problem, uniform_settings(levels)).history
            while not effectivity_settled(history) and levels < cfg.get("max_levels", levels):
                levels += 1
                history = nc.adapt(problem, uniform_settings(levels)).history
            rows = [row_of(r) for r in history]
            for r in rows:  # the box's tetrahedra: the longest edge is the diagonal of a sub-cube
                r["h"] = math.sqrt(3.0) / (cells * 2 ** r["level"])
            runs.append({"m": m, "c": c, "rows": rows, "time": time.perf_counter() - t})
            say(f"  manufactured3d m={m} c={c}: {rows[-1]['dofs']} dofs, eta={rows[-1]['eta']:.3e} "
                f"|e|_1={rows[-1]['h1_error']:.3e} eff={rows[-1]['effectivity']:.3f} ({time.perf_counter() - t:.1f} s)")
    return {"runs": runs}


def effectivity_settled(history):
    effectivities = [row["effectivity"] for row in fitted_levels(history)]
    return spread(effectivities) <= EFF_SETTLE


# --- hertz3d, adaptive ----------------------------------------------------------------------------------

def study_hertz3d(cfg):
    problem = nc.load_problem("hertz3d")
    settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=cfg["levels"])
    history = nc.adapt(problem, settings).history
    R, E, nu = problem["reference.radius"], problem["material.E"], problem["material.nu"]
    fraction = problem["reference.model_fraction"]
    rows = []
    for h in history:
        r = row_of(h)
        ref = nc.hertz_sphere_contact(h["contact_resultant"] / fraction, R, E, nu)
        r["hertz_radius"], r["hertz_peak_pressure"] = ref["radius"], ref["peak_pressure"]
        r["radius"] = math.sqrt(h["contact_area"] / fraction / math.pi)
        rows.append(r)
        say(f"  hertz3d level {r['level']}: {r['dofs']} dofs, a = {r['radius']:.5f} vs {ref['radius']:.5f}, "
            f"p0 = {r['max_contact_pressure']:.4g} vs {ref['peak_pressure']:.4g}")
    return {"E": E, "nu": nu, "R": R, "fraction": fraction, "c_n": str(problem["contact.c_n"]), "rows": rows}


# --- fichera: adaptive against uniform ------------------------------------------------------------------

def total_energy(u, fields):
    """Π(u) = ½ a(u, u) − L(u) + ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1}, the convex energy that u_h minimises
    over V_h (its gradient is the residual of (7))."""
    n = ufl.FacetNormal(fields.domain.mesh)
    gap = ufl.dot(u, n) - fields.gap
    penetration = ufl.conditional(ufl.gt(gap, 0), gap, 0)
    elastic = 0.5 * ufl.inner(nc.sigma(u, fields.lmbda, fields.mu), ufl.sym(ufl.grad(u))) * ufl.dx
    load = ufl.inner(fields.f, u) * ufl.dx
    for group_id, g in fields.g.items():
        load += ufl.inner(g, u) * fields.ds(group_id)
    contact = fields.c_n / (fields.m_n + 1) * penetration ** (fields.m_n + 1) * nc.contact_measure(fields)
    return nc.integrate(elastic - load + contact, COMM)


def energy_recorder(store, kind):
    def on_level(level):
        store[(kind, level.row["level"])] = total_energy(level.u, level.fields)
    return on_level


def study_fichera(cfg):
    """Adaptive and uniform runs of the fichera case. The error of each u_h is measured in energy,
    E_h = (2 (Π(u_h) − Π_ref))^{1/2}, with Π_ref the energy of a reference solution: the adaptive mesh
    ``reference_extra`` levels beyond the compared ones, refined uniformly once if ``reference_uniform``. Since u
    minimises the convex Π, Π(v) − Π(u) = ½ ‖v − u‖_a² + B(v, u), with B ≥ 0 the Bregman distance of the contact
    energy: E_h bounds the energy-norm error from above, needs no interpolation between meshes, and works for
    non-nested ones."""
    problem = nc.load_problem("fichera")
    energies = {}
    n_adapt = cfg["adaptive_levels"]
    settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=n_adapt + cfg["reference_extra"])
    result = nc.adapt(problem, settings, on_level=energy_recorder(energies, "adaptive"))
    t = time.perf_counter()
    if cfg["reference_uniform"]:
        domain_ref = nc.refine(result.final.fields.domain)
        solution = nc.solve(problem, domain_ref, initial=result.final.u)
        eta_ref = nc.estimate(solution.u, solution.fields).totals["eta"]
    else:
        solution, domain_ref, eta_ref = result.final.solution, result.final.fields.domain, result.final.row["eta"]
    reference = {"dofs": 3 * domain_ref.num_vertices(), "cells": domain_ref.num_cells(), "eta": eta_ref,
                 "energy": total_energy(solution.u, solution.fields), "uniform": cfg["reference_uniform"],
                 "newton_iterations": solution.stats.newton_iterations, "time": time.perf_counter() - t,
                 "from_adaptive_level": len(result.history) - 1}
    say(f"  fichera reference: {reference['dofs']} dofs, eta = {reference['eta']:.4e}, "
        f"energy = {reference['energy']:.10e}")
    uniform = nc.adapt(problem, nc.AdaptSettings(refine="uniform", levels=cfg["uniform_levels"]),
                       on_level=energy_recorder(energies, "uniform")).history
    histories = {"adaptive": [row_of(r) for r in result.history], "uniform": [row_of(r) for r in uniform]}
    for kind, rows in histories.items():
        for r in rows:
            r["energy"] = energies[(kind, r["level"])]
            r["energy_error"] = math.sqrt(max(2 * (r["energy"] - reference["energy"]), 0.0))
            say(f"  fichera {kind} level {r['level']}: {r['dofs']} dofs, eta = {r['eta']:.4e}, "
                f"energy error = {r['energy_error']:.4e}")
    return {"compared_adaptive_levels": n_adapt, "histories": histories, "reference": reference}


# --- penalty -> Signorini in 3D ---------------------------------------------------------------------------

def study_penalty3d(cfg):
    return penalty_limit("box", cfg["cells"], PENALTY_SET_3D, cfg["eps"])


# --- 1, 2, 3 ranks -----------------------------------------------------------------------------------------

# Newton to ‖F‖ <= 1e-12 ‖F_0‖ or 1e-12 ‖L‖ (the defaults: 1e-10): GAMG's aggregates depend on the
# partition, so rank counts stop at different iterates within the tolerance; 1e-10 ‖L‖ left differences
# of 1.3e-8 in manufactured3d's L² error. The comparison is of the discrete solutions, not of where the
# solver stopped.
TIGHT_NEWTON = ["solver.petsc_options.snes_rtol=1e-12", "solver.petsc_options.atol_of_load=1e-12"]


def study_parallel3d(cfg):
    cells = cfg["manufactured_cells"]
    manufactured = nc.load_problem("manufactured3d", [f"mesh.cells=[{cells},{cells},{cells}]", *TIGHT_NEWTON])
    runs = {"manufactured3d": nc.adapt(manufactured, uniform_settings(cfg["manufactured_levels"])).history}
    for case, levels in (("fichera", cfg["fichera_levels"]), ("hertz3d", cfg["hertz_levels"])):
        problem = nc.load_problem(case, TIGHT_NEWTON)
        settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=levels)
        runs[case] = nc.adapt(problem, settings).history
    return {"ranks": COMM.size, **{name: [row_of(r) for r in rows] for name, rows in runs.items()}}


STUDIES = {"manufactured3d": study_manufactured3d, "hertz3d": study_hertz3d, "fichera": study_fichera,
           "penalty3d": study_penalty3d, "parallel3d": study_parallel3d}


if __name__ == "__main__":
    sys.exit(main(STUDIES, CONFIG, with_output_path=()))
