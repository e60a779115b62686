#!/usr/bin/env python3
"""The solver's benchmark family (issue 13): iterations, converged reasons and time against a linear floor.

    /usr/bin/python3 benchmarks/family.py [--np 1 2] [--members issue 3d ...] [--repeat 3] [--csv F]

Every 2D member is the issue's geometry — the unit square, N = 256 cells a side (132,098 dofs), clamped on
top, f = (0, −0.5), contact on the bottom, E = 1 — with a contact law (c_n/E, m_n, gap), or the same square
made of two materials (E = 1 below y = 1/2, E = 1000 above: a gmsh mesh with two cell groups). Every 3D
member is the same in the unit cube (``mesh.box``, tetrahedra, n = 32 cells a side: 107,811 dofs; clamped
on top, f = (0, 0, −0.5), contact on the bottom, the four sides free), with each of the 2D members' laws and
the two-material body (the cells above z = 1/2 stiff). Each is solved with NO options (the shipped
defaults: preset "auto") through the public API (``nc.solve``) in its own process (``--worker``), on 1 and
2 ranks, and timed against the linear floor measured in the same process, back to back:

- ``floor``: one linear elasticity solve K u = L on the same mesh, written independently of nc_dolfinx's
  solver as DOLFINx's demo_elasticity.py does it (``common.LinearFloor``: CG + GAMG, rigid-body
  near-nullspace, SPD flag, ksp_rtol 1e-8 in CG's preconditioned norm), PC set-up included, assembly not;
- ``solve``: the SNES time of ``nc.solve`` from u = 0 (``Solution.stats.time``: Newton to
  ‖F‖ <= 1e-10 ‖F_0‖ or 1e-10 ‖L‖), its assembly of K and L not included (``setup``: the rest of the call);
- ``nested``: the adaptive loop's next level: the member solved on N/2, refined uniformly (the same dofs
  again), ``nc.solve`` on the child from the parent's solution, against the floor on the child;
- ``floor=``: for context, the floor at the nonlinear solve's accuracy (true residual <= 1e-10 ‖L‖);
- ``increment`` (friction members): the last increment of a load path, on the same mesh: the member solved
  at 9/10 of its weight, the law's state moved on by the return map (``nc.SlipState.after``), then
  ``nc.solve`` at the full weight from there (``initial`` and ``previous_state``), against the floor.

Every timed solve follows an identical untimed one (JIT, first touch of memory), and of ``--repeat``
alternating floor/solve pairs the fastest of each is kept. Legacy FEniCS (``legacy_fenics.py``, Newton +
CG + GAMG, u = 0) runs the 2D square members in its own process when python3-dolfin is installed
(``--legacy``).
"""
import argparse
import csv
import json
import math
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (LinearFloor, format_table, launch, legacy_available, machine_load,  # noqa: E402
                    pc_available, refine_uniformly, timed_solve, dofs)

CELLS = {2: 256, 3: 32}        # cells a side: 132,098 dofs (2D), 107,811 dofs (3D)
SMOKE_CELLS = {2: 16, 3: 4}


@dataclass(frozen=True)
class Member:
    name: str
    c_n: float
    m_n: float
    gap: tuple = (0.0, 0.0)  # g_0 = a + b x
    body: str = "square"     # a key of BODIES
    group: str = ""          # "issue": the five rows of issue 13, "corner": c_n/E and m_n extremes, ...
    friction: float = None   # Coulomb's μ (contact.friction), None: frictionless

    def gap_text(self):
        a, b = self.gap
        return " + ".join(([f"{a:g}"] if a else []) + ([f"{b:g}*x"] if b else [])) or "0"

    @property
    def dim(self):
        return BODIES[self.body][1]


MEMBERS_2D = [
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
# 3D: every law of the 2D family on the unit cube (m_n <= 3 is admissible in 3D), group "3d"
MEMBERS_3D = [replace(m, name="3d-" + m.name, group="3d",
                      body={"square": "cube", "two_materials": "two_materials_cube"}[m.body]) for m in MEMBERS_2D]
# Coulomb friction (issue 32): the issue's laws with μ from 0.1 to 1. The weight presses the base, which the
# Poisson effect spreads sideways: it sticks in the middle and slips towards the free sides.
MEMBERS_FRICTION = [Member(f"{m.name}-mu{mu:g}", m.c_n, m.m_n, m.gap, m.body, "friction", mu)
                    for m in MEMBERS_2D[:3] for mu in (0.1, 0.3, 1.0)]
MEMBERS_FRICTION += [replace(m, name="3d-" + m.name, group="friction3d", body="cube") for m in MEMBERS_FRICTION[:6]]
MEMBERS = MEMBERS_2D + MEMBERS_3D + MEMBERS_FRICTION


# --- bodies: (mesh table, Domain or None, material extras) for `cells` cells a side -----------------

def square_body(cells, comm, tmp):
    return {"rectangle": [[0.0, 0.0], [1.0, 1.0]], "cells": [cells, cells]}, None, {}


def two_materials_body(cells, comm, tmp):
    path = Path(tmp) / f"two_materials_{cells}.msh"
    return {"file": str(path)}, None, {"regions": {"stiff": {"E": 1000.0, "nu": 0.3}}}


def cube_body(cells, comm, tmp):
    return {"box": [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], "cells": [cells] * 3}, None, {}


def two_materials_cube_body(cells, comm, tmp):
    """The unit cube (``nc.box``) with its cells above z = 1/2 in the group 'stiff' (``nc.from_dolfinx``)."""
    import numpy as np
    import nc_dolfinx as nc
    from dolfinx import mesh as dmesh
    cube = nc.box(comm, [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [cells] * 3)
    msh = cube.mesh
    n_cells = msh.topology.index_map(3).size_local + msh.topology.index_map(3).num_ghosts
    all_cells = np.arange(n_cells, dtype=np.int32)
    stiff = dmesh.compute_midpoints(msh, 3, all_cells)[:, 2] > 0.5
    cell_tags = dmesh.meshtags(msh, 3, all_cells, np.where(stiff, 2, 1).astype(np.int32))
    names = {group_id: name for name, group_id in cube.facet_groups.items()}
    domain = nc.from_dolfinx(msh, cube.facet_tags, names, cell_tags, {1: "soft", 2: "stiff"})
    return {}, domain, {"regions": {"stiff": {"E": 1000.0, "nu": 0.3}}}


# body -> (maker, dimension)
BODIES = {"square": (square_body, 2), "two_materials": (two_materials_body, 2),
          "cube": (cube_body, 3), "two_materials_cube": (two_materials_cube_body, 3)}
ROLES = {2: {"dirichlet": ["top"], "neumann": ["left", "right"], "contact": ["bottom"]},
         3: {"dirichlet": ["top"], "neumann": ["left", "right", "front", "back"], "contact": ["bottom"]}}


def member_problem(member, cells, comm, tmp):
    """The member's nc.Problem and its Domain with ``cells`` cells a side."""
    import nc_dolfinx as nc
    make, dim = BODIES[member.body]
    mesh, domain, material = make(cells, comm, tmp)
    mesh.update(ROLES[dim])
    data = {"mesh": mesh, "material": {"E": 1.0, "nu": 0.3, **material},
            "loads": {"f": ["0"] * (dim - 1) + ["-0.5"]},
            "contact": {"c_n": member.c_n, "m_n": member.m_n, "gap": member.gap_text(),
                        **({} if member.friction is None else {"friction": member.friction})}}
    problem = nc.Problem.from_dict(data, member.name)
    return problem, domain if domain is not None else nc.build_domain(problem, comm)


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

def scaled(problem, factor):
    """``problem`` with its body force times ``factor`` (an earlier state of a load path)."""
    import nc_dolfinx as nc
    raw = dict(problem.raw)
    raw["loads"] = {**raw["loads"], "f": [f"{factor!r}*({f})" for f in raw["loads"]["f"]]}
    return nc.Problem.from_dict(raw, problem.name)


def measure(problem, domain, comm, repeat, initial=None, with_equal_floor=False, petsc_options=None,
            previous_state=None):
    """Warm-up, then `repeat` alternating (floor, solve) pairs; the fastest of each. Returns (row, Solution)."""
    floor = LinearFloor(problem, domain)
    with_ml = pc_available("ml")
    best = {key: math.inf for key in ("t_floor", "t_solve", "t_setup")}
    for attempt in range(repeat + 1):
        solution, setup, solve = timed_solve(problem, domain, comm, initial=initial, petsc_options=petsc_options,
                                             previous_state=previous_state)
        t_floor, floor_its, floor_residual = floor.solve()
        t_floor_ml = floor.solve(amg="ml")[0] if with_ml else None  # ML: not in trixie's and sid's PETSc
        t_floor_hypre = floor.solve(amg="hypre")[0]
        if attempt == 0:
            if with_equal_floor:
                best["t_floor_eq"], best["floor_eq_its"], _ = floor.solve(1e-10, "unpreconditioned")
            continue
        for key, value in (("t_floor", t_floor), ("t_floor_ml", t_floor_ml), ("t_floor_hypre", t_floor_hypre),
                           ("t_solve", solve), ("t_setup", setup)):
            if value is not None:
                best[key] = min(best.get(key, math.inf), value)
        stats = solution.stats
        best.update(floor_its=floor_its, floor_residual=floor_residual, newton=stats.newton_iterations,
                    krylov=stats.linear_iterations, reason=stats.converged_reason, preset=stats.preset,
                    pc_setups=stats.pc_setups, recoveries=stats.recoveries, pc_type=stats.pc_type,
                    passes=stats.friction_passes)
    floor.destroy()
    best["ratio"] = best["t_solve"] / best["t_floor"]
    if "t_floor_ml" in best:
        best["ratio_ml"] = best["t_solve"] / best["t_floor_ml"]
    best["ratio_hypre"] = best["t_solve"] / best["t_floor_hypre"]
    if "t_floor_eq" in best:
        best["ratio_eq"] = best["t_solve"] / best["t_floor_eq"]
    return best, solution


def worker(args):
    import nc_dolfinx as nc
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    member = next(m for m in MEMBERS if m.name == args.member)
    cells = args.cells if member.dim == 2 else args.cells3d
    row = {"member": member.name, "np": comm.size, "dim": member.dim, **asdict(member)}
    problem, domain = member_problem(member, cells, comm, args.tmp)
    row["dofs"] = dofs(domain)
    options = dict(item.partition("=")[::2] for item in args.petsc or []) or None
    cold, solution = measure(problem, domain, comm, args.repeat, with_equal_floor=True, petsc_options=options)
    row.update(cold)
    quantities = nc.solution_quantities(solution.u, solution.fields)
    row.update(energy=quantities["elastic_energy"], contact_resultant=quantities["contact_resultant"])
    if member.friction is not None and not args.no_increment:
        start = nc.solve(scaled(problem, 0.9), domain, petsc_options=options)
        increment, _ = measure(problem, domain, comm, args.repeat, initial=start.u, petsc_options=options,
                               previous_state=nc.SlipState.after(start.u, start.fields))
        row.update({f"increment_{k}": increment[k] for k in ("newton", "krylov", "pc_setups", "passes", "ratio")})
    if not args.no_nested:
        _, parent = member_problem(member, cells // 2, comm, args.tmp)
        u_parent = nc.solve(problem, parent, petsc_options=options).u
        child = refine_uniformly(parent)
        nested, _ = measure(problem, child, comm, args.repeat, initial=u_parent, petsc_options=options)
        row.update({f"nested_{k}": v for k, v in nested.items()})
        row["nested_dofs"] = dofs(child)
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row, indent=1, default=str))


# ------------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------------

def run_member(member, nprocs, args, tmp):
    out = Path(tmp) / f"{member.name}_{nprocs}.json"
    cmd = [Path(__file__).resolve(), "--worker", "--member", member.name, "--cells", args.cells,
           "--cells3d", args.cells3d, "--repeat", args.repeat, "--tmp", tmp, "--json", out]
    cmd += ["--no-nested"] if args.no_nested else []
    cmd += ["--no-increment"] if args.no_increment else []
    for item in args.petsc or []:
        cmd += ["--petsc", item]
    proc = launch(cmd, nprocs, args.timeout)
    if proc.returncode != 0:
        print(f"{member.name} on {nprocs} rank(s) FAILED:\n{proc.stderr[-3000:]}", file=sys.stderr)
        return {"member": member.name, "np": nprocs, "dim": member.dim, "reason": "FAILED"}
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


COLUMNS = [  # (key, header, format)
    ("member", "member", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
    ("pc_type", "pc", "{}"), ("newton", "Nwt", "{}"), ("krylov", "Kry", "{}"), ("pc_setups", "set", "{}"),
    ("passes", "fp", "{}"), ("reason", "reason", "{}"),
    ("t_floor", "floor", "{:.3f}"), ("floor_its", "its", "{}"), ("t_solve", "solve", "{:.3f}"),
    ("ratio", "cold/floor", "{:.2f}"), ("ratio_eq", "cold/floor=", "{:.2f}"),
    ("increment_newton", "incr Nwt", "{}"), ("increment_passes", "fp", "{}"),
    ("increment_ratio", "incr/floor", "{:.2f}"),
    ("nested_newton", "nest Nwt", "{}"), ("nested_krylov", "Kry", "{}"), ("nested_pc_type", "pc", "{}"),
    ("nested_ratio", "nest/floor", "{:.2f}"), ("nested_ratio_ml", "(ML)", "{:.2f}"),
    ("nested_ratio_hypre", "(hypre)", "{:.2f}"),
    ("t_legacy", "legacy", "{:.2f}"), ("legacy_newton", "leg Nwt", "{}"), ("speedup_legacy", "x legacy", "{:.1f}"),
    ("legacy_reason", "legacy end", "{}"), ("recoveries", "fallbacks", "{}"),
]


def targets(rows):
    """The issue's targets, checked on the table (benchmarks, not tests)."""
    ok = [r for r in rows if str(r.get("reason", "")).startswith("CONVERGED")]
    lines = [f"converged with no options: {len(ok)}/{len(rows)}"]
    for label, key, limit in (("cold <= 1.5x floor", "ratio", 1.5), ("nested <= 1.2x floor", "nested_ratio", 1.2),
                              ("friction: cold <= 2x floor", "ratio", 2.0),
                              ("friction: increment <= 2x floor", "increment_ratio", 2.0),
                              ("friction: nested <= 2x floor", "nested_ratio", 2.0)):
        for dim in (2, 3):
            have = [r for r in rows if r.get(key) is not None and r.get("dim") == dim
                    and (r.get("friction") is not None or not label.startswith("friction"))]
            worst = max(have, key=lambda r: r[key], default=None)
            if worst:
                met = sum(r[key] <= limit for r in have)
                lines.append(f"{dim}D {label}: {met}/{len(have)} (worst {worst[key]:.2f}, "
                             f"{worst['member']} np={worst['np']})")
    legacy = [r["speedup_legacy"] for r in rows if r.get("speedup_legacy")]
    if legacy:
        lines.append(f">= 3x faster than legacy FEniCS: {sum(s >= 3 for s in legacy)}/{len(legacy)} "
                     f"(least {min(legacy):.1f}x)")
    return "\n".join(lines)


def selected(args):
    return [m for m in MEMBERS if (m.name in args.members or m.group in args.members or "all" in args.members)
            and m.dim in args.dims]


def driver(args):
    tmp = tempfile.mkdtemp(prefix="nc_family_")
    members = selected(args)
    if any(m.body == "two_materials" for m in members):
        for cells in (args.cells, args.cells // 2):
            write_two_materials_mesh(Path(tmp) / f"two_materials_{cells}.msh", cells)
    with_legacy = args.legacy and legacy_available()
    if args.legacy and not with_legacy:
        print("legacy FEniCS (python3-dolfin) is not importable: no legacy columns", file=sys.stderr)
    rows, start = [], time.perf_counter()
    print(f"load average at the start: {machine_load():.2f}", file=sys.stderr, flush=True)
    for member in members:
        for nprocs in args.np:  # the rank counts of one member back to back
            row = run_member(member, nprocs, args, tmp)
            if with_legacy and member.body == "square" and nprocs in args.legacy_np and "energy" in row:
                row.update(run_legacy(member, row, args, tmp))
            row["load"] = machine_load()
            rows.append(row)
            print(f"  {member.name} np={nprocs}: {row.get('reason')} ratio {row.get('ratio', math.nan):.2f} "
                  f"({time.perf_counter() - start:.0f} s, load {row['load']:.2f})", file=sys.stderr, flush=True)
    for dim in (2, 3):
        these = [r for r in rows if r.get("dim") == dim]
        if these:
            print(f"\n{dim}D\n" + format_table(these, COLUMNS))
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
                   help="member names or groups (issue, corner, gap, materials, 3d, friction, friction3d) or all")
    p.add_argument("--dims", type=int, nargs="+", default=[2, 3], choices=(2, 3))
    p.add_argument("--np", type=int, nargs="+", default=[1, 2])
    p.add_argument("--cells", type=int, default=CELLS[2], help="2D: cells a side (256: 132,098 dofs)")
    p.add_argument("--cells3d", type=int, default=CELLS[3], help="3D: cells a side (32: 107,811 dofs)")
    p.add_argument("--repeat", type=int, default=2, help="timed (floor, solve) pairs per process")
    p.add_argument("--no-nested", action="store_true")
    p.add_argument("--no-increment", action="store_true", help="friction members: no load-path increment")
    p.add_argument("--petsc", action="append", metavar="KEY=VALUE",
                   help="exploration: a solver option for nc.solve (the family's figures use none)")
    p.add_argument("--legacy", action=argparse.BooleanOptionalAction, default=True)
    p.add_argument("--legacy-np", type=int, nargs="+", default=[1])
    p.add_argument("--timeout", type=float, default=1800)
    p.add_argument("--csv")
    p.add_argument("--json-out")
    p.add_argument("--smoke", action="store_true", help="16 (2D) and 4 (3D) cells, one repeat, no legacy")
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--member", help=argparse.SUPPRESS)
    p.add_argument("--tmp", help=argparse.SUPPRESS)
    p.add_argument("--json", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.smoke:
        args.cells, args.cells3d, args.repeat, args.legacy = SMOKE_CELLS[2], SMOKE_CELLS[3], 1, False
    return worker(args) if args.worker else driver(args)


if __name__ == "__main__":
    sys.exit(main())
