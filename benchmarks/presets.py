#!/usr/bin/env python3
"""The measurements behind ``preset = "auto"`` (nc_dolfinx.solver.choose_preset): direct against iterative.

    /usr/bin/python3 benchmarks/presets.py cold-nested [--cases block corner square] [--sizes 1 2 3 4]
    /usr/bin/python3 benchmarks/presets.py loops [--cases block corner hertz manufactured] [--max-dofs 2e5]

``cold-nested``: per case and size, in one process, ``nc.solve`` from u = 0 (cold) and on the
uniformly refined mesh from the transferred solution (nested), with ``preset = direct`` and ``iterative``
alternately, 3 times; the fastest of each is printed (solve time only, no assembly of K). Sizes: block
``mesh.cells = [2k, k]`` with k = 16·2^(s−1); square (the family's, c_n = 1, m_n = 1.5) k×k; corner: s
uniform refinements of ``meshes/corner.msh``.

``loops``: the built-in case's adaptive loop (Dörfler, θ = 0.5) to ``--max-dofs`` with each preset; the
sum of the levels' solve times (from ``run_cases.py``'s history).
"""
import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PYTHON = "/usr/bin/python3"


def build(case, size, comm):
    import nc_dolfinx as nc
    k = 16 * 2 ** (size - 1)
    if case == "square":
        data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [k, k], "dirichlet": ["top"],
                         "neumann": ["left", "right"], "contact": ["bottom"]},
                "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "-0.5"]},
                "contact": {"c_n": 1.0, "m_n": 1.5}}
        problem = nc.Problem.from_dict(data, "square")
    else:
        problem = nc.load_problem(case, [f"mesh.cells=[{2 * k},{k}]"] if case == "block" else [])
    domain = nc.build_domain(problem, comm)
    if case == "corner":
        for _ in range(size):
            domain = nc.refine(domain)
    return problem, domain


def solve(problem, domain, preset, initial=None):
    import nc_dolfinx as nc
    solution = nc.solve(problem.replace({"solver.preset": preset}), domain, initial=initial)
    return solution.u, solution.stats


def cold_nested(args):
    import nc_dolfinx as nc
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    for case in args.cases:
        for size in args.sizes:
            problem, domain = build(case, size, comm)
            child = nc.refine(domain)
            best = {}
            for _ in range(3):
                for preset in ("direct", "iterative"):
                    u, cold = solve(problem, domain, preset)
                    _, nested = solve(problem, child, preset, u)
                    b = best.setdefault(preset, {"cold": 1e99, "nested": 1e99})
                    b["cold"], b["nested"] = min(b["cold"], cold.time), min(b["nested"], nested.time)
                    b["its"] = [cold.newton_iterations, cold.linear_iterations,
                                nested.newton_iterations, nested.linear_iterations]
            if comm.rank == 0:
                print(json.dumps({"case": case, "dofs": 2 * domain.num_vertices(),
                                  "nested_dofs": 2 * child.num_vertices(), **best}), flush=True)


def loops(args):
    for case in args.cases:
        totals = {}
        for preset in ("direct", "iterative"):
            out = Path(tempfile.mkdtemp(prefix="nc_presets_"))
            subprocess.run([PYTHON, ROOT / "run_cases.py", case, "--refine", "adaptive", "--levels", "30",
                            "--max-dofs", str(int(float(args.max_dofs))), "--preset", preset, "--quiet",
                            "--out", out], check=True, cwd=ROOT)
            history = json.loads((out / "history.json").read_text())
            totals[preset] = {"levels": len(history), "dofs": history[-1]["dofs"],
                              "solve": round(sum(r["time_solve"] for r in history), 2),
                              "its": [(r["newton_iterations"], r["linear_iterations"]) for r in history]}
        print(json.dumps({"case": case, **totals}), flush=True)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("what", choices=("cold-nested", "loops"))
    p.add_argument("--cases", nargs="+")
    p.add_argument("--sizes", type=int, nargs="+", default=[1, 2, 3, 4])
    p.add_argument("--max-dofs", default="2e5")
    args = p.parse_args()
    sys.path.insert(0, str(ROOT))
    if args.what == "cold-nested":
        args.cases = args.cases or ["block", "corner", "square"]
        cold_nested(args)
    else:
        args.cases = args.cases or ["block", "corner", "hertz", "manufactured"]
        loops(args)


if __name__ == "__main__":
    main()
