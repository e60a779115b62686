"""Uniform against Dörfler-adaptive refinement on nc_dolfinx/cases/manufactured_friction_layer.toml (the 2D
manufactured frictional solution plus a narrow interior Gaussian bump) or, with --3d, on
manufactured_friction_layer3d.toml: the H¹ error, its rate, the effectivity η/‖u − u_h‖_1 and, for each
adaptive level, the uniform dofs that reach the same error (log-log interpolation between uniform levels)
and their ratio to the adaptive dofs. Serial; prints Markdown.

    PYTHONPATH=. /usr/bin/python3 verification/manufactured_friction_layer.py [--3d] [--quick]

--quick: uniform to 64×64 (16³) only (a smoke run); the full run goes to 256×256 (32³).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from common import loglog_interpolate  # noqa: E402
from manufactured_friction import adaptive_table, run, uniform_table  # noqa: E402

# dimension -> (case, its coarsest mesh, uniform levels of the full run, of --quick)
CASES = {2: ("manufactured_friction_layer", "8×8", 6, 4), 3: ("manufactured_friction_layer3d", "4³", 4, 3)}


def header(argv):
    from common import provenance
    print("# Manufactured frictional solution with an interior bump: uniform against adaptive\n")
    print("\n".join(provenance("manufactured_friction_layer.py", argv)))
    print()


def uniform_dofs_for(error, uniform):
    """The dofs a uniform mesh needs for ``error`` (between the uniform levels; None outside their range)."""
    return loglog_interpolate(error, [r["h1_error"] for r in uniform], [r["dofs"] for r in uniform])


def savings_table(adaptive, uniform):
    print("| adaptive level | dofs | ‖u−u_h‖_1 | η/‖u−u_h‖_1 | uniform dofs for this error "
          "| uniform/adaptive dofs |")
    print("|---|---|---|---|---|---|")
    for r in adaptive:
        need = uniform_dofs_for(r["h1_error"], uniform)
        need_text, ratio = ("–", "–") if need is None else (f"{need:.0f}", f"{need / r['dofs']:.2f}")
        print(f"| {r['level']} | {r['dofs']} | {r['h1_error']:.4e} | {r['eta'] / r['h1_error']:.3f} | "
              f"{need_text} | {ratio} |")
    print()


def main(argv):
    quick = "--quick" in argv
    dim = 3 if "--3d" in argv else 2
    case, coarsest, full_levels, quick_levels = CASES[dim]
    header(argv)
    levels = quick_levels if quick else full_levels
    print(f"## Uniform, {coarsest}, {levels} levels\n")
    uniform, seconds = run(case, "--refine", "uniform", "--levels", str(levels))
    uniform_table(uniform, dim, seconds)
    print(f"## Dörfler θ = 0.5 from {coarsest}, against uniform at the same dofs\n")
    adaptive, seconds = run(case, "--refine", "adaptive", "--theta", "0.5", "--levels", "30",
                            "--max-dofs", str(uniform[-1]["dofs"]))
    adaptive_table(adaptive, uniform, seconds)
    print("## The uniform dofs needed for each adaptive error\n")
    savings_table(adaptive, uniform)


if __name__ == "__main__":
    main(sys.argv[1:])
