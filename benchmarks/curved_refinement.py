#!/usr/bin/env python3
"""Placing new boundary vertices on the true shape against the refinement they follow (issue 46, item 6).

    /usr/bin/python3 benchmarks/curved_refinement.py [--np 1 2] [--sizes2d 0.025 0.0125] [--sizes3d 0.125 0.0625]

On the half-disc (meshes/halfdisc.py, its arc given as a circle) and the quarter ball (meshes/quarterball.py,
its sphere given) of size h, refined once with the shape to make the parent (on the surface, as in the
adaptive loop), three things are timed on the parent, each on its own copy, the fastest of ``--repeat``:

- ``refine``: ``nc.refine`` of the parent with its shapes set to None (Plaza, the transfer of groups and
  regions, rebalancing: everything but the snap);
- ``refine+snap``: ``nc.refine`` of the parent with its shapes (what the adaptive loop calls);
- ``snap``: ``nc.snap`` alone, on the child of the first with the shapes set back (the
  placing of the vertices, the cells' quality check and, if needed, the interior's harmonic move).

Two markings: ``uniform`` (every cell) and ``local`` (the cells within R/4 of the contact point, where
Dörfler's marking puts them). The target is snap ≤ 10 % of refine. Each (body, h, ranks) runs in its own
process; the table goes to stdout with the date, commit, machine and command beside it.
"""
import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (barrier_time, format_table, launch, machine_load, owned_cells, rank_max,  # noqa: E402
                    run_harness)

TARGET = 0.10


def worker(args):
    import numpy as np
    from mpi4py import MPI
    import nc_dolfinx as nc
    comm = MPI.COMM_WORLD
    dim = args.dim
    domain = nc.from_gmsh(comm, args.mesh)
    surface = {"circle": {"centre": [0.0, 1.0], "radius": 1.0}} if dim == 2 else \
        {"sphere": {"centre": [0.0, 0.0, 1.0], "radius": 1.0}}
    shapes_only = nc.Problem.from_dict({  # a problem for its [mesh.shapes]: nothing is solved
        "mesh": {"contact": ["contact"], "shapes": {"contact": surface, "free": surface}},
        "material": {"E": 1.0, "nu": 0.3}, "contact": {"c_n": 1.0, "m_n": 1}, "loads": {"f": ["0"] * dim}})
    nc.resolve_shapes(domain, shapes_only)
    parent = nc.refine(domain)  # on the surface, as a level of the adaptive loop
    shapes = parent.shapes
    flat = dataclasses.replace(parent, shapes=None)
    rows = []
    for marking in ("uniform", "local"):
        if marking == "uniform":
            cells = owned_cells(parent)
        else:
            from dolfinx import mesh as dmesh
            mid = dmesh.compute_midpoints(parent.mesh, dim, owned_cells(parent))
            cells = owned_cells(parent)[np.linalg.norm(mid[:, :dim], axis=1) < 0.25]
        times = {"refine": [], "refine+snap": [], "snap": []}
        for _ in range(args.repeat):
            start = barrier_time(comm)
            child = nc.refine(flat, cells)
            times["refine"].append(barrier_time(comm) - start)
            start = barrier_time(comm)
            snapped = nc.refine(parent, cells)
            times["refine+snap"].append(barrier_time(comm) - start)
            child = dataclasses.replace(child, shapes=shapes)
            start = barrier_time(comm)
            nc.snap(child)
            times["snap"].append(barrier_time(comm) - start)
        best = {k: rank_max(comm, min(v)) for k, v in times.items()}
        rows.append({"body": "half-disc" if dim == 2 else "quarter ball", "h": args.h, "marking": marking,
                     "np": comm.size, "parent_cells": parent.num_cells(), "cells": snapped.num_cells(),
                     "t_refine": best["refine"], "t_both": best["refine+snap"], "t_snap": best["snap"],
                     "share": best["snap"] / best["refine"],
                     "share_diff": (best["refine+snap"] - best["refine"]) / best["refine"]})
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(rows))


COLUMNS = [("body", "body", "{}"), ("h", "h", "{:g}"), ("marking", "marking", "{}"), ("np", "np", "{}"),
           ("parent_cells", "parent cells", "{}"), ("cells", "child cells", "{}"),
           ("t_refine", "refine [s]", "{:.3f}"), ("t_both", "refine+snap [s]", "{:.3f}"),
           ("t_snap", "snap [s]", "{:.3f}"), ("share", "snap/refine", "{:.1%}"),
           ("share_diff", "(r+s − r)/r", "{:+.1%}")]


def driver(args):
    import importlib.util

    def load(path):
        spec = importlib.util.spec_from_file_location(path.stem, path)
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    provenance = load(HERE.parent / "verification" / "common.py").provenance
    tmp = Path(tempfile.mkdtemp(prefix="nc_curved_bench-"))
    rows = []
    print(f"load average at the start: {machine_load():.2f}", file=sys.stderr, flush=True)
    for dim, sizes in ((2, args.sizes2d), (3, args.sizes3d)):
        script = HERE.parent / "meshes" / ("halfdisc.py" if dim == 2 else "quarterball.py")
        generator = load(script)
        for h in sizes:
            mesh = tmp / f"{script.stem}_{h}.msh"
            generator.write(mesh, h)
            for nprocs in args.np:
                out = tmp / f"{dim}_{h}_{nprocs}.json"
                proc = launch([Path(__file__).resolve(), "--worker", "--dim", dim, "--h", h, "--mesh", mesh,
                               "--json", out, "--repeat", args.repeat], nprocs, args.timeout)
                if proc.returncode != 0:
                    print(f"{dim}D h={h} np={nprocs} FAILED:\n{proc.stderr[-2000:]}", file=sys.stderr)
                    continue
                rows += json.loads(out.read_text())
                print(f"  {dim}D h={h} np={nprocs} done (load {machine_load():.2f})", file=sys.stderr, flush=True)
    if args.json_out:  # (the rows, before the table)
        Path(args.json_out).write_text(json.dumps(rows, indent=1))
    print("\n".join(provenance("curved_refinement.py", sys.argv[1:], "1, 2" if len(args.np) > 1 else args.np[0],
                               folder="benchmarks")))
    print(f"- load average at the end: {machine_load():.2f}")
    print()
    print(format_table(rows, COLUMNS))
    worst = max((r["share"] for r in rows), default=float("nan"))
    print(f"\nworst snap/refine {worst:.1%} (target ≤ {TARGET:.0%}): {'met' if worst <= TARGET else 'MISSED'}")
    return 0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--sizes2d", type=float, nargs="+", default=[0.025, 0.0125, 0.00625], help="half-disc h")
    p.add_argument("--sizes3d", type=float, nargs="+", default=[0.125, 0.0625], help="quarter ball h")
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--repeat", type=int, default=2)
    return run_harness(p, argv, worker, driver, hidden=(("--dim", int), ("--h", float), "--mesh", "--json"))

if __name__ == "__main__":
    sys.exit(main())
