#!/usr/bin/env python3
"""The adaptive loop timed level by level (issues 10 and 13): ``nc.adapt`` with Dörfler marking to a dof budget.

    /usr/bin/python3 benchmarks/adaptive.py --problem box --np 2 --max-dofs 1e6 [--floor] [--csv F]

Runs ``nc.adapt(problem, AdaptSettings(refine="adaptive", theta=0.5, max_dofs=...))`` — the public API, the
shipped solver defaults — on ``box`` (3D, the data of the box case from ``--cells`` = [8, 4, 4]) or ``block``
(2D) under mpirun, and prints per level: dofs, Newton/Krylov iterations and the preset ``auto`` chose, the
phase times the loop records (``time_solve`` = the whole ``nc.solve`` call, split into set-up and the SNES
time ``stats.time``; ``time_estimate``, ``time_mark``; ``time_refine``, the refinement that made the
level's mesh), and, measured inside ``on_level`` (outside those phases):

- ``dolfinx``: DOLFINx's own ``dolfinx.mesh.refine`` of the same marked cells (children kept on their
  parent's rank, as ``nc.refine`` calls it: ``redistribute=False`` on DOLFINx 0.5.2) — against
  ``nc.refine``'s time on the next level (issue 13: at most 1.2×); ``dflt``: DOLFINx's plain
  ``refine(msh, edges)`` (on 0.5.2 it partitions the child anew, as a rebalanced ``nc.refine`` does);
- with ``--floor``: one linear elasticity solve on the level's mesh (``common.LinearFloor``, CG + GAMG as in
  DOLFINx's demo_elasticity.py, rtol 1e-8), and the level's SNES time over it (issue 13: at most 1.2× on
  nested levels); the same floor with ML instead of GAMG (PETSc 3.18's GAMG sets up slowly on refined
  meshes), for context;
- the peak resident memory so far (largest rank) and the largest rank's over the mean (issue 30: ≤ 1.2);
- ``imbalance``: the owned cells of the busiest rank over the mean (the history column; issue 30: ≤ 1.10),
  and ``unbal``: ``nc.refine(..., balance=False)`` of the same marked cells, timed in ``on_level``: the
  next level's ``time_refine`` less this is what rebalancing cost (``rebal``, and ``rebal/ref`` its share
  of the refinement it follows; issue 30: ≤ 25 %).

``hertz3d`` runs the built-in case of that name (a gmsh mesh, contact at one point) instead.
"""
import argparse
import csv
import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (LinearFloor, build_refinement_connectivity, dolfinx_refine_seconds,  # noqa: E402
                    format_table, launch, machine_load, max_rss_mb, pc_available, rank_max)
from run import BOX  # noqa: E402


def problem_and_settings(args):
    import nc_dolfinx as nc
    if args.problem == "hertz3d":
        problem = nc.load_problem("hertz3d")
    elif args.problem == "box":
        problem = nc.Problem.from_dict(BOX, "box").replace({"mesh.cells": args.cells or [8, 4, 4]})
    else:
        problem = nc.load_problem("block", [f"mesh.cells={args.cells}"] if args.cells else [])
    settings = nc.AdaptSettings(refine="adaptive", levels=args.levels, theta=args.theta,
                                max_dofs=int(float(args.max_dofs)))
    return problem, settings


def worker(args):
    import nc_dolfinx as nc
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    problem, settings = problem_and_settings(args)
    extra = {}

    def on_level(level):
        solution, stats = level.solution, level.solution.stats
        row = {"snes": rank_max(comm, stats.time), "newton": stats.newton_iterations,
               "krylov": stats.linear_iterations, "preset": stats.preset, "pc_type": stats.pc_type,
               "pc_setups": stats.pc_setups, "reason": stats.converged_reason}
        if level.marked is not None:
            build_refinement_connectivity(solution.domain.mesh)
            row["refine_dolfinx_next"] = dolfinx_refine_seconds(solution.domain, level.marked)
            row["refine_default_next"] = dolfinx_refine_seconds(solution.domain, level.marked, default=True)
            comm.barrier()
            start = time.perf_counter()
            nc.refine(solution.domain, level.marked, balance=False)
            row["refine_unbalanced_next"] = rank_max(comm, time.perf_counter() - start)
        if args.floor:
            floor = LinearFloor(problem, solution.domain)
            row["floor"], row["floor_its"], _ = floor.solve()
            if pc_available("ml"):  # not in trixie's and sid's PETSc
                row["floor_ml"] = floor.solve(amg="ml")[0]
            row["floor_hypre"] = floor.solve(amg="hypre")[0]
            floor.destroy()
        memory = max_rss_mb()
        row["mem_MB"] = rank_max(comm, memory)
        row["mem_ratio"] = row["mem_MB"] * comm.size / comm.allreduce(memory)
        extra[level.number] = row

    result = nc.adapt(problem, settings, comm=comm, on_level=on_level)
    rows = []
    for history in result.history:
        n = history["level"]
        row = {"level": n, "dofs": history["dofs"], "np": comm.size, "eta": history["eta"],
               "imbalance": history["imbalance"], **extra[n]}
        row.update({k: history[k] for k in ("time_solve", "time_estimate", "time_mark", "time_refine")
                    if k in history})
        row["setup"] = row["time_solve"] - row["snes"]
        row["estimate_mark_fraction"] = (row["time_estimate"] + row.get("time_mark", 0.0)) / row["time_solve"]
        if "floor" in row:
            row["snes_over_floor"] = row["snes"] / row["floor"]
            if "floor_ml" in row:
                row["snes_over_floor_ml"] = row["snes"] / row["floor_ml"]
            row["snes_over_floor_hypre"] = row["snes"] / row["floor_hypre"]
        rows.append(row)
    for previous, row in zip(rows, rows[1:]):  # nc.refine made this level from the previous one's marks
        row["refine_dolfinx"] = previous.get("refine_dolfinx_next")
        if row.get("refine_dolfinx"):
            row["refine_over_dolfinx"] = row["time_refine"] / row["refine_dolfinx"]
        row["refine_default"] = previous.get("refine_default_next")
        if row.get("refine_default"):
            row["refine_over_default"] = row["time_refine"] / row["refine_default"]
        row["refine_unbalanced"] = previous.get("refine_unbalanced_next")
        if row.get("refine_unbalanced"):
            row["rebalance"] = max(row["time_refine"] - row["refine_unbalanced"], 0.0)
            row["rebalance_share"] = row["rebalance"] / row["refine_unbalanced"]
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps({"rows": rows, "stop_reason": result.stop_reason}, default=str))


COLUMNS = [("level", "level", "{}"), ("dofs", "dofs", "{}"), ("eta", "eta", "{:.10g}"), ("pc_type", "pc", "{}"),
           ("newton", "Nwt", "{}"), ("krylov", "Kry", "{}"), ("pc_setups", "set", "{}"),
           ("setup", "setup", "{:.2f}"), ("snes", "solve", "{:.2f}"), ("floor", "floor", "{:.2f}"),
           ("snes_over_floor", "solve/floor", "{:.2f}"), ("floor_ml", "floor ML", "{:.2f}"),
           ("snes_over_floor_ml", "(ML)", "{:.2f}"), ("snes_over_floor_hypre", "(hypre)", "{:.2f}"),
           ("time_estimate", "estim", "{:.2f}"),
           ("time_mark", "mark", "{:.3f}"), ("estimate_mark_fraction", "(E+M)/solve", "{:.3f}"),
           ("time_refine", "refine", "{:.2f}"), ("refine_dolfinx", "dolfinx", "{:.2f}"),
           ("refine_over_dolfinx", "ratio", "{:.2f}"), ("refine_default", "dflt", "{:.2f}"),
           ("refine_over_default", "ratio", "{:.2f}"), ("refine_unbalanced", "unbal", "{:.2f}"),
           ("rebalance", "rebal", "{:.2f}"), ("rebalance_share", "rebal/ref", "{:.2f}"),
           ("imbalance", "imbal", "{:.3f}"), ("mem_MB", "MB/rank", "{:.0f}"), ("mem_ratio", "max/mean", "{:.2f}")]


def driver(args):
    out = Path(tempfile.mkdtemp(prefix="nc_adaptive_")) / "levels.json"
    cmd = [Path(__file__).resolve(), "--worker", "--json", out, "--problem", args.problem,
           "--max-dofs", args.max_dofs, "--levels", args.levels, "--theta", args.theta]
    if args.cells:
        cmd += ["--cells", *args.cells]
    if args.floor:
        cmd.append("--floor")
    load = machine_load()
    proc = launch(cmd, args.np, args.timeout)
    if proc.returncode != 0:
        print(proc.stderr[-4000:], file=sys.stderr)
        return 1
    result = json.loads(out.read_text())
    rows = result["rows"]
    print(f"{args.problem} on {args.np} rank(s), Dörfler theta = {args.theta}, max_dofs = {args.max_dofs}: "
          f"{len(rows)} levels, stop: {result['stop_reason']} (load average {load:.2f} -> {machine_load():.2f})")
    print(format_table(rows, COLUMNS))
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            writer = csv.DictWriter(fh, list(dict.fromkeys(k for r in rows for k in r)))
            writer.writeheader()
            writer.writerows(rows)
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--problem", choices=("box", "block", "hertz3d"), default="box")
    p.add_argument("--np", type=int, default=2)
    p.add_argument("--cells", type=int, nargs="+", help="level-0 cells (box: 8 4 4, block: 16 8)")
    p.add_argument("--max-dofs", default="1e6")
    p.add_argument("--levels", type=int, default=60)
    p.add_argument("--theta", type=float, default=0.5)
    p.add_argument("--floor", action="store_true",
                   help="a linear floor solve on every level (GAMG, ML and BoomerAMG)")
    p.add_argument("--csv")
    p.add_argument("--timeout", type=float, default=7200)
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--json", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        if args.cells:
            args.cells = list(args.cells)
        return worker(args)
    return driver(args)


if __name__ == "__main__":
    sys.exit(main())
