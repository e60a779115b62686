#!/usr/bin/env python3
"""The defaults on laws beyond the family (issue 13: "never fail on a problem nobody tuned for").

    /usr/bin/python3 benchmarks/extremes.py [--np 1 2] [--dims 2 3] [--c-n 1e-2 1 1e3 1e6 1e9 1e12] [--csv F]

The family's square (2D, ``--cells`` a side) and cube (3D, ``--cells3d``), E = 1, clamped on top, f = −0.5
downwards, contact at the bottom, solved with NO options through the public API (``nc.solve`` from u = 0)
for every c_n/E of ``--c-n``, m_n ∈ {1, 2, 3} and gap g_0 ∈ {0, 0.01, 0.02 x} (x along the contact side):
the family stops at c_n/E = 1e5; a penalty 1/ε for Signorini's limit goes further. One process per
dimension and rank count (``--worker``); each member is solved twice and the second solve is reported
(Newton and Krylov iterations, preconditioner set-ups, converged reason, fallbacks, SNES time). A member
that ends in an error prints it in the reason column.
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
COLUMNS = [("dim", "dim", "{}"), ("np", "np", "{}"), ("c_n", "c_n/E", "{:g}"), ("m_n", "m_n", "{}"),
           ("gap", "gap", "{}"), ("dofs", "dofs", "{}"), ("preset", "preset", "{}"), ("newton", "Nwt", "{}"),
           ("krylov", "Kry", "{}"), ("pc_setups", "set", "{}"), ("reason", "reason", "{}"),
           ("recoveries", "fallbacks", "{}"), ("time", "solve", "{:.2f}")]


def worker(args):
    from mpi4py import MPI
    import nc_dolfinx as nc
    comm = MPI.COMM_WORLD
    cells = args.cells if args.dim == 2 else args.cells3d
    rows = []
    for c_n, m_n, gap in itertools.product(args.c_n, M_N, GAPS):
        member = Member(f"{c_n:g}-{m_n}", c_n, m_n, gap, body="square" if args.dim == 2 else "cube")
        p, domain = member_problem(member, cells, comm, None)
        row = {"dim": args.dim, "np": comm.size, "c_n": c_n, "m_n": m_n, "gap": member.gap_text()}
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
            print(f"  {args.dim}D np={comm.size} c_n={c_n:g} m_n={m_n} gap={gap}: {row['reason']}", file=sys.stderr,
                  flush=True)
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(rows))


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--dims", type=int, nargs="+", default=[2, 3], choices=(2, 3))
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
                   "--cells3d", args.cells3d, "--c-n", *args.c_n]
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
