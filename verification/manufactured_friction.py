"""Convergence study of the manufactured frictional cases (nc_dolfinx/cases/manufactured_friction.toml and
manufactured_friction3d.toml): uniform refinement (H¹ error and its rate against dofs, the effectivity
η/|u − u_h|_1, η_3's share, the friction force against its exact value, the stick zone's measure) and
Dörfler-adaptive (θ = 0.5) against uniform at comparable dofs. Serial; prints Markdown tables.

    PYTHONPATH=. /usr/bin/python3 verification/manufactured_friction.py [--quick]

--quick: 2D only, one level fewer (a smoke run).
"""
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


ROOT = Path(__file__).resolve().parent.parent
PYTHON = "/usr/bin/python3"

# exact ∫_Γ_C s_t (first component; s_t = −G Δu_t in both zones, G = E/(2(1 + ν)) = 1/2.6):
# 2D: −G S ∫_0^1 (x − x0)(1 + x) dx = −G S (1/3 + (1 − x0)/2 − x0);  3D: −G S ∫∫ (x − x0)(1 + y) = −G S (1/2 − x0)(3/2)
G, S, X0 = 1 / 2.6, 0.01, 0.4
EXACT_FORCE = {2: -G * S * (1 / 3 + (1 - X0) / 2 - X0), 3: -G * S * (0.5 - X0) * 1.5}


def run(case, *options):
    """Run the CLI on ``case`` serially; returns (history rows, seconds)."""
    with tempfile.TemporaryDirectory() as folder:
        env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1")
        start = time.perf_counter()
        proc = subprocess.run([PYTHON, str(ROOT / "run_cases.py"), case, "--out", folder, "--overwrite", "--quiet",
                               *options], env=env, capture_output=True, text=True, cwd=ROOT)
        seconds = time.perf_counter() - start
        if proc.returncode != 0:
            sys.exit(f"{case} {' '.join(options)} failed:\n{proc.stdout}\n{proc.stderr}")
        return json.loads((Path(folder) / "history.json").read_text()), seconds


def header(argv):
    from common import provenance
    print("# Manufactured frictional solutions: convergence\n")
    print("\n".join(provenance("manufactured_friction.py", argv)))
    print()


def uniform_table(rows, dim, seconds):
    measure = "stick_length" if dim == 2 else "stick_area"
    print("| level | dofs | ‖u−u_h‖_1 | rate (dofs) | rate (h) | η | η/‖u−u_h‖_1 | η_3 | η_3²/η² | η_4²/η² | friction force rel. error | stick |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for i, r in enumerate(rows):
        ratio = math.log(r["h1_error"] / rows[i - 1]["h1_error"]) if i else None
        rate = "–" if i == 0 else f"{ratio / math.log(r['dofs'] / rows[i - 1]['dofs']):.3f}"
        # h ∝ cells^(−1/dim) under uniform refinement
        h_rate = "–" if i == 0 else f"{-dim * ratio / math.log(r['cells'] / rows[i - 1]['cells']):.3f}"
        force = abs(r["friction_force"][0] - EXACT_FORCE[dim]) / abs(EXACT_FORCE[dim])
        print(f"| {r['level']} | {r['dofs']} | {r['h1_error']:.4e} | {rate} | {h_rate} | {r['eta']:.4e} | "
              f"{r['eta'] / r['h1_error']:.3f} | {r['eta_3']:.3e} | {(r['eta_3'] / r['eta']) ** 2:.2e} | "
              f"{(r['eta_4'] / r['eta']) ** 2:.2e} | {force:.2e} | {r.get(measure, float('nan')):.4f} |")
    # 2D: the last three levels; 3D (three levels in all): the last two, the first step from 6×6×6 being
    # preasymptotic (its rate in h is 1.3)
    from common import fitted_slope  # (imported here: see adaptive_table)
    fit = rows[-min(3 if dim == 2 else 2, len(rows)):]
    last = len(fit)
    slope = fitted_slope([r["dofs"] for r in fit], [r["h1_error"] for r in fit])
    eta_slope = fitted_slope([r["dofs"] for r in fit], [r["eta"] for r in fit])
    h_slope = fitted_slope([r["cells"] ** (-1 / dim) for r in fit], [r["h1_error"] for r in fit])
    print(f"\nfitted over the last {last} levels: ‖u−u_h‖_1 ∝ dofs^{slope:.3f} (optimal: −1/{dim} = {-1 / dim:.3f}) "
          f"= h^{h_slope:.3f}, η ∝ dofs^{eta_slope:.3f}; {seconds:.1f} s\n")


def adaptive_table(adaptive, uniform, seconds):
    # (imported here: checks_friction imports this module for EXACT_FORCE in processes where benchmarks/
    # common.py may already be `common`; only the scripts that print this table need verification's)
    from common import loglog_interpolate
    print("| level | dofs | ‖u−u_h‖_1 | η/‖u−u_h‖_1 | η_3²/η² | uniform ‖u−u_h‖_1 at these dofs | adaptive/uniform |")
    print("|---|---|---|---|---|---|---|")
    for r in adaptive:
        ref = loglog_interpolate(r["dofs"], [u["dofs"] for u in uniform], [u["h1_error"] for u in uniform])
        if ref is not None:
            ref_text, ratio = f"{ref:.4e}", f"{r['h1_error'] / ref:.3f}"
        else:
            ref_text = ratio = "–"
        print(f"| {r['level']} | {r['dofs']} | {r['h1_error']:.4e} | {r['eta'] / r['h1_error']:.3f} | "
              f"{(r['eta_3'] / r['eta']) ** 2:.2e} | {ref_text} | {ratio} |")
    print(f"\n{seconds:.1f} s\n")


def main(argv):
    quick = "--quick" in argv
    header(argv)
    levels_2d = 4 if quick else 5
    print(f"## 2D: manufactured_friction, 8×8 → uniform, {levels_2d} levels\n")
    uniform, seconds = run("manufactured_friction", "--refine", "uniform", "--levels", str(levels_2d))
    uniform_table(uniform, 2, seconds)
    print("## 2D: Dörfler θ = 0.5 against uniform\n")
    adaptive, seconds = run("manufactured_friction", "--refine", "adaptive", "--theta", "0.5", "--levels", "12",
                            "--max-dofs", str(uniform[-1]["dofs"]))
    adaptive_table(adaptive, uniform, seconds)
    if quick:
        return
    print("## 3D: manufactured_friction3d, 6×6×6 → uniform, 3 levels\n")
    uniform, seconds = run("manufactured_friction3d", "--refine", "uniform", "--levels", "3", "--set", "mesh.cells=[6,6,6]")
    uniform_table(uniform, 3, seconds)
    print("## 3D: Dörfler θ = 0.5 against uniform\n")
    adaptive, seconds = run("manufactured_friction3d", "--refine", "adaptive", "--theta", "0.5", "--levels", "8",
                            "--set", "mesh.cells=[6,6,6]",
                            "--max-dofs", str(uniform[-1]["dofs"]))
    adaptive_table(adaptive, uniform, seconds)


if __name__ == "__main__":
    main(sys.argv[1:])
