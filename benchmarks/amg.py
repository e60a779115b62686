#!/usr/bin/env python3
"""Which AMG for CG (issue 13): one linear elasticity solve per preconditioner, on the family's meshes.

    /usr/bin/python3 benchmarks/amg.py [--np 1 2] [--bodies square cube ...] [--repeat 2]

The linear part of every Newton step is a CG solve with J = K + j_n'(u) ≈ K; this harness times the
preconditioners the solver could use on K u = L of the family's bodies (``family.py``: the unit square at
132,098 dofs, the unit cube at 107,811 dofs, each also of two materials E 1 : 1000), on the generated mesh
and on the mesh of half the cells refined once uniformly by Plaza (the same dofs: what the adaptive loop's
nested levels solve on). Each solve starts from zero, PC set-up included, to the accuracy Newton stops at
(true residual 1e-10 ‖L‖; ``--rtol``), against the issue's linear floor (GAMG as DOLFINx's elasticity demo
sets it up, CG to its default preconditioned rtol 1e-8). The preconditioners:

- ``gamg``:   DOLFINx's demo settings (benchmarks/common.py, FLOOR_OPTIONS);
- ``hypre``:  BoomerAMG as the solver sets it up in that dimension (common.FLOOR_HYPRE: the solver's);
- ``hypre_before``: BoomerAMG as the solver set it up before (one aggressive level, θ 0.5, hybrid Gauss–Seidel).

Every (body, mesh) runs in its own process per rank count; each timed solve follows an untimed one, and
the fastest of ``--repeat`` is kept. Prints one table.
"""
import argparse
import json
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (FLOOR_HYPRE, FLOOR_RTOL, LinearFloor, dofs, format_table, launch, machine_load,  # noqa: E402
                    refine_uniformly, run_harness)
import family  # noqa: E402

# (the settings before, the same in 2D and 3D: the 3D ones with one aggressive level and Gauss–Seidel)
BEFORE = {**FLOOR_HYPRE[3], "pc_hypre_boomeramg_agg_nl": 1, "pc_hypre_boomeramg_strong_threshold": 0.5,
          "pc_hypre_boomeramg_relax_type_all": "symmetric-SOR/Jacobi"}
VARIANTS = {"gamg": None, "hypre": None, "hypre_before": BEFORE}
BODIES = {"square": "1-1", "two_materials": "two-1e4-1", "cube": "3d-1-1", "two_materials_cube": "3d-two-1e4-1"}


def worker(args):
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    member = next(m for m in family.MEMBERS if m.name == BODIES[args.body])
    cells = family.CELLS[member.dim] if not args.small else family.SMOKE_CELLS[member.dim]
    if args.mesh == "generated":
        problem, domain = family.member_problem(member, cells, comm, args.tmp)
    else:
        problem, parent = family.member_problem(member, cells // 2, comm, args.tmp)
        domain = refine_uniformly(parent)
    floor = LinearFloor(problem, domain)
    row = {"body": args.body, "mesh": args.mesh, "np": comm.size, "dofs": dofs(domain)}
    runs = [("floor", "gamg", None, FLOOR_RTOL, "preconditioned")]
    runs += [(name, name, settings, args.rtol, "unpreconditioned") for name, settings in VARIANTS.items()]
    for label, amg, settings, rtol, norm in runs:
        timed = [floor.solve(rtol, norm, amg, settings) for _ in range(args.repeat + 1)][1:]  # (one untimed)
        row[f"t_{label}"], row[f"its_{label}"], row[f"residual_{label}"] = min(timed)
    floor.destroy()
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row))


COLUMNS = [("body", "body", "{}"), ("mesh", "mesh", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
           ("t_floor", "floor", "{:.3f}"), ("its_floor", "its", "{}")]
for _name in VARIANTS:
    COLUMNS += [(f"t_{_name}", _name, "{:.3f}"), (f"its_{_name}", "its", "{}"), (f"x_{_name}", "/floor", "{:.2f}")]


def driver(args):
    tmp = tempfile.mkdtemp(prefix="nc_amg_")
    if any(b == "two_materials" for b in args.bodies):
        cells = family.SMOKE_CELLS[2] if args.small else family.CELLS[2]
        for c in (cells, cells // 2):
            family.write_two_materials_mesh(Path(tmp) / f"two_materials_{c}.msh", c)
    rows = []
    print(f"load average at the start: {machine_load():.2f}", file=sys.stderr, flush=True)
    for body in args.bodies:
        for mesh in args.meshes:
            for nprocs in args.np:
                out = Path(tmp) / f"{body}_{mesh}_{nprocs}.json"
                cmd = [Path(__file__).resolve(), "--worker", "--body", body, "--mesh", mesh, "--tmp", tmp,
                       "--json", out, "--repeat", args.repeat, "--rtol", args.rtol]
                cmd += ["--small"] if args.small else []
                proc = launch(cmd, nprocs, args.timeout)
                if proc.returncode != 0:
                    print(f"{body} {mesh} np={nprocs} FAILED:\n{proc.stderr[-2000:]}", file=sys.stderr)
                    continue
                row = json.loads(out.read_text())
                for name in VARIANTS:
                    row[f"x_{name}"] = row[f"t_{name}"] / row["t_floor"]
                rows.append(row)
                print(f"  {body} {mesh} np={nprocs} done (load {machine_load():.2f})", file=sys.stderr, flush=True)
    print(format_table(rows, COLUMNS))
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(rows, indent=1))
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--bodies", nargs="+", default=list(BODIES), choices=list(BODIES))
    p.add_argument("--meshes", nargs="+", default=["generated", "refined"], choices=("generated", "refined"))
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--rtol", type=float, default=1e-10, help="true-residual tolerance of the compared solves")
    p.add_argument("--small", action="store_true", help="the family's smoke sizes (seconds: for the tests)")
    return run_harness(p, argv, worker, driver, hidden=("--body", "--mesh", "--tmp", "--json"))


if __name__ == "__main__":
    sys.exit(main())
