#!/usr/bin/env python3
"""The solver's benchmark family (issue 13): iterations, converged reasons and time against a linear floor.

    /usr/bin/python3 benchmarks/family.py [--np 1 2] [--members issue corners ...] [--repeat 3] [--csv F]

Every member is the issue's geometry — the unit square, N = 256 cells a side (132,098 dofs), clamped on
top, f = (0, −0.5), contact on the bottom, E = 1 — with a contact law (c_n/E, m_n, gap), or the same square
made of two materials (E = 1 below y = 1/2, E = 1000 above: a gmsh mesh with two cell groups). Each is
solved with NO options (the shipped defaults: preset "auto") in its own process (``--worker``), on 1 and 2
ranks, and timed against the linear floor measured in the same process, back to back:

- ``floor``: one linear elasticity solve K u = L on the same mesh (the solver's K and L), CG + GAMG with
  the rigid-body near-nullspace and the solver's AMG options, ksp_rtol 1e-8 (preconditioned norm, PETSc's
  default for CG), PC set-up included, K's assembly not (the nonlinear solve does not pay for it either);
- ``cold``: ``NonlinearSolver.solve()`` from u = 0 (Newton to ‖F‖ <= 1e-10 ‖F_0‖ or 1e-10 ‖L‖);
- ``nested``: the adaptive loop's next level: the member solved on N/2, refined uniformly (132,098 dofs
  again), the solution transferred, ``solve()`` on the child against the floor on the child;
- ``floor=``: for context, the floor at the nonlinear solve's accuracy (true residual <= 1e-10 ‖L‖).

Every timed solve follows an identical untimed one (JIT, first touch of memory), and of ``--repeat``
alternating floor/solve pairs the fastest of each is kept. Legacy FEniCS (``legacy_fenics.py``, Newton +
CG + GAMG, u = 0) runs the square members in its own process when python3-dolfin is installed
(``--legacy``). A 3D member is one more entry in MEMBERS with its body in BODIES.
"""
import argparse
import csv
import json
import math
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
from run import launch, legacy_available  # noqa: E402  (the harness's process launcher)

FLOOR_RTOL = 1e-8


@dataclass(frozen=True)
class Member:
    name: str
    c_n: float
    m_n: float
    gap: tuple = (0.0, 0.0)  # g_0 = a + b x
    body: str = "square"     # a key of BODIES
    group: str = ""          # "issue": the five rows of issue 13, "corner": c_n/E and m_n extremes, ...

    def gap_text(self):
        a, b = self.gap
        return "0" if a == b == 0 else f"{a} + {b}*x"


MEMBERS = [
    # the issue's five rows
    Member("1-1", 1, 1, group="issue"), Member("100-2", 100, 2, group="issue"),
    Member("1e4-1", 1e4, 1, group="issue"), Member("1e3-3", 1e3, 3, group="issue"),
    Member("10-1.5-gap", 10, 1.5, (0.002, 0.002), group="issue"),
    # the corners of c_n/E in [0.1, 1e5] x m_n in [1, 3]
    Member("0.1-1", 0.1, 1, group="corner"), Member("0.1-3", 0.1, 3, group="corner"),
    Member("1e5-1", 1e5, 1, group="corner"), Member("1e5-3", 1e5, 3, group="corner"),
    # gaps on a penalty and a cubic law, m_n = 1.5 without gap
    Member("1e4-1-gap", 1e4, 1, (0.002, 0.002), group="gap"),
    Member("1e3-3-gap", 1e3, 3, (0.002, 0.002), group="gap"),
    Member("1-1.5", 1, 1.5, group="gap"),
    # two materials, E 1 : 1000
    Member("two-100-2", 100, 2, body="two_materials", group="materials"),
    Member("two-1e4-1", 1e4, 1, body="two_materials", group="materials"),
]


def square_body(cells, tmp):
    return {"rectangle": [[0.0, 0.0], [1.0, 1.0]], "cells": [cells, cells]}, {}


def two_materials_body(cells, tmp):
    path = Path(tmp) / f"two_materials_{cells}.msh"
    return {"file": str(path)}, {"regions": {"stiff": {"E": 1000.0}}}


# body -> (mesh table, material extras) for a mesh of `cells` cells a side (3D: a box, once it lands)
BODIES = {"square": square_body, "two_materials": two_materials_body}


def problem_data(member, cells, tmp):
    mesh, material = BODIES[member.body](cells, tmp)
    mesh.update(dirichlet=["top"], neumann=["left", "right"], contact=["bottom"])
    return {"mesh": mesh, "material": {"E": 1.0, "nu": 0.3, **material}, "loads": {"f": ["0", "-0.5"]},
            "contact": {"c_n": member.c_n, "m_n": member.m_n, "gap": member.gap_text()}}


def write_two_materials_mesh(path, cells):
    """Structured triangles on [0,1]^2, `cells` a side; cell groups soft (y < 1/2) and stiff; boundary
    groups bottom, right, top, left."""
    import gmsh
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("two_materials")
        geo = gmsh.model.geo
        p = [geo.addPoint(x, y, 0.0) for x, y in ((0, 0), (1, 0), (1, 0.5), (0, 0.5), (1, 1), (0, 1))]
        bottom, right1, middle, left1 = (geo.addLine(p[i], p[j]) for i, j in ((0, 1), (1, 2), (2, 3), (3, 0)))
        right2, top, left2 = (geo.addLine(p[i], p[j]) for i, j in ((2, 4), (4, 5), (5, 3)))
        soft = geo.addPlaneSurface([geo.addCurveLoop([bottom, right1, middle, left1])])
        stiff = geo.addPlaneSurface([geo.addCurveLoop([-middle, right2, top, left2])])
        for curve in (bottom, middle, top):
            geo.mesh.setTransfiniteCurve(curve, cells + 1)
        for curve in (right1, left1, right2, left2):
            geo.mesh.setTransfiniteCurve(curve, cells // 2 + 1)
        for surface in (soft, stiff):
            geo.mesh.setTransfiniteSurface(surface)
        geo.synchronize()
        groups = {"bottom": [bottom], "right": [right1, right2], "top": [top], "left": [left1, left2]}
        for tag, (name, curves) in enumerate(groups.items(), start=1):
            gmsh.model.addPhysicalGroup(1, curves, tag)
            gmsh.model.setPhysicalName(1, tag, name)
        for tag, (name, surface) in enumerate((("soft", soft), ("stiff", stiff)), start=1):
            gmsh.model.addPhysicalGroup(2, [surface], tag)
            gmsh.model.setPhysicalName(2, tag, name)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


# ------------------------------------------------------------------------------------------------
# worker
# ------------------------------------------------------------------------------------------------

def barrier_time(comm):
    comm.barrier()
    return time.perf_counter()


class Clock:
    """Wall time on rank 0 between barriers, and CPU time (the largest over ranks): CPU time does not
    count the time another job held the core, so on a shared machine its ratios are the steadier."""

    def __init__(self, comm):
        self.comm = comm
        self.wall, self.cpu = barrier_time(comm), time.process_time()

    def stop(self):
        cpu = self.comm.allreduce(time.process_time() - self.cpu, op=_max())
        return barrier_time(self.comm) - self.wall, cpu


def _max():
    from mpi4py import MPI
    return MPI.MAX


def floor_solve(solver, comm, rtol=FLOOR_RTOL, norm="preconditioned"):
    """CG + GAMG on the solver's K (rigid modes and SPD flag set) for L: (wall s, CPU s, iterations)."""
    from petsc4py import PETSc
    from nc_dolfinx.solver import AMG, set_petsc_options
    set_petsc_options({"ksp_type": "cg", "ksp_rtol": rtol, "ksp_norm_type": norm, **AMG}, "floor_")
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix("floor_")
    ksp.setOperators(solver.K)
    ksp.setFromOptions()
    x = solver.K.createVecRight()
    clock = Clock(comm)
    ksp.solve(solver.load, x)
    wall, cpu = clock.stop()
    its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
    ksp.destroy()
    x.destroy()
    if reason <= 0:
        raise RuntimeError(f"the linear floor did not converge (reason {reason})")
    return wall, cpu, its


class Level:
    """One mesh of a member: set up the solver (from u = 0 or a transferred solution) and solve."""

    def __init__(self, problem, domain, initial=None):
        self.problem, self.domain, self.initial = problem, domain, initial

    def solve(self, comm):
        """(setup s, (solve wall s, solve CPU s), stats, solver, u, fields); the caller destroys the solver."""
        from dolfinx import fem
        from nc_dolfinx import forms, refinement
        from nc_dolfinx.adaptive import dirichlet_bcs
        from nc_dolfinx.problem import bind
        from nc_dolfinx.solver import NonlinearSolver, solver_options
        start = barrier_time(comm)
        fields = bind(self.problem, self.domain)
        V = fem.VectorFunctionSpace(self.domain.mesh, ("CG", 1))
        u = refinement.transfer(self.initial, V) if self.initial is not None else fem.Function(V)
        solver = NonlinearSolver(forms.normal_compliance_forms(u, fields), u, dirichlet_bcs(V, fields),
                                 solver_options(self.problem.preset, self.problem.petsc_options), "auto",
                                 forms.energy(u, fields))
        setup = barrier_time(comm) - start
        clock = Clock(comm)
        stats = solver.solve()
        wall, cpu = clock.stop()
        return setup, (wall, cpu), stats, solver, u, fields


def measure(level, comm, repeat, with_equal_floor):
    """Warm-up, then `repeat` alternating (floor, solve) pairs; the fastest of each (wall and CPU apart)."""
    best = {key: math.inf for key in ("t_floor", "t_solve", "t_setup", "cpu_floor", "cpu_solve")}
    for attempt in range(repeat + 1):
        setup, (wall, cpu), stats, solver, u, fields = level.solve(comm)
        t_floor, cpu_floor, floor_its = floor_solve(solver, comm)
        if attempt == 0:
            if with_equal_floor:
                best["t_floor_eq"], best["cpu_floor_eq"], best["floor_eq_its"] = floor_solve(
                    solver, comm, 1e-10, "unpreconditioned")
            solver.destroy()
            continue
        for key, value in (("t_floor", t_floor), ("cpu_floor", cpu_floor), ("t_solve", wall),
                           ("cpu_solve", cpu), ("t_setup", setup)):
            best[key] = min(best[key], value)
        best.update(floor_its=floor_its, newton=stats.newton_iterations, krylov=stats.linear_iterations,
                    reason=stats.converged_reason, preset=stats.preset, pc_setups=stats.pc_setups,
                    recoveries=stats.recoveries)
        solver.destroy()
    best["ratio"] = best["t_solve"] / best["t_floor"]
    best["ratio_cpu"] = best["cpu_solve"] / best["cpu_floor"]
    return best, u, fields


def contact_quantities(u, fields):
    from nc_dolfinx import forms
    from nc_dolfinx.quantities import integrate
    comm = fields.domain.comm
    return {"energy": integrate(forms.elastic_energy(u, fields), comm),
            "contact_force": integrate(forms.contact_pressure(u, fields) * forms.contact_measure(fields), comm)}


def worker(args):
    from mpi4py import MPI
    from nc_dolfinx import refinement
    from nc_dolfinx.problem import build_domain, problem_from_data
    comm = MPI.COMM_WORLD
    member = next(m for m in MEMBERS if m.name == args.member)
    row = {"member": member.name, "np": comm.size, **asdict(member)}
    problem = problem_from_data(problem_data(member, args.cells, args.tmp), member.name)
    domain = build_domain(problem, comm)
    row["dofs"] = 2 * domain.num_vertices()
    cold, u, fields = measure(Level(problem, domain), comm, args.repeat, True)
    row.update(cold)
    row.update(contact_quantities(u, fields))
    if not args.no_nested:
        parent = build_domain(problem_from_data(problem_data(member, args.cells // 2, args.tmp), member.name), comm)
        _, _, _, solver, u_parent, _ = Level(problem, parent).solve(comm)
        solver.destroy()
        child = refinement.refine(parent)
        nested, _, _ = measure(Level(problem, child, u_parent), comm, args.repeat, False)
        row.update({f"nested_{k}": v for k, v in nested.items()})
        row["nested_dofs"] = 2 * child.num_vertices()
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row, indent=1, default=str))


# ------------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------------

def run_member(member, nprocs, args, tmp):
    out = Path(tmp) / f"{member.name}_{nprocs}.json"
    cmd = [Path(__file__).resolve(), "--worker", "--member", member.name, "--cells", args.cells,
           "--repeat", args.repeat, "--tmp", tmp, "--json", out] + (["--no-nested"] if args.no_nested else [])
    proc = launch(cmd, nprocs, args.timeout)
    if proc.returncode != 0:
        print(f"{member.name} on {nprocs} rank(s) FAILED:\n{proc.stderr[-3000:]}", file=sys.stderr)
        return {"member": member.name, "np": nprocs, "reason": "FAILED"}
    return json.loads(out.read_text())


def run_legacy(member, row, args, tmp):
    """Legacy FEniCS on the same square (total time setup + solve, the fastest of --repeat runs)."""
    out = Path(tmp) / f"legacy_{member.name}.json"
    cmd = [HERE / "legacy_fenics.py", "--problem", "square", "--cells", args.cells, args.cells,
           "--cn", member.c_n, "--mn", member.m_n, "--gap", *member.gap, "--json", out]
    runs = []
    for _ in range(max(1, args.repeat)):
        proc = launch(cmd, row["np"], args.timeout)
        if proc.returncode != 0:  # dolfin's Newton raised (a diverged Krylov solve, NaN)
            last = (proc.stderr.strip().splitlines() or ["?"])[-1]
            return {"legacy_reason": "failed: " + last[-100:]}
        runs.append(json.loads(out.read_text()))
    best = min(runs, key=lambda r: r["setup"] + r["solve"])
    if not best["converged"]:  # dolfin's Newton (no line search) on a stiff penalty
        return {"legacy_reason": "diverged", "legacy_krylov": best["krylov"]}
    total = best["setup"] + best["solve"]
    return {"t_legacy": total, "legacy_newton": best["newton"], "legacy_krylov": best["krylov"],
            "legacy_reason": "converged",
            "legacy_energy_rdiff": abs(best["energy"] - row["energy"]) / abs(row["energy"]),
            "speedup_legacy": total / (row["t_setup"] + row["t_solve"])}


COLUMNS = [  # (header, key, format)
    ("member", "member", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"), ("preset", "preset", "{}"),
    ("Nwt", "newton", "{}"), ("Kry", "krylov", "{}"), ("PC", "pc_setups", "{}"), ("reason", "reason", "{}"),
    ("floor", "t_floor", "{:.3f}"), ("its", "floor_its", "{}"), ("solve", "t_solve", "{:.3f}"),
    ("cold/floor", "ratio", "{:.2f}"), ("cpu", "ratio_cpu", "{:.2f}"), ("cpu=", "ratio_eq_cpu", "{:.2f}"),
    ("nest Nwt", "nested_newton", "{}"), ("nest Kry", "nested_krylov", "{}"), ("nest preset", "nested_preset", "{}"),
    ("nest/floor", "nested_ratio", "{:.2f}"), ("cpu", "nested_ratio_cpu", "{:.2f}"),
    ("legacy", "t_legacy", "{:.2f}"), ("leg Nwt", "legacy_newton", "{}"), ("x legacy", "speedup_legacy", "{:.1f}"),
    ("legacy end", "legacy_reason", "{}"), ("fallbacks", "recoveries", "{}"),
]


def table(rows):
    cells = [[fmt.format(r[key]) if r.get(key) not in (None, "") else "-" for _, key, fmt in COLUMNS] for r in rows]
    widths = [max(len(h), *(len(c[i]) for c in cells)) for i, (h, _, _) in enumerate(COLUMNS)]
    lines = ["  ".join(h.rjust(w) for (h, _, _), w in zip(COLUMNS, widths)),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.rjust(w) for c, w in zip(row, widths)) for row in cells]
    return "\n".join(lines)


def targets(rows):
    """The issue's targets, checked on the table (benchmarks, not tests)."""
    ok = [r for r in rows if str(r.get("reason", "")).startswith("CONVERGED")]
    lines = [f"converged with no options: {len(ok)}/{len(rows)}"]
    for label, key, limit in (("cold <= 1.5x floor (wall)", "ratio", 1.5), ("cold, CPU time", "ratio_cpu", 1.5),
                              ("nested <= 1.2x floor (wall)", "nested_ratio", 1.2),
                              ("nested, CPU time", "nested_ratio_cpu", 1.2)):
        have = [r for r in rows if r.get(key) is not None]
        worst = max(have, key=lambda r: r[key], default=None)
        if worst:
            met = sum(r[key] <= limit for r in have)
            lines.append(f"{label}: {met}/{len(have)} (worst {worst[key]:.2f}, {worst['member']} np={worst['np']})")
    legacy = [r["speedup_legacy"] for r in rows if r.get("speedup_legacy")]
    if legacy:
        lines.append(f">= 3x faster than legacy FEniCS: {sum(s >= 3 for s in legacy)}/{len(legacy)} "
                     f"(least {min(legacy):.1f}x)")
    return "\n".join(lines)


def driver(args):
    tmp = tempfile.mkdtemp(prefix="nc_family_")
    members = [m for m in MEMBERS if m.name in args.members or m.group in args.members or "all" in args.members]
    if any(m.body == "two_materials" for m in members):
        for cells in (args.cells, args.cells // 2):
            write_two_materials_mesh(Path(tmp) / f"two_materials_{cells}.msh", cells)
    with_legacy = args.legacy and legacy_available()
    if args.legacy and not with_legacy:
        print("legacy FEniCS (python3-dolfin) is not importable: no legacy columns", file=sys.stderr)
    rows, start = [], time.perf_counter()
    for member in members:
        for nprocs in args.np:  # the rank counts of one member back to back
            row = run_member(member, nprocs, args, tmp)
            if "cpu_floor_eq" in row:
                row["ratio_eq_cpu"] = row["cpu_solve"] / row["cpu_floor_eq"]
            if with_legacy and member.body == "square" and nprocs in args.legacy_np and "energy" in row:
                row.update(run_legacy(member, row, args, tmp))
            rows.append(row)
            print(f"  {member.name} np={nprocs}: {row.get('reason')} ratio {row.get('ratio', math.nan):.2f} "
                  f"({time.perf_counter() - start:.0f} s)", file=sys.stderr, flush=True)
    print(table(rows))
    print()
    print(targets(rows))
    if args.csv:
        keys = sorted({k for r in rows for k in r})
        with open(args.csv, "w", newline="") as fh:
            writer = csv.DictWriter(fh, keys)
            writer.writeheader()
            writer.writerows(rows)
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(rows, indent=1, default=str))
    return 0 if all(str(r.get("reason", "")).startswith("CONVERGED") for r in rows) else 1


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--members", nargs="+", default=["all"],
                   help="member names or groups (issue, corner, gap, materials) or all")
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--cells", type=int, default=256, help="cells a side (256: 132,098 dofs)")
    p.add_argument("--repeat", type=int, default=2, help="timed (floor, solve) pairs per process")
    p.add_argument("--no-nested", action="store_true")
    p.add_argument("--legacy", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--legacy-np", type=int, nargs="+", default=[1])
    p.add_argument("--timeout", type=float, default=1800)
    p.add_argument("--csv")
    p.add_argument("--json-out")
    p.add_argument("--smoke", action="store_true", help="16 cells, one repeat, no legacy (seconds)")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--member", help=argparse.SUPPRESS)
    p.add_argument("--tmp", help=argparse.SUPPRESS)
    p.add_argument("--json", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.smoke:
        args.cells, args.repeat, args.legacy = 16, 1, False
    return worker(args) if args.worker else driver(args)


if __name__ == "__main__":
    sys.exit(main())
