#!/usr/bin/env python3
"""Solver-settings sweep behind the recommendation in benchmarks/README.md.

Runs ``benchmarks/run.py`` (no baselines, no legacy) for named configurations of PETSc options and prints,
per configuration: Newton and Krylov iterations, the nonlinear solve, the linear floor K u = L (CG + GAMG as
in DOLFINx's elasticity demo, the same for every configuration), their ratio, and the same for the
nested-iteration level::

    /usr/bin/python3 benchmarks/sweep.py --problems block box --sizes 1.3e5 --np 1 [--configs ml aggressive-2 ...]

Each configuration is a list of ``run.py`` arguments (``--petsc KEY=VALUE``, ``--preset``,
``--pc-matrix``). Timings are medians over ``--repeat`` runs.
"""
import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
def p(*items):
    return [a for item in items for a in ("--petsc", item)]


IT = ["--preset", "iterative"]
GAMG = IT + p("pc_type=gamg")  # (the iterative preset's BoomerAMG replaced by GAMG, with its settings)
HYPRE_NODAL = p("pc_hypre_boomeramg_nodal_coarsen=6", "pc_hypre_boomeramg_vec_interp_variant=3")
ML = p("pc_type=ml", "pc_ml_reuse_interpolation=true")

CONFIGS = {
    # the shipped defaults (preset "auto") and the two presets
    "shipped": [],
    "iterative": IT,
    "direct": ["--preset", "direct"],
    # the forcing terms (the iterative preset: Eisenstat–Walker version 3, rtol0 0.03, see solver.forcing.Forcing)
    "ew1": IT + p("snes_ksp_ew_version=1"),
    "ew2": IT + p("snes_ksp_ew_version=2"),
    "ew-rtol0-0.1": IT + p("snes_ksp_ew_rtol0=0.1"),
    "ew-rtolmax-0.1": IT + p("snes_ksp_ew_rtolmax=0.1"),
    "ew-rtolmax-0.5": IT + p("snes_ksp_ew_rtolmax=0.5"),
    "no-ew": IT + p("snes_ksp_ew=false"),
    "preconditioned-norm": IT + p("ksp_norm_type=preconditioned"),
    # BoomerAMG variants (the shipped settings: solver.linear.HYPRE_BY_DIM)
    "hypre-nodal": IT + HYPRE_NODAL,
    "hypre-agg1": IT + p("pc_hypre_boomeramg_agg_nl=1"),
    "hypre-agg2": IT + p("pc_hypre_boomeramg_agg_nl=2"),
    "hypre-gs": IT + p("pc_hypre_boomeramg_relax_type_all=symmetric-SOR/Jacobi"),
    "hypre-chebyshev": IT + p("pc_hypre_boomeramg_relax_type_all=Chebyshev"),
    "hypre-thr-0.25": IT + p("pc_hypre_boomeramg_strong_threshold=0.25"),
    "hypre-thr-0.5": IT + p("pc_hypre_boomeramg_strong_threshold=0.5"),
    # GAMG and its tuning
    "gamg": GAMG,
    "thr-0.01": GAMG + p("pc_gamg_threshold=0.01"),
    "thr-0.05": GAMG + p("pc_gamg_threshold=0.05"),
    "square-0": GAMG + p("pc_gamg_square_graph=0"),
    "aggressive-2": GAMG + p("pc_gamg_aggressive_coarsening=2"),
    "aggressive-10": GAMG + p("pc_gamg_aggressive_coarsening=10"),
    "coarse-1000": GAMG + p("pc_gamg_coarse_eq_limit=1000"),
    "coarse-5000": GAMG + p("pc_gamg_coarse_eq_limit=5000"),
    "repartition": GAMG + p("pc_gamg_repartition=true"),
    "nsmooths-0": GAMG + p("pc_gamg_agg_nsmooths=0"),
    "mg-its-3": GAMG + p("mg_levels_ksp_max_it=3"),
    "esteig-20": GAMG + p("mg_levels_ksp_chebyshev_esteig_steps=20"),
    "sa-esteig": GAMG + p("pc_gamg_use_sa_esteig=true", "pc_gamg_reuse_interpolation=false"),
    "no-reuse": GAMG + p("pc_gamg_reuse_interpolation=false"),
    # other AMG
    "ml": IT + ML,
    # the preconditioner's refresh
    "misfit-1": IT + p("pc_refresh_misfit=1"),
    "misfit-0.1": IT + p("pc_refresh_misfit=0.1"),
    "growth-2": IT + p("pc_refresh_growth=2"),
    "bulk": IT + ["--pc-matrix", "bulk"],
    "jacobian": IT + ["--pc-matrix", "jacobian"],
    # the line search
    "no-line-min": IT + p("line_minimisation=false"),
    "bt": IT + p("line_minimisation=false", "snes_linesearch_type=bt"),
}

KEYS = [("dofs", "{}"), ("preset", "{}"), ("nested_preset", "{}"), ("newton", "{}"), ("krylov", "{}"),
        ("t_setup", "{:.2f}"), ("t_solve", "{:.2f}"),
        ("t_pc_setup", "{:.2f}"), ("t_linear", "{:.2f}"), ("linear_its", "{}"), ("ratio_linear", "{:.2f}"),
        ("nested_newton", "{}"), ("nested_krylov", "{}"), ("t_nested_solve", "{:.2f}"),
        ("t_nested_linear", "{:.2f}"), ("ratio_nested", "{:.2f}"), ("energy", "{:.12e}")]


def run(config, problem, size, nprocs, no_nested):
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "rows.json"
        cmd = [sys.executable if sys.executable.startswith("/usr/bin") else "/usr/bin/python3",
               str(HERE / "run.py"), "--np", str(nprocs), "--sizes", size, "--problems", problem, "--baselines",
               "--no-legacy", "--quiet", "--json-out", str(out), *CONFIGS[config]]
        if no_nested:
            cmd.append("--no-nested")
        proc = subprocess.run(cmd, capture_output=True, text=True)
        if proc.returncode != 0:
            return {"error": (proc.stderr.strip().splitlines() or ["?"])[-1][:100]}
        return json.loads(out.read_text())[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--configs", nargs="+", default=list(CONFIGS), choices=list(CONFIGS))
    ap.add_argument("--problems", nargs="+", default=["block"], choices=("block", "corner", "box"))
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
