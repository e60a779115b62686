#!/usr/bin/env python3
"""A frictional load cycle on benchmarks/family.py's friction members (issue 48): what an increment costs.

    /usr/bin/python3 benchmarks/load_cycle.py [--np 1 2] [--members friction friction3d 1-1 ...]
        [--increments 20 auto] [--predictor auto secant tangent none] [--cells 128] [--cells3d 16] [--smoke]

Each friction member's body and law (family.py's ``member_problem``: the unit square or cube, E = 1, the
weight f = −0.5 e_y (e_z), c_n/E, m_n, μ) is unclamped and loaded on its top by a traction (q, −p)
(3D: (q, 0, −p)): held by the foundation alone (the settling path), it goes round a load cycle
— **press** (p from 0 to 0.5: the weight doubled, P = 1), **shear** to q = 0.8 μP, **back** to −0.8 μP,
**return** to 0 (the members with μ = 1 are not run: 0.8 μP on the top would tip the body over, q > P/2) — in 20 increments (4 + 4 + 8 + 4) or with ``increments = "auto"`` on every step, through
the public API (``nc.adapt``, no refinement, no options but the predictor), each member in its own process
(``--worker``) on 1 and 2 ranks. The unit of cost is family.py's: one linear elasticity solve on the same
mesh (``common.LinearFloor``: CG + GAMG to 1e-8, PC set-up included; the member as family.py poses it,
clamped on top), the fastest of three. Reported per member and rank count:

- ``mean``, ``worst``: the SNES time of an increment (``Solution.stats.time``, the slowest rank, as
  family.py's ``increment`` column) over the floor, the mean over the cycle's increments and the worst one;
  with ``auto`` the time of the discarded (cut) solves is added to the increment that replaced them;
- ``cold``: the member's cold frictional solve as family.py measures it (``family.measure``, u = 0, the
  clamped member) over the floor;
- ``Nwt``: the Newton steps of the whole cycle; ``incr``: its increments; ``cuts`` (auto); ``lin``: its Krylov
  iterations (the tangent predictor's included); ``PC``: its preconditioner set-ups (factorisations with the
  direct preset); ``pred``: the increments whose tangent prediction was kept; ``cycle``: the whole cycle's time.

A frictionless member named in ``--members`` (``1-1``, ``3d-100-2``, ...: the predictors' comparison) is held
laterally by symmetry planes (left; 3D: left and front), since a frictionless foundation holds no lateral
motion, and goes round a press cycle instead: p to 0.5, 1.5, back to 0 and to 0.5 again (P = 1, 2, 0.5, 1),
in the same 4 + 4 + 8 + 4 increments.

Targets (issue 48): mean <= 2, worst <= 5, cold <= 5 (2D) / 4 (3D). Every timed cycle follows an untimed
one with one increment a step (JIT compilation, first touch of memory). ``--smoke``: 16 (2D) and 4 (3D)
cells, the first 2D and 3D members, one rank (tests/test_benchmark_smoke.py).
"""
import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import LinearFloor, dofs, format_table, launch, machine_load, rank_max, run_harness  # noqa: E402
import family  # noqa: E402

CELLS = {2: 128, 3: 16}
SMOKE_CELLS = {2: 16, 3: 4}
# (parameter values at each step's end, increments of the 20-increment cycle); q in units of 0.8 μP
PRESS, LIMIT_FRACTION = 0.5, 0.8
STEPS = [({"p": PRESS}, 4), ({"q": "qmax"}, 4), ({"q": "-qmax"}, 8), ({"q": 0.0}, 4)]
# Frictionless members (the predictors' comparison): no shear holds, so their cycle presses, unloads and presses
# again (p to 0.5, 1.5, back to 0, 0.5: P = 1, 2, 0.5, 1) in the same 20 increments
STEPS_FRICTIONLESS = [({"p": PRESS}, 4), ({"p": 3 * PRESS}, 4), ({"p": 0.0}, 8), ({"p": PRESS}, 4)]
PREDICTORS = ("auto", "secant", "tangent", "none")
TARGETS = {"mean": 2.0, "worst": 5.0, "cold": {2: 5.0, 3: 4.0}}
# The shear q on the top (height H = 1) tips the body over its edge once q H > P W/2 (width W = 1): beyond
# q = 0.5 P no equilibrium exists, so the members with 0.8 μ > 0.5 (μ = 1) are listed as "overturns".
OVERTURNS = 0.5


def cycle_problem(problem, increments, predictor):
    """The member ``problem`` unclamped, with the top traction (q, −p) going round the cycle."""
    import nc_dolfinx as nc
    raw = json.loads(json.dumps(problem.raw))
    mesh, dim = raw["mesh"], problem.values["mesh"]["box"] and 3 or 2
    mesh["dirichlet"] = []
    mesh["neumann"] = list(mesh.get("neumann", [])) + ["top"]
    mu = float(problem.values["contact"].get("friction") or 0.0)
    weight = 0.5  # f = -0.5 on the unit square/cube
    raw["parameters"] = {"p": 0.0, "q": 0.0, "qmax": LIMIT_FRACTION * mu * (weight + PRESS)}
    raw["loads"]["g"] = {"top": ["q", "-p"] if dim == 2 else ["q", "0", "-p"]}
    if mu == 0.0:  # (a frictionless foundation holds no lateral motion: symmetry planes do)
        mesh["symmetry"] = ["left"] if dim == 2 else ["left", "front"]
        mesh["neumann"] = [name for name in mesh["neumann"] if name not in mesh["symmetry"]]
    raw["steps"] = [{"set": dict(values), "increments": n if increments == "20" else "auto"}
                    for values, n in (STEPS if mu > 0 else STEPS_FRICTIONLESS)]
    raw["solver"] = dict(raw.get("solver", {}), predictor=predictor)
    return nc.Problem.from_dict(raw, problem.name + "-cycle")


def run_cycle(problem, domain, comm):
    """nc.adapt along the cycle: per increment (SNES time on the slowest rank, cut time, Newton, cuts)."""
    import nc_dolfinx as nc
    rows = []

    def on_level(level):
        stats = level.solution.stats
        rows.append({"solve": rank_max(comm, stats.time), "linear": stats.linear_iterations,
                     "pc_setups": stats.pc_setups, "predicted": stats.predictor == "tangent",
                     "cut": rank_max(comm, level.row.get("time_cut", 0.0)),
                     "newton": level.row["newton_iterations"], "cuts": level.row.get("increment_cuts", 0),
                     "reason": level.row["converged_reason"], "load_time": level.row["load_time"]})

    result = nc.adapt(problem, nc.AdaptSettings(refine="none"), domain=domain, on_level=on_level)
    return rows, result


def worker(args):
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    args.increments, args.predictor = args.increments[0], args.predictor[0]  # (one of each per worker)
    member = next(m for m in family.MEMBERS if m.name == args.member)
    cells = args.cells if member.dim == 2 else args.cells3d
    problem, domain = family.member_problem(member, cells, comm, args.tmp)
    row = {"member": member.name, "np": comm.size, "dim": member.dim, "dofs": dofs(domain),
           "increments": args.increments, "predictor": args.predictor}
    cold, _ = family.measure(problem, domain, comm, args.repeat)
    row["cold"] = cold["ratio"]
    floor = LinearFloor(problem, domain)
    t_floor = min(floor.solve()[0] for _ in range(3))
    floor.destroy()
    row["t_floor"] = t_floor
    cycle = cycle_problem(problem, args.increments, args.predictor)
    warm = json.loads(json.dumps(cycle.raw))
    warm["steps"] = [dict(step, increments=1) for step in warm["steps"]]
    import nc_dolfinx as nc
    try:  # (one increment a step may be too much for the solver: it has compiled its forms by then)
        run_cycle(nc.Problem.from_dict(warm, "warm-up"), domain, comm)
    except nc.InputError:
        pass
    t = time.perf_counter()
    rows, result = run_cycle(cycle, domain, comm)
    row["t_cycle"] = rank_max(comm, time.perf_counter() - t)
    costs = [(r["solve"] + r["cut"]) / t_floor for r in rows]
    row.update(mean=sum(costs) / len(costs), worst=max(costs), incr=len(rows),
               newton=sum(r["newton"] for r in rows), cuts=sum(r["cuts"] for r in rows),
               linear=sum(r["linear"] for r in rows), pc_setups=sum(r["pc_setups"] for r in rows),
               predicted=sum(r["predicted"] for r in rows),
               worst_at=rows[costs.index(max(costs))]["load_time"],
               converged=all(r["reason"].startswith("CONVERGED") for r in rows), costs=costs)
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row, indent=1, default=str))


COLUMNS = [("member", "member", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
           ("increments", "increments", "{}"), ("predictor", "predictor", "{}"), ("incr", "incr", "{}"),
           ("cuts", "cuts", "{}"), ("newton", "Nwt", "{}"), ("linear", "lin", "{}"),
           ("pc_setups", "PC", "{}"), ("predicted", "pred", "{}"), ("t_cycle", "cycle [s]", "{:.2f}"),
           ("t_floor", "floor [s]", "{:.3f}"),
           ("mean", "mean", "{:.2f}"), ("worst", "worst", "{:.2f}"), ("worst_at", "at t", "{:.3g}"),
           ("cold", "cold", "{:.2f}"), ("met", "targets", "{}")]


def verdict(row):
    misses = [name for name, limit in (("mean", TARGETS["mean"]), ("worst", TARGETS["worst"]),
                                       ("cold", TARGETS["cold"][row["dim"]])) if not row[name] <= limit]
    return "met" if not misses else "missed: " + ", ".join(misses)


def driver(args):
    import importlib.util  # (verification's common, by its path: benchmarks' own is imported as common)
    spec = importlib.util.spec_from_file_location("verification_common", HERE.parent / "verification" / "common.py")
    vcommon = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(vcommon)
    tmp = tempfile.mkdtemp(prefix="nc_load_cycle_")
    members = [m for m in family.MEMBERS if m.name in args.members
               or (m.friction is not None and (m.group in args.members or "all" in args.members))]
    rows = []
    print(f"load average at the start: {machine_load():.2f}", file=sys.stderr, flush=True)
    for member in [m for m in members if LIMIT_FRACTION * (m.friction or 0.0) > OVERTURNS]:
        rows += [{"member": member.name, "np": nprocs, "dim": member.dim, "met": "overturns", "converged": True}
                 for nprocs in args.np]
    for member in [m for m in members if LIMIT_FRACTION * (m.friction or 0.0) <= OVERTURNS]:
        for nprocs in args.np:
            for increments in args.increments:
                for predictor in args.predictor:
                    out = Path(tmp) / f"{member.name}_{nprocs}_{increments}_{predictor}.json"
                    cmd = [Path(__file__).resolve(), "--worker", "--member", member.name, "--cells", args.cells,
                           "--cells3d", args.cells3d, "--repeat", args.repeat, "--tmp", tmp, "--json", out,
                           "--increments", increments, "--predictor", predictor]
                    proc = launch(cmd, nprocs, args.timeout)
                    if proc.returncode != 0:
                        print(f"{member.name} np={nprocs} {increments} {predictor} FAILED:\n{proc.stderr[-3000:]}",
                              file=sys.stderr)
                        rows.append({"member": member.name, "np": nprocs, "dim": member.dim,
                                     "increments": increments, "predictor": predictor, "met": "FAILED"})
                        continue
                    row = json.loads(out.read_text())
                    row["met"] = verdict(row) if row["converged"] else "not converged"
                    rows.append(row)
                    print(f"  {member.name} np={nprocs} {increments} {predictor}: mean {row['mean']:.2f} worst "
                          f"{row['worst']:.2f} cold {row['cold']:.2f} (load {machine_load():.2f})",
                          file=sys.stderr, flush=True)
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(rows, indent=1, default=str))
    ranks = ", ".join(map(str, args.np))
    print("\n".join(vcommon.provenance("load_cycle.py", sys.argv[1:], ranks, folder="benchmarks")))
    print(f"- load average at the end: {machine_load():.2f}")
    for dim in (2, 3):
        these = [r for r in rows if r.get("dim") == dim]
        if these:
            print(f"\n{dim}D\n" + format_table(these, COLUMNS))
    measured = [r for r in rows if "mean" in r]
    print(f"\ntargets met (mean <= {TARGETS['mean']:g}, worst <= {TARGETS['worst']:g}, cold <= 5 (2D) / 4 (3D)): "
          f"{sum(r['met'] == 'met' for r in measured)}/{len(measured)}")
    return 0 if all(r.get("converged") for r in rows) else 1


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--members", nargs="+", default=["friction", "friction3d"],
                   help="friction member names or groups (friction, friction3d) or all")
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--increments", nargs="+", default=["20"], choices=("20", "auto"))
    p.add_argument("--predictor", nargs="+", default=["auto"], choices=PREDICTORS)
    p.add_argument("--cells", type=int, default=CELLS[2], help="2D: cells a side")
    p.add_argument("--cells3d", type=int, default=CELLS[3], help="3D: cells a side")
    p.add_argument("--repeat", type=int, default=1, help="timed (floor, solve) pairs of the cold solve")
    p.add_argument("--smoke", action="store_true", help="16 (2D) and 4 (3D) cells, one member each, one rank")
    args_list = list(sys.argv[1:] if argv is None else argv)
    if "--smoke" in args_list and "--worker" not in args_list:
        args_list += ["--cells", str(SMOKE_CELLS[2]), "--cells3d", str(SMOKE_CELLS[3]), "--np", "1",
                      "--members", "1-1-mu0.3", "3d-1-1-mu0.3"]
    return run_harness(p, args_list, worker, driver, hidden=("--member", "--tmp", "--json"))


if __name__ == "__main__":
    sys.exit(main())
