#!/usr/bin/env python3
"""Solver-settings sweep behind the recommendation in benchmarks/README.md.

Runs ``benchmarks/run.py`` (no baselines, no legacy) for named configurations of PETSc options and prints,
per configuration: Newton and Krylov iterations, the nonlinear solve, the linear solve K u = L with the same
options, their ratio, and the same for the nested-iteration level::

    /usr/bin/python3 benchmarks/sweep.py --problems block --sizes 1.3e5 --np 1 [--configs ew1 ew1-ns ...]

Each configuration is a list of ``run.py`` arguments (``--petsc KEY=VALUE``, ``--preset``,
``--pc-matrix``, ``--nullspace-on-K``). Timings are medians over ``--repeat`` runs.
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
EW = ["--petsc", "snes_ksp_ew=true", "--petsc", "snes_linesearch_type=basic"]


def ew(version, rtol0=None, extra=()):
    args = EW + ["--petsc", f"snes_ksp_ew_version={version}"]
    if rtol0 is not None:
        args += ["--petsc", f"snes_ksp_ew_rtol0={rtol0}"]
    return args + list(extra)


HYPRE = ["--petsc", "pc_type=hypre", "--petsc", "pc_hypre_type=boomeramg",
         "--petsc", "pc_hypre_boomeramg_nodal_coarsen=6", "--petsc", "pc_hypre_boomeramg_vec_interp_variant=3",
         "--petsc", "pc_hypre_boomeramg_strong_threshold=0.5", "--petsc", "pc_hypre_boomeramg_coarsen_type=HMIS",
         "--petsc", "pc_hypre_boomeramg_interp_type=ext+i", "--petsc", "pc_hypre_boomeramg_agg_nl=1"]


def p(*items):
    return [a for item in items for a in ("--petsc", item)]


E3 = ew(3)
BULK = ["--pc-matrix", "bulk"]

CONFIGS = {
    # the presets as they are (the problem's preconditioner_matrix, "auto" since the lead's change)
    "iterative": [],
    "iterative-bulk": BULK,
    "direct": ["--preset", "direct"],
    # line search alone (exact linear solves)
    "basic": p("snes_linesearch_type=basic"),
    "cp": p("snes_linesearch_type=cp"),
    # Eisenstat-Walker (bt line search with inexact steps can fail: DIVERGED_LINE_SEARCH)
    "ew1": ew(1, 0.3),
    "ew2": ew(2, 0.3),
    "ew3": E3,
    "ew1-bulk": ew(1, 0.3) + BULK,
    "ew3-bulk": E3 + BULK,
    "ew3-r05": E3 + p("snes_ksp_ew_rtol0=0.5"),
    "ew3-r01": E3 + p("snes_ksp_ew_rtol0=0.1"),
    "ew3-cp": E3 + p("snes_linesearch_type=cp"),
    "ew3-unprec": E3 + p("ksp_norm_type=unpreconditioned"),
    # GAMG tuning (with EW v3)
    "ew3-thr01": E3 + p("pc_gamg_threshold=0.01"),
    "ew3-thr02": E3 + p("pc_gamg_threshold=0.02"),
    "ew3-thr05": E3 + p("pc_gamg_threshold=0.05"),
    "ew3-sq0": E3 + p("pc_gamg_square_graph=0"),
    "ew3-bulk-sq0": E3 + BULK + p("pc_gamg_square_graph=0"),
    "ew3-bulk-mg3": E3 + BULK + p("mg_levels_ksp_max_it=3"),
    "ew3-bulk-sq0-mg3": E3 + BULK + p("pc_gamg_square_graph=0", "mg_levels_ksp_max_it=3"),
    "ew3-bulk-thr02": E3 + BULK + p("pc_gamg_threshold=0.02"),
    "ew3-bulk-esteig": E3 + BULK + p("pc_gamg_esteig_ksp_type=cg", "pc_gamg_esteig_ksp_max_it=5"),
    "ew3-sq10": E3 + p("pc_gamg_square_graph=10"),
    "ew3-mg1": E3 + p("mg_levels_ksp_max_it=1"),
    "ew3-mg3": E3 + p("mg_levels_ksp_max_it=3"),
    "ew3-sor": E3 + p("mg_levels_pc_type=sor"),
    "ew3-nsm0": E3 + p("pc_gamg_agg_nsmooths=0"),
    "ew3-esteig": E3 + p("pc_gamg_esteig_ksp_type=cg", "pc_gamg_esteig_ksp_max_it=5"),
    "ew3-coarse": E3 + p("pc_gamg_coarse_eq_limit=1000"),
    # hypre BoomerAMG with nodal coarsening
    "ew3-hypre": E3 + HYPRE,
    "hypre": HYPRE,
    # direct preset variants
    "direct-ew3": ["--preset", "direct"] + E3,
    "direct-ew3-icntl7-5": ["--preset", "direct"] + E3 + p("mat_mumps_icntl_7=5"),
    "direct-ew3-icntl7-0": ["--preset", "direct"] + E3 + p("mat_mumps_icntl_7=0"),
    "direct-ew3-petsc": ["--preset", "direct"] + E3 + p("pc_factor_mat_solver_type=petsc",
                                                       "pc_factor_mat_ordering_type=nd"),
    # preconditioner from the Jacobian (rebuilt every Newton step)
    "ew3-jac": E3 + ["--pc-matrix", "jacobian"],
    "ew3-jac-reuse": E3 + ["--pc-matrix", "jacobian"] + p("pc_gamg_reuse_interpolation=true"),
    # ... built once from J(u_0) (the transferred solution on a nested level, K on a cold start)
    "ew3-jac-lag": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=-1"),
    "ew3-jac-once": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=100"),
    "ew3-jac-once-sq0": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=100",
                                                             "pc_gamg_square_graph=0"),
    "ew3-jac-once-mg3": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=100",
                                                             "mg_levels_ksp_max_it=3"),
    "tr": BULK + p("snes_type=newtontr"),
    "ew3-tr": ew(3) + BULK + p("snes_type=newtontr"),
    "ew3-fischer": E3 + BULK + p("ksp_guess_type=fischer", "ksp_guess_fischer_model=1,10"),
    "ew3-fischer2": E3 + BULK + p("ksp_guess_type=fischer", "ksp_guess_fischer_model=2,10"),
    "ew3-jac-lag3-reuse": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=3",
                                                               "pc_gamg_reuse_interpolation=true"),
    "ew3-jac-lag5-reuse": E3 + ["--pc-matrix", "jacobian"] + p("snes_lag_preconditioner=5",
                                                               "pc_gamg_reuse_interpolation=true"),
}

KEYS = [("dofs", "{}"), ("pc_mode", "{}"), ("nested_pc_mode", "{}"), ("newton", "{}"), ("krylov", "{}"),
        ("t_setup", "{:.2f}"), ("t_solve", "{:.2f}"),
        ("t_pc_setup", "{:.2f}"), ("t_linear", "{:.2f}"), ("linear_its", "{}"), ("ratio_linear", "{:.2f}"),
        ("nested_newton", "{}"), ("nested_krylov", "{}"), ("t_nested_solve", "{:.2f}"),
        ("t_nested_linear", "{:.2f}"), ("ratio_nested", "{:.2f}"), ("energy", "{:.12e}")]


def run(config, problem, size, nprocs, no_nested):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        cmd = [sys.executable if sys.executable.startswith("/usr/bin") else "/usr/bin/python3",
               str(HERE / "run.py"), "--np", str(nprocs), "--sizes", size, "--problems", problem, "--baselines",
               "--no-legacy", "--quiet", "--json-out", str(out), "--settings", "shipped", *CONFIGS[config]]
        if no_nested:
            cmd.append("--no-nested")
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            return {"error": (proc.stderr.strip().splitlines() or ["?"])[-1][:100]}
        return json.loads(out.read_text())[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--problems", nargs="+", default=["block"])
    ap.add_argument("--sizes", nargs="+", default=["1.3e5"])
    ap.add_argument("--np", type=int, nargs="+", default=[1])
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--no-nested", action="store_true")
    args = ap.parse_args()
    header = ["config", "problem", "np"] + [k for k, _ in KEYS]
    print("  ".join(header), flush=True)
    for problem in args.problems:
        for size in args.sizes:
            for nprocs in args.np:
                for config in args.configs:
                    rows = [run(config, problem, size, nprocs, args.no_nested) for _ in range(args.repeat)]
                    if "error" in rows[0]:
                        print(f"{config}  {problem}  {nprocs}  ERROR {rows[0]['error']}", flush=True)
                        continue
                    cells = [config, problem, str(nprocs)]
                    for key, fmt in KEYS:
                        values = [r.get(key) for r in rows]
                        if values[0] is None:
                            cells.append("-")
                        elif isinstance(values[0], float) and key != "energy":
                            cells.append(fmt.format(statistics.median(values)))
                        else:
                            cells.append(fmt.format(values[0]))
                    print("  ".join(cells), flush=True)


if __name__ == "__main__":
    main()
