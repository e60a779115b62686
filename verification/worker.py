"""The computations of the verification studies, run under MPI by verify.py:

    mpirun -n N /usr/bin/python3 verification/worker.py STUDY --mode quick|full --out RESULT.json

Every study uses only the package's public API (``import nc_dolfinx as nc``: problem files, ``nc.adapt``,
``nc.solve``, ``nc.estimate``, ``nc.solution_quantities`` …) and writes one JSON file (rank 0). The checks, tables, plots and the
report are verify.py's business; this file only measures.
"""
import argparse
import json
import math
import sys
import time
import traceback
from pathlib import Path

import numpy as np
from mpi4py import MPI

from common import CASES, HERE, ROOT  # noqa: F401  (sets sys.path)

import ufl
from dolfinx import fem
import dolfinx.fem.petsc  # noqa: F401  (fem.petsc)
from petsc4py import PETSc

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions

COMM = MPI.COMM_WORLD


def say(text):
    if COMM.rank == 0:
        print(text, flush=True)


# --- configuration of the studies per mode ----------------------------------------------------------

CONFIG = {
    "quick": {
        "manufactured": {"cells": 8, "levels": 4, "m": [1, 1.5, 2, 3], "c": [0.1, 10, 1000],
                         "efficiency": [[1.5, 10], [1, 1000], [3, 1000]]},
        "closed_form": {"meshes": [[4, 2], [8, 4], [16, 8], [32, 16]]},
        "penalty": {"cells": [16, 8], "eps": [1e-5, 1e-6, 1e-7, 1e-8, 1e-9]},
        "hertz": {"levels": 6},
        "corner": {"adaptive_levels": 9, "uniform_levels": 4, "reference_extra": 2},
        "parallel": {"manufactured_levels": 4, "corner_levels": 6},
    },
    "full": {
        "manufactured": {"cells": 8, "levels": 6, "m": [1, 1.5, 2, 3], "c": [0.1, 1, 10, 100, 1000],
                         "efficiency": [[1.5, 10], [1, 1000], [3, 1000], [2, 0.1]]},
        "closed_form": {"meshes": [[4, 2], [8, 4], [16, 8], [32, 16], [64, 32], [128, 64]]},
        "penalty": {"cells": [32, 16], "eps": [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]},
        "hertz": {"levels": 10},
        "corner": {"adaptive_levels": 11, "uniform_levels": 6, "reference_extra": 2},
        "parallel": {"manufactured_levels": 5, "corner_levels": 8},
    },
}

ROW_KEYS = ("level", "dofs", "cells", "eta", "eta_1", "eta_2", "eta_3", "eta_4", "zeta", "h1_error",
            "l2_error", "augmented_error", "effectivity", "effectivity_augmented", "newton_iterations",
            "linear_iterations", "contact_resultant", "max_contact_pressure", "contact_length",
            "max_penetration", "elastic_energy", "marked")


def clean_row(row):
    out = {k: row[k] for k in ROW_KEYS if k in row}
    for k, v in out.items():
        if isinstance(v, (np.floating, np.integer)):
            out[k] = v.item()
    return out


def manufactured_problem(m, c, cells):
    return nc.load_problem("manufactured",
                                       [f"parameters.m={m}", f"parameters.c={c}", f"mesh.cells=[{cells},{cells}]"])


def uniform_settings(levels):
    return nc.AdaptSettings(refine="uniform", levels=levels)


def cell_values(form, Q):
    """Owned-cell values of a linear form against a DG0 test function (the estimator's assembly)."""
    return nc.assemble_cellwise(form, Q)[:, 0]


def gather_array(a):
    parts = COMM.gather(np.asarray(a), root=0)
    return np.concatenate(parts) if COMM.rank == 0 else None


# --- study 1: manufactured solution, uniform refinement ------------------------------------------------

def study_manufactured(cfg):
    """Study 1 (rates, effectivity) and, on the configurations listed in cfg["efficiency"], study 6."""
    runs, efficiency = [], []
    for m in cfg["m"]:
        for c in cfg["c"]:
            t = time.perf_counter()
            problem = manufactured_problem(m, c, cfg["cells"])
            local = []

            def on_level(level):
                stats = local_efficiency(level)
                if stats is not None:
                    stats.update(level=level.row["level"], dofs=level.row["dofs"])
                    local.append(stats)

            wanted = [m, c] in [list(x) for x in cfg["efficiency"]]
            history = nc.adapt(problem, uniform_settings(cfg["levels"]),
                               on_level=on_level if wanted else None).history
            rows = [clean_row(r) for r in history]
            for r in rows:
                r["h"] = math.sqrt(2.0) / (cfg["cells"] * 2 ** r["level"])  # max h_K (right-angled triangles)
            runs.append({"m": m, "c": c, "rows": rows, "time": time.perf_counter() - t})
            if wanted:
                efficiency.append({"m": m, "c": c, "levels": local})
            say(f"  manufactured m={m} c={c}: eta={rows[-1]['eta']:.3e} |e|_1={rows[-1]['h1_error']:.3e} "
                f"eff={rows[-1]['effectivity']:.3f} ({time.perf_counter() - t:.1f} s)"
                + (f"; local eta_K/|e|_1,w_K q95 {[round(s['q95'], 2) for s in local]}" if local else ""))
    return {"runs": runs, "efficiency": efficiency}


# --- study 6: local efficiency on the manufactured problem ---------------------------------------------

def local_efficiency(level):
    """Per cell: η_K, the exact local error ‖u − u_h‖_{1,ω_K} over the vertex patch, and the contact term."""
    u, fields = level.u, level.fields
    msh = u.function_space.mesh
    Q = versions.dg0_space(msh)
    w = ufl.TestFunction(Q)
    e = fields.u_exact - u
    dx = ufl.dx(metadata={"quadrature_degree": 8})
    err_K = cell_values((ufl.inner(e, e) + ufl.inner(ufl.grad(e), ufl.grad(e))) * w * dx, Q)
    err_patch = nc.patch_sum(err_K, Q)  # Σ_{K' ⊂ ω_K} ‖e‖²_{1,K'}
    # the contact part of Remark 9's ẽ, per cell: Σ_{E ∈ E_K^C} h_E ‖σ_n(u − u_h)‖_E²
    n = ufl.FacetNormal(msh)
    s_n = nc.normal_stress(nc.sigma(e, fields.lmbda, fields.mu), n)
    dC = fields.ds_of("contact")(metadata={"quadrature_degree": 16})
    contact_K = cell_values(ufl.FacetArea(msh) * s_n ** 2 * w * dC, Q)
    n_owned = len(err_K)
    eta_K = level.estimate.fields["eta"].x.array[:n_owned]
    on_contact = level.estimate.fields["eta_4"].x.array[:n_owned] > 0
    touches = cell_values(w * dC, Q) > 0
    ratio = eta_K / np.sqrt(np.maximum(err_patch, 1e-300))
    ratio_aug = eta_K / (np.sqrt(np.maximum(err_patch, 1e-300)) + np.sqrt(np.maximum(contact_K, 0.0)))
    ratio, ratio_aug, touches = gather_array(ratio), gather_array(ratio_aug), gather_array(touches | on_contact)
    if COMM.rank != 0:
        return None
    q = lambda a, p: float(np.quantile(a, p))  # noqa: E731
    return {"cells": int(len(ratio)), "q05": q(ratio, 0.05), "q50": q(ratio, 0.5), "q95": q(ratio, 0.95),
            "min": float(ratio.min()), "max": float(ratio.max()),
            "contact_q05": q(ratio[touches], 0.05), "contact_q95": q(ratio[touches], 0.95),
            "contact_max": float(ratio[touches].max()),
            "aug_contact_max": float(ratio_aug[touches].max()), "aug_max": float(ratio_aug.max()),
            "hist": np.histogram(np.log10(ratio), bins=40, range=(-1.5, 1.5))[0].tolist()}


# --- study 2: the closed-form 1D problem ----------------------------------------------------------------

CLOSED_FORM = {"a": 2.0, "b": 1.0, "E": 1.0, "nu": 0.3, "w": 0.1, "c": 1.0, "m": 1.5, "g0": 0.01}


def closed_form_solution(p):
    """u = (0, v(y)): v(y) = w y (y − b)/(2L) + s (1 − y/b), s = −(δ + g0), δ from the law at y = 0."""
    from scipy.optimize import brentq
    lmbda, mu = nc.lame(p["E"], p["nu"])
    L = lmbda + 2 * mu
    a, b, w, c, m, g0 = (p[k] for k in ("a", "b", "w", "c", "m", "g0"))

    def F(delta):  # c δ^m + L (δ + g0)/b − w b/2: the law σ_n = −c δ^m with σ_yy(0) = L v'(0)
        return c * delta ** m + L * (delta + g0) / b - w * b / 2

    if F(0.0) >= 0:
        delta = 0.0
    else:
        delta = brentq(F, 0.0, w * b * b / (2 * L), xtol=1e-16, rtol=1e-15, maxiter=200)
    s = -(delta + g0)
    return {"lambda": lmbda, "mu": mu, "L": L, "delta": delta, "s": s, "pressure": c * delta ** m,
            "force": a * c * delta ** m, "F0": F(0.0), "residual": F(delta),
            "top_reaction": w * a * b - a * c * delta ** m}


def closed_form_data(p, s, cells):
    lmbda, mu = nc.lame(p["E"], p["nu"])
    params = dict(p, lam=lmbda, L=lmbda + 2 * mu, s=s)
    vp = "(w/(2*L)*(2*y - b) - s/b)"  # v'(y)
    return {
        "title": "closed form: block hanging from its clamped top onto the foundation",
        "parameters": params,
        "mesh": {"rectangle": [[0.0, 0.0], [p["a"], p["b"]]], "cells": cells, "dirichlet": ["top"],
                 "neumann": ["left", "right"], "contact": ["bottom"]},
        "material": {"E": "E", "nu": "nu"},
        "loads": {"f": ["0", "-w"], "g": {"left": [f"-lam*{vp}", "0"], "right": [f"lam*{vp}", "0"]}},
        "contact": {"c_n": "c", "m_n": "m", "gap": "g0"},
        "exact": {"u": ["0", "w/(2*L)*y*(y - b) + s*(1 - y/b)"]},
    }


def study_closed_form(cfg):
    p = dict(CLOSED_FORM)
    exact = closed_form_solution(p)
    rows = []
    for cells in cfg["meshes"]:
        problem = nc.Problem.from_dict(closed_form_data(p, exact["s"], cells), "closed_form")
        history = nc.adapt(problem, nc.AdaptSettings(refine="none")).history
        r = clean_row(history[0])
        r["mesh"] = cells
        r["contact_force_vector"] = history[0]["contact_force"]
        rows.append(r)
        say(f"  closed form {cells}: force {r['contact_resultant']:.8e} vs {exact['force']:.8e} "
            f"({100 * (r['contact_resultant'] / exact['force'] - 1):+.4f} %)")
    return {"parameters": p, "exact": exact, "rows": rows}


# --- study 3: penalty -> Signorini ---------------------------------------------------------------------

# the block pressed by a traction on the left half of its top only (no weight), flat foundation: contact on
# part of the base. (g_0 must be affine along Γ_C for the penalty limit to be the *nodal* Signorini problem:
# with P1, u_hn − g_0 ≤ 0 at the nodes then means ≤ 0 on the whole edge.)
PENALTY_SET = ['loads.f=["0","0"]', 'loads.g={top=["0","-40*pos(1-x)"]}', 'contact.gap="0"']


def contact_nodal_force(u, fields):
    """Σ_i ∫_Γ_C p φ_i over the contact nodes i that are not on Γ_D: the penalty's discrete contact force as the
    Signorini solver sees it (its multipliers live on the free contact nodes only; on the vertical dofs)."""
    V = u.function_space
    dim, fdim = V.mesh.geometry.dim, V.mesh.topology.dim - 1
    v = ufl.TestFunction(V)
    p = nc.contact_pressure(u, fields)
    vec = fem.petsc.assemble_vector(fem.form(p * v[dim - 1] * nc.contact_measure(fields)))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    tags = fields.domain.facet_tags
    vertical = V.sub(dim - 1)
    contact = fem.locate_dofs_topological(vertical, fdim, tags.indices[np.isin(tags.values, fields.ids["contact"])])
    clamped = fem.locate_dofs_topological(vertical, fdim, tags.indices[np.isin(tags.values, fields.ids["dirichlet"])])
    dofs = np.setdiff1d(contact, clamped)
    dofs = dofs[dofs < V.dofmap.index_map.size_local * dim]
    local = float(np.sum(vec.array[dofs]))
    vec.destroy()
    return COMM.allreduce(local, MPI.SUM)


def study_penalty(cfg):
    return penalty_limit("block", cfg["cells"], PENALTY_SET, cfg["eps"])


def penalty_limit(case, cells, overrides, eps_values):
    """The discrete Signorini solution on the case's mesh (``cells`` per direction) and the penalty solutions
    (m_n = 1, c_n = 1/ε) for each ε, from the largest ε down (each started from the previous one)."""
    from signorini import solve_signorini
    base = [f"mesh.cells={list(cells)}".replace(" ", ""), "contact.m_n=1"] + overrides
    problem = nc.load_problem(case, base + ["contact.c_n=1.0"])
    domain = nc.build_domain(problem, COMM)
    fields, u_S, info = solve_signorini(problem, domain)
    say(f"  Signorini (vinewtonrsls): {info['iterations']} its, {info['reason']}, "
        f"active contact nodes {info['active']}/{info['contact_nodes']}")
    quantities_S = nc.solution_quantities(u_S, fields)
    rows, previous = [], None
    for eps in sorted(eps_values, reverse=True):
        pb = nc.load_problem(case, base + [f"contact.c_n={float(1.0 / eps)!r}"])
        t = time.perf_counter()
        solution = nc.solve(pb, domain, initial=previous)
        fields_e, u_e, stats = solution.fields, solution.u, solution.stats
        diff = fem.Function(u_e.function_space)
        diff.x.array[:] = u_e.x.array - u_S.x.array
        l2 = math.sqrt(nc.integrate(ufl.inner(diff, diff) * ufl.dx, COMM))
        h1 = math.sqrt(l2 ** 2 + nc.integrate(ufl.inner(ufl.grad(diff), ufl.grad(diff)) * ufl.dx, COMM))
        q = nc.solution_quantities(u_e, fields_e)
        n_owned = u_e.function_space.dofmap.index_map.size_local * fields_e.dim
        linf = COMM.allreduce(float(np.max(np.abs(diff.x.array[:n_owned]), initial=0.0)), MPI.MAX)
        nodal = contact_nodal_force(u_e, fields_e)
        rows.append({"eps": eps, "c_n": 1.0 / eps, "h1_diff": h1, "l2_diff": l2, "max_diff": linf,
                     "nodal_force": nodal,
                     "max_penetration": q["max_penetration"], "contact_resultant": q["contact_resultant"],
                     "newton_iterations": stats.newton_iterations, "time": time.perf_counter() - t})
        say(f"  penalty eps={eps:.0e}: |u_eps - u_S|_1 = {h1:.3e}, max penetration {q['max_penetration']:.3e}, "
            f"{stats.newton_iterations} Newton its")
        previous = u_e
    return {"mesh": list(cells), "E": problem["material.E"], "overrides": overrides, "signorini": info,
            "signorini_force": info["reaction"],
            "signorini_quantities": {k: v for k, v in quantities_S.items() if k != "contact_force"},
            "rows": rows}


# --- study 4: Hertz line contact ------------------------------------------------------------------------

def study_hertz(cfg):
    problem = nc.load_problem("hertz")
    settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=cfg["levels"])
    profile = {}

    def on_level(level):  # the nodal (lumped) contact pressure along Γ_C, kept for the last level
        p = nc.contact_projection(nc.contact_pressure(level.u, level.fields), level.fields, "p")
        V = p.function_space
        tags = level.fields.domain.facet_tags
        facets = tags.indices[np.isin(tags.values, level.fields.ids["contact"])]
        dofs = fem.locate_dofs_topological(V, 1, facets)
        dofs = dofs[dofs < V.dofmap.index_map.size_local]
        x = gather_array(V.tabulate_dof_coordinates()[dofs, 0])
        values = gather_array(p.x.array[dofs])
        if COMM.rank == 0:
            order = np.argsort(x)
            profile.update(x=x[order].tolist(), p=values[order].tolist(), level=level.row["level"])

    history = nc.adapt(problem, settings, on_level=on_level).history
    rows = []
    R, E, nu = problem["reference.radius"], problem["material.E"], problem["material.nu"]
    for h in history:
        r = clean_row(h)
        ref = nc.hertz_line_contact(h["contact_resultant"], R, E, nu)
        r["hertz_half_width"], r["hertz_peak_pressure"] = ref["half_width"], ref["peak_pressure"]
        r["half_width"] = h["contact_length"] / 2
        rows.append(r)
        say(f"  hertz level {r['level']}: {r['dofs']} dofs, a = {r['half_width']:.5f} vs {ref['half_width']:.5f}, "
            f"p0 = {r['max_contact_pressure']:.4g} vs {ref['peak_pressure']:.4g}")
    return {"E": E, "nu": nu, "R": R, "c_n": str(problem["contact.c_n"]), "rows": rows, "profile": profile}


# --- study 5: adaptive against uniform on the corner case ---------------------------------------------

def gather_p1(u):
    """(vertex coordinates, triangles, vertex values) of a P1 vector function, on rank 0 (global numbering)."""
    V = u.function_space
    imap = V.dofmap.index_map
    n = imap.size_local
    x = V.tabulate_dof_coordinates()[:n, :2]
    values = u.x.array.reshape(-1, 2)[:n]
    start = imap.local_range[0]
    n_cells = V.mesh.topology.index_map(2).size_local
    cells = imap.local_to_global(versions.cell_dofs(V.dofmap)[:n_cells].ravel()).reshape(-1, 3)
    parts = COMM.gather((start, x, values, cells), root=0)
    if COMM.rank != 0:
        return None
    total = sum(len(p[1]) for p in parts)
    X, U = np.zeros((total, 2)), np.zeros((total, 2))
    for s, xx, vv, _ in parts:
        X[s:s + len(xx)], U[s:s + len(vv)] = xx, vv
    T = np.concatenate([p[3] for p in parts]).astype(np.int64)
    return X, T, U


def study_corner(cfg, out):
    """Adaptive and uniform runs of the corner case; the true H¹ error against an overkill reference: the
    last adaptive mesh (``reference_extra`` levels beyond the compared ones) refined uniformly once."""
    from overlay import difference_norms, nested_difference
    problem = nc.load_problem("corner")
    store = {}

    def recorder(kind):
        def on_level(level):
            data = gather_p1(level.u)
            if data is not None:
                store[(kind, level.row["level"])] = data
        return on_level

    n_adapt = cfg["adaptive_levels"]
    settings = nc.AdaptSettings.from_problem(problem, refine="adaptive", levels=n_adapt + cfg["reference_extra"])
    result_a = nc.adapt(problem, settings, on_level=recorder("adaptive"))
    final, hist_a = result_a.final, result_a.history
    t = time.perf_counter()
    domain_ref = nc.refine(final.fields.domain)
    solution = nc.solve(problem, domain_ref, initial=final.u)
    u_ref, stats = solution.u, solution.stats
    est = nc.estimate(u_ref, solution.fields)
    reference = {"dofs": 2 * domain_ref.num_vertices(), "cells": domain_ref.num_cells(), "eta": est.totals["eta"],
                 "newton_iterations": stats.newton_iterations, "solve_time": time.perf_counter() - t,
                 "from_adaptive_level": len(hist_a) - 1}
    ref = gather_p1(u_ref)
    say(f"  corner reference: {reference['dofs']} dofs, eta = {reference['eta']:.4e}")
    settings_u = nc.AdaptSettings(refine="uniform", levels=cfg["uniform_levels"])
    hist_u = nc.adapt(problem, settings_u, on_level=recorder("uniform")).history
    histories = {"adaptive": [clean_row(r) for r in hist_a[:n_adapt]], "uniform": [clean_row(r) for r in hist_u]}
    result = {"compared_adaptive_levels": n_adapt, "histories": histories, "reference": reference}
    if COMM.rank == 0:
        t = time.perf_counter()
        # adaptive meshes are nested in the reference mesh: exact evaluation at its vertices
        for row in histories["adaptive"]:
            row["l2_error"], row["h1_error"] = nested_difference(store[("adaptive", row["level"])], ref)
        # uniform meshes are not: exact integration on the overlay of the two triangulations
        coverage = 0.0
        for row in histories["uniform"]:
            l2, h1, cov = difference_norms(ref, store[("uniform", row["level"])])
            row["l2_error"], row["h1_error"], coverage = l2, h1, max(coverage, cov)
        # cross-check of the two ways on one nested level
        check_level = min(n_adapt - 1, 4)
        l2, h1, cov = difference_norms(ref, store[("adaptive", check_level)])
        result["error_check"] = {"level": check_level, "overlay_h1": h1,
                                 "nested_h1": histories["adaptive"][check_level]["h1_error"],
                                 "coverage": max(coverage, cov)}
        result["error_time"] = time.perf_counter() - t
        pictures = sorted({2, n_adapt // 2, n_adapt - 1})
        arrays = {}
        for lev in pictures:
            X, T, _ = store[("adaptive", lev)]
            arrays[f"adaptive_{lev:02d}_X"], arrays[f"adaptive_{lev:02d}_T"] = X, T
        X, T, _ = store[("uniform", len(hist_u) - 1)]
        arrays["uniform_X"], arrays["uniform_T"] = X, T
        np.savez_compressed(out.with_suffix(".npz"), **arrays)
        result["meshes"] = str(out.with_suffix(".npz"))
        result["picture_levels"] = pictures
    return result


# --- study 7: parallel invariance ------------------------------------------------------------------------

def study_parallel(cfg):
    problem = manufactured_problem(1.5, 10, 4)
    h1 = nc.adapt(problem, uniform_settings(cfg["manufactured_levels"])).history
    corner = nc.load_problem("corner")
    settings = nc.AdaptSettings.from_problem(corner, refine="adaptive", levels=cfg["corner_levels"])
    h2 = nc.adapt(corner, settings).history
    return {"ranks": COMM.size, "manufactured": [clean_row(r) for r in h1], "corner": [clean_row(r) for r in h2]}


STUDIES = {"manufactured": study_manufactured, "closed_form": study_closed_form,
           "penalty": study_penalty, "hertz": study_hertz, "corner": study_corner, "parallel": study_parallel}


def main(studies=None, config=None, with_output_path=("corner",)):
    """Run one study (the command line above) and write its JSON result; worker3d.py reuses this with its
    own studies and configuration. The studies in ``with_output_path`` also get the result's path."""
    studies, config = studies or STUDIES, config or CONFIG
    parser = argparse.ArgumentParser()
    parser.add_argument("study", choices=sorted(studies))
    parser.add_argument("--mode", choices=("quick", "full"), default="quick")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    out = Path(args.out)
    start = time.perf_counter()
    cfg = config[args.mode][args.study]
    func = studies[args.study]
    try:
        result = func(cfg, out) if args.study in with_output_path else func(cfg)
    except Exception:  # on one rank only, perhaps: the others would wait for it in a collective
        traceback.print_exc()
        sys.stderr.flush()
        COMM.Abort(1)
    result.update({"study": args.study, "mode": args.mode, "ranks": COMM.size, "time": time.perf_counter() - start,
                   "config": cfg})
    if COMM.rank == 0:
        tmp = out.with_name(out.name + ".tmp")
        tmp.write_text(json.dumps(result, indent=1, default=float))
        tmp.replace(out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
