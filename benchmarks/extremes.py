#!/usr/bin/env python3
"""The defaults on laws and bodies beyond the family (issue 13: "never fail on a problem nobody tuned for").

    /usr/bin/python3 benchmarks/extremes.py [--np 1 2] [--dims 2 3] [--bodies square cantilever]
                                            [--c-n 1e-2 1 1e3 1e6 1e9 1e12] [--csv F]

Bodies, E = 1, ν = 0.3, contact at the bottom, solved with NO options through the public API (``nc.solve``
from u = 0) for every c_n/E of ``--c-n``, m_n ∈ {1, 2, 3} and gap g_0 ∈ {0, 0.01, 0.02 x}:

- ``square``: the family's square (2D, ``--cells`` a side) and cube (3D, ``--cells3d``), clamped on top,
  f = −0.5 downwards (``family.member_problem``); the family stops at c_n/E = 1e5, a penalty 1/ε for
  Signorini's limit goes further;
- ``cantilever``: a beam 10 long and 1 thick (3D: 1 × 1 section; 10n × n (× n) cells, n = a quarter of
  the square's), clamped at x = 0, sagging under f = −0.01 onto the foundation below it: unsupported, its
  tip would sink by ~150, so the contact zone grows from the tip towards the clamp.

One process per dimension and rank count (``--worker``); each member is solved twice and the second solve
is reported (Newton and Krylov iterations, preconditioner set-ups, converged reason, fallbacks, SNES time).
A member that ends in an error prints it in the reason column.
"""
import argparse
import csv
import itertools
import json
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import format_table, launch  # noqa: E402
from family import Member, member_problem  # noqa: E402

M_N = (1, 2, 3)
GAPS = ((0.0, 0.0), (0.01, 0.0), (0.0, 0.02))  # g_0 = a + b x
COLUMNS = [("body", "body", "{}"), ("dim", "dim", "{}"), ("np", "np", "{}"), ("c_n", "c_n/E", "{:g}"), ("m_n", "m_n", "{}"),
           ("gap", "gap", "{}"), ("dofs", "dofs", "{}"), ("preset", "preset", "{}"), ("newton", "Nwt", "{}"),
           ("krylov", "Kry", "{}"), ("pc_setups", "set", "{}"), ("reason", "reason", "{}"),
           ("recoveries", "fallbacks", "{}"), ("time", "solve", "{:.2f}")]


def cantilever_problem(member, dim, n):
    """The cantilever (see the module's docstring) with the member's law, 10n × n (× n) cells."""
    import nc_dolfinx as nc
    if dim == 2:
        mesh = {"rectangle": [[0, 0], [10, 1]], "cells": [10 * n, n], "neumann": ["right", "top"]}
    else:
        mesh = {"box": [[0, 0, 0], [10, 1, 1]], "cells": [10 * n, n, n],
                "neumann": ["right", "top", "front", "back"]}
    data = {"mesh": {**mesh, "dirichlet": ["left"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0"] * (dim - 1) + ["-0.01"]},
            "contact": {"c_n": member.c_n, "m_n": member.m_n, "gap": member.gap_text()}}
    return nc.Problem.from_dict(data, "cantilever")


def worker(args):
    from mpi4py import MPI
    import nc_dolfinx as nc
    comm = MPI.COMM_WORLD
    cells = args.cells if args.dim == 2 else args.cells3d
    rows = []
    for body, c_n, m_n, gap in itertools.product(args.bodies, args.c_n, M_N, GAPS):
        member = Member(f"{c_n:g}-{m_n}", c_n, m_n, gap, body="square" if args.dim == 2 else "cube")
        if body == "square":
            p, domain = member_problem(member, cells, comm, None)
        else:
            p = cantilever_problem(member, args.dim, max(cells // 4, 1))
            domain = nc.build_domain(p, comm)
        row = {"body": body, "dim": args.dim, "np": comm.size, "c_n": c_n, "m_n": m_n,
               "gap": member.gap_text()}
        try:
            for _ in range(2):  # the first solve compiles; the second is reported
                solution = nc.solve(p, domain)
            s = solution.stats
            V = solution.u.function_space
            row.update(dofs=V.dofmap.index_map.size_global * V.dofmap.index_map_bs, preset=s.preset,
                       newton=s.newton_iterations, krylov=s.linear_iterations, pc_setups=s.pc_setups,
                       reason=s.converged_reason, recoveries=s.recoveries, time=s.time)
        except nc.InputError as err:
            row["reason"] = f"error: {err}"
        rows.append(row)
        if comm.rank == 0:
            print(f"  {body} {args.dim}D np={comm.size} c_n={c_n:g} m_n={m_n} gap={gap}: {row['reason']}",
                  file=sys.stderr, flush=True)
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(rows))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--dims", type=int, nargs="+", default=[2, 3], choices=(2, 3))
    p.add_argument("--bodies", nargs="+", default=["square", "cantilever"], choices=("square", "cantilever"))
    p.add_argument("--c-n", type=float, nargs="+", default=[1e-2, 1, 1e3, 1e6, 1e9, 1e12])
    p.add_argument("--cells", type=int, default=128, help="2D: cells a side (128: 33,282 dofs)")
    p.add_argument("--cells3d", type=int, default=16, help="3D: cells a side (16: 14,739 dofs)")
    p.add_argument("--timeout", type=float, default=3600)
    p.add_argument("--csv")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--dim", type=int, help=argparse.SUPPRESS)
    p.add_argument("--json", help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.worker:
        return worker(args)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for dim, nprocs in itertools.product(args.dims, args.np):
            out = Path(tmp) / f"{dim}-{nprocs}.json"
            cmd = [HERE / "extremes.py", "--worker", "--dim", dim, "--json", out, "--cells", args.cells,
                   "--cells3d", args.cells3d, "--bodies", *args.bodies, "--c-n", *args.c_n]
            proc = launch(cmd, nprocs, args.timeout)
            sys.stderr.write(proc.stderr)
            if proc.returncode != 0:
                sys.exit(f"extremes.py: the {dim}D worker on {nprocs} ranks failed")
            rows += json.loads(out.read_text())
    print(format_table(rows, COLUMNS))
    converged = [r for r in rows if r["reason"].startswith("CONVERGED")]
    print(f"\nconverged with no options: {len(converged)}/{len(rows)}; without a fallback: "
          f"{sum(not r['recoveries'] for r in converged)}; at the residual's round-off: "
          f"{sum(r['reason'] == 'CONVERGED_ROUNDOFF' for r in rows)}")
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=[k for k, _, _ in COLUMNS])
            writer.writeheader()
            writer.writerows(rows)


if __name__ == "__main__":
    main()
