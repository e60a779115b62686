#!/usr/bin/env python3
"""Two deformable bodies ([[pairs]], issue 47): a frictionless two-body solve against one linear solve.

    /usr/bin/python3 benchmarks/two_bodies.py [--np 1 2] [--problems two_cylinders sphere_on_block large]
                                              [--repeat 2] [--smoke]

Problems: the built-in cases ``two_cylinders`` and ``sphere_on_block`` on their shipped meshes refined once
uniformly, and ``large``: two_cylinders on a finer mesh of meshes/two_bodies.py (``--h``, ``--h-contact``),
also refined once. Each in its own process (``--worker``), on 1 and 2 ranks, timed as benchmarks/family.py
times its members (its ``measure``: the fastest of ``--repeat`` alternating pairs after an untimed one):

- ``floor``: one linear elasticity solve of BOTH bodies on the same mesh (``common.LinearFloor``: the
  problem's material, loads and Dirichlet conditions, no pair; CG + AMG with the rigid-body near-nullspace,
  PC set-up included, assembly not). ``ratio`` is against the floor with the solver's own preconditioner
  (``pc``: the shipped preset "auto" takes a MUMPS Cholesky factorisation on small problems, then the floor
  is CG + the same factorisation, one step; hypre BoomerAMG spelled as the solver sets it up when it is
  hypre; GAMG when GAMG); ``ratio_gamg`` against demo_elasticity.py's GAMG floor, for context;
- ``cold``: ``nc.solve`` from u = 0 (SNES time: Newton to the solver's tolerance), the pair's search and
  gap operator B (``setup``: the rest of the call, binding, forms, K, the search) not included; ``setup``
  is shown, and ``ratio_total`` = (setup + solve) / floor;
  The cases' ``[mesh.shapes]`` are dropped (the refined mesh keeps its chords: the same mesh for all).
- ``nested``: the adaptive loop's next level: the same mesh solved from the parent's solution (the
  shipped mesh's solution, transferred by ``nc.solve(initial=...)``).

Targets: cold <= 2x one linear solve, nested <= 1x. The table prints date, commit, machine, command; the
machine is shared and loaded, so the ratios (both times in one process, back to back) are what to read.
"""
import argparse
import copy
import datetime
import json
import math
import os
import platform
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (ROOT, commit, dofs, format_table, launch, machine_load, refine_uniformly,  # noqa: E402
                    run_harness)

PROBLEMS = ("two_cylinders", "sphere_on_block", "large")
TARGET_COLD, TARGET_NESTED = 2.0, 1.0


def build(name, args, comm):
    """(problem, parent domain) of ``name``: the case, refine none, on its mesh (``large``: a finer mesh)."""
    import nc_dolfinx as nc
    case = "sphere_on_block" if name == "sphere_on_block" else "two_cylinders"
    problem = nc.load_problem(case, ["adapt.refine=\"none\""])
    raw = copy.deepcopy(problem.raw)
    raw["mesh"].pop("shapes", None)  # uniform refinement's midpoints stay on the chords: the same mesh for all
    raw["mesh"]["file"] = str(Path(args.tmp) / "two_cylinders_large.msh") if name == "large" else \
        str(problem["mesh.file"])
    problem = nc.Problem.from_dict(raw, problem.name)
    return problem, nc.build_domain(problem, comm)


def write_large_mesh(args):
    sys.path.insert(0, str(ROOT / "meshes"))
    import two_bodies
    two_bodies.two_cylinders_2d(str(Path(args.tmp) / "two_cylinders_large.msh"), h=args.h, h_contact=args.h_contact)


# the solver's direct preset (nc_dolfinx.solver.linear.PRESETS["direct"]), spelled out: the floor's factorisation
DIRECT = {"ksp_type": "cg", "pc_type": "cholesky", "pc_factor_mat_solver_type": "mumps", "mat_mumps_icntl_7": 2}


def floor_with(pc, problem, domain, repeat, timed):
    """The floor's time with the solver's preconditioner ``pc``: hypre and GAMG as ``family.measure`` timed
    them (``timed``), a Cholesky factorisation (MUMPS) timed here, the fastest of ``repeat`` + 1 after one."""
    if pc == "hypre":
        return timed["t_floor_hypre"]
    if pc not in ("cholesky", "lu"):
        return timed["t_floor"]
    from common import LinearFloor
    floor = LinearFloor(problem, domain)
    seconds = min(floor.solve(settings=DIRECT, amg="direct")[0] for _ in range(repeat + 2))
    floor.destroy()
    return seconds


def worker(args):
    import nc_dolfinx as nc
    from mpi4py import MPI
    from family import measure
    comm = MPI.COMM_WORLD
    problem, parent = build(args.problem, args, comm)
    child = refine_uniformly(parent)
    row = {"problem": args.problem, "np": comm.size, "dofs": dofs(child), "parent_dofs": dofs(parent)}
    cold, solution = measure(problem, child, comm, args.repeat)
    floor = floor_with(cold.get("pc_type"), problem, child, args.repeat, cold)
    row.update(pc=cold.get("pc_type"), preset=cold.get("preset"), reason=cold.get("reason"),
               newton=cold.get("newton"), krylov=cold.get("krylov"), pc_setups=cold.get("pc_setups"),
               floor_its=cold.get("floor_its"),
               t_floor=floor, t_solve=cold["t_solve"], t_setup=cold["t_setup"],
               ratio=cold["t_solve"] / floor, ratio_gamg=cold["t_solve"] / cold["t_floor"],
               ratio_total=(cold["t_solve"] + cold["t_setup"]) / floor)
    q = nc.solution_quantities(solution.u, solution.fields)
    row["pair_force"] = q["pair1_force"][-1]
    u_parent = nc.solve(problem, parent).u
    nested, _ = measure(problem, child, comm, args.repeat, initial=u_parent)
    floor = floor_with(nested.get("pc_type"), problem, child, args.repeat, nested)
    row.update(nested_pc=nested.get("pc_type"), nested_newton=nested.get("newton"),
               nested_krylov=nested.get("krylov"), nested_solve=nested["t_solve"],
               nested_ratio=nested["t_solve"] / floor,
               nested_ratio_total=(nested["t_solve"] + nested["t_setup"]) / floor)
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row, indent=1, default=str))


COLUMNS = [("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"), ("pc", "pc", "{}"),
           ("newton", "Newton", "{}"), ("krylov", "Krylov", "{}"), ("pc_setups", "PC set-ups", "{}"),
           ("floor_its", "floor its", "{}"),
           ("t_floor", "floor s", "{:.3f}"), ("t_solve", "cold s", "{:.3f}"), ("t_setup", "setup s", "{:.3f}"),
           ("ratio", "cold x floor", "{:.2f}"), ("ratio_gamg", "x GAMG floor", "{:.2f}"),
           ("ratio_total", "(cold+setup) x floor", "{:.2f}"), ("nested_pc", "nested pc", "{}"),
           ("nested_newton", "nested Newton", "{}"),
           ("nested_ratio", "nested x floor", "{:.2f}"), ("nested_ratio_total", "(nested+setup) x floor", "{:.2f}"),
           ("load", "load", "{:.1f}")]


def header(argv):
    return (f"date: {datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC; commit: {commit()}; "
            f"machine: {platform.node()} {platform.machine()}, {os.cpu_count()} CPUs, load {machine_load():.1f}; "
            f"command: benchmarks/two_bodies.py {' '.join(argv)}")


def driver(args, argv):
    if args.smoke:
        args.problems, args.np, args.repeat = ["two_cylinders"], [1], 1
    tmp = tempfile.mkdtemp(prefix="nc_two_bodies_")
    args.tmp = tmp
    if "large" in args.problems:
        write_large_mesh(args)
    rows = []
    for name in args.problems:
        for nprocs in args.np:
            out = Path(tmp) / f"{name}_{nprocs}.json"
            cmd = [Path(__file__).resolve(), "--worker", "--problem", name, "--repeat", args.repeat, "--tmp", tmp,
                   "--json", out]
            proc = launch(cmd, nprocs, args.timeout)
            if proc.returncode != 0:
                print(f"{name} on {nprocs} rank(s) FAILED:\n{proc.stderr[-3000:]}", file=sys.stderr)
                row = {"problem": name, "np": nprocs, "reason": "FAILED"}
            else:
                row = json.loads(out.read_text())
            row["load"] = machine_load()
            rows.append(row)
            print(f"  {name} np={nprocs}: cold {row.get('ratio', math.nan):.2f}x, nested "
                  f"{row.get('nested_ratio', math.nan):.2f}x", file=sys.stderr, flush=True)
    print(header(argv))
    print()
    print(format_table(rows, COLUMNS))
    print()
    for r in rows:
        if "ratio" not in r:
            print(f"{r['problem']} np={r['np']}: FAILED")
            continue
        cold = "meets" if r["ratio"] <= TARGET_COLD else "MISSES"
        nested = "meets" if r["nested_ratio"] <= TARGET_NESTED else "MISSES"
        print(f"{r['problem']} np={r['np']} ({r['dofs']} dofs): cold {r['ratio']:.2f}x ({cold} <= {TARGET_COLD:g}x), "
              f"nested {r['nested_ratio']:.2f}x ({nested} <= {TARGET_NESTED:g}x)")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(rows, indent=1, default=str))
    return 0 if all("ratio" in r for r in rows) else 1


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=PROBLEMS)
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--repeat", type=int, default=2, help="timed (floor, solve) pairs per process")
    p.add_argument("--h", type=float, default=1 / 40, help="large: the size far from the contact")
    p.add_argument("--h-contact", type=float, default=1 / 800, help="large: the size near the contact point")
    p.add_argument("--smoke", action="store_true", help="two_cylinders only, 1 rank, one repeat")
    return run_harness(p, argv, worker, lambda args: driver(args, argv), hidden=("--problem", "--tmp", "--json"))


if __name__ == "__main__":
    sys.exit(main())
