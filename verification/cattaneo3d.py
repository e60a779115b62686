#!/usr/bin/env python3
"""Cattaneo–Mindlin partial slip of a sphere (the ``cattaneo3d`` case, a half ball): the comparison table.

Run (any number of ranks; ``--set`` overrides as in run_cases.py)::

    PYTHONPATH=. /usr/bin/python3 verification/cattaneo3d.py [--set steps.2.set.dt=0.002 ...]

It solves the case's load path and prints, for every state of the last step (the tangential loading),
the full ball's normal force P = −2 reaction_top[2] and tangential force Q = 2 |friction_force[0]|, the
contact radius a = sqrt(2 A/π) (A = contact_area, the measure of {p > 0} of the normal law: a half disc)
against Hertz's a_H = (3PR/(4E*))^(1/3), E* = E/(1 − ν²), and the stick radius over it,
c/a = sqrt(A_stick/(A_stick + A_slip)) in the friction law's own classification (the vertices of Γ_C,
weighted by m_i = ∫ φ_i: stick_area, slip_area), against Cattaneo–Mindlin's c/a = (1 − Q/(μP))^(1/3). The last line is JSON (the final state's numbers) for
tests and docs. docs/src/cattaneo3d.md discusses the differences.
"""
import argparse
import json
import math
import sys
import time
from pathlib import Path

from mpi4py import MPI

import nc_dolfinx as nc


ROOT = Path(__file__).resolve().parent.parent


def measures(row, problem):
    """The comparison's numbers from one history row of the case (half ball) at ``problem``'s parameters."""
    values = problem.values
    E, nu = float(values["material"]["E"]), float(values["material"]["nu"])
    R, mu = problem.parameters["R"], problem.parameters["mu"]
    P = -2.0 * row["reaction_top"][2]
    Q = 2.0 * abs(row["friction_force"][0])
    a = math.sqrt(2.0 * row["contact_area"] / math.pi)
    a_hertz = (3.0 * P * R * (1.0 - nu ** 2) / (4.0 * E)) ** (1.0 / 3.0)
    # (the stick and slip areas weigh the law's vertices, the contact area the normal law's Gauss points:
    # the ratio is taken within the law's own measure)
    c = a * math.sqrt(row["stick_area"] / (row["stick_area"] + row["slip_area"]))
    ratio = Q / (mu * P) if mu > 0 else float("nan")
    mindlin = (1.0 - ratio) ** (1.0 / 3.0) if ratio < 1 else 0.0
    return {"P": P, "Q": Q, "Q/muP": ratio, "a": a, "a_hertz": a_hertz, "a_error": a / a_hertz - 1.0,
            "contact_area": row["contact_area"], "stick_area": row["stick_area"], "slip_area": row["slip_area"],
            "c": c, "c/a": c / a, "c/a_mindlin": mindlin, "c/a_error": (c / a) / mindlin - 1.0 if mindlin else None,
            "max_slip": row["max_slip"], "friction_passes": row["friction_passes"],
            "friction_newton": row["friction_newton"]}


def run(overrides=(), comm=MPI.COMM_WORLD):
    """Solve the case; returns (rows of the last step with their measures, the problem, seconds)."""
    problem = nc.load_problem("cattaneo3d", list(overrides))
    t0 = time.perf_counter()
    result = nc.adapt(problem, comm=comm)
    seconds = time.perf_counter() - t0
    last = max(row.get("step", 0) for row in result.history)
    states = problem.load_path()
    out = []
    for row, state in zip(result.history, states):
        if row.get("step") == last:
            out.append({"increment": row["increment"], **measures(row, state.problem)})
            final = state.problem
    return out, final, seconds


def header(argv):
    from common import provenance
    return provenance("cattaneo3d.py", argv[1:], MPI.COMM_WORLD.size)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="problem overrides")
    args = ap.parse_args(argv)
    rows, problem, seconds = run(args.set)
    if MPI.COMM_WORLD.rank != 0:
        return 0
    print("\n".join(header([Path(sys.argv[0]).name] + (argv if argv is not None else sys.argv[1:]))))
    print(f"case     cattaneo3d (half ball, {Path(problem.values['mesh']['file']).name}), mu = {problem.parameters['mu']:g}"
          f" at the end, eps_r = {problem.values['contact']['slip_regularisation']:g}; solve {seconds:.1f} s")
    print()
    print(f"{'incr':>4} {'P':>8} {'Q':>8} {'Q/muP':>6} {'a':>8} {'a_Hertz':>8} {'a err':>7}"
          f" {'c':>8} {'c/a':>6} {'Mindlin':>7} {'c/a err':>7}")
    for r in rows:
        err = f"{100 * r['c/a_error']:+6.1f}%" if r["c/a_error"] is not None else "    -  "
        print(f"{r['increment']:>4} {r['P']:8.4f} {r['Q']:8.4f} {r['Q/muP']:6.3f} {r['a']:8.5f} {r['a_hertz']:8.5f}"
              f" {100 * r['a_error']:+6.2f}% {r['c']:8.5f} {r['c/a']:6.3f} {r['c/a_mindlin']:7.3f} {err}")
    print(json.dumps({**rows[-1], "seconds": seconds}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
