#!/usr/bin/env python3
"""Performance harness for nc_dolfinx (issues 5, 10 and 13): phases, iterations, memory and baselines per mesh size.

One command (1 and 2 ranks, the default sizes, tables on stdout, every column in the CSV; see
benchmarks/README.md for the columns)::

    /usr/bin/python3 benchmarks/run.py --csv benchmarks/results.csv

Problems: ``block`` and ``corner`` (2D, the built-in cases) and ``box`` (3D: the block in 3D, the data of the
``box`` case, on ``mesh.box`` [0,2]x[0,1]x[0,1] with [2k, k, k] cells of tetrahedra).

The script is a *driver*: for every rank count, problem and size it launches itself as a *worker*
(``mpirun --allow-run-as-root --oversubscribe -n NP /usr/bin/python3 benchmarks/run.py --worker ...``,
plain ``/usr/bin/python3`` for one rank), one process per (problem, size), so ``ru_maxrss`` is the peak of
that size alone. The worker uses nc_dolfinx through its public API only (``import nc_dolfinx as nc``) and
measures, on one mesh and in one process:

- the phases of one level of the adaptive loop: mesh, setup (``nc.solve`` minus its SNES time: binding,
  function space, forms, K/L assembly, the solver's creation), nonlinear solve from u = 0 (the SNES time,
  ``Solution.stats.time``), estimator (``nc.estimate``), Dörfler marking (``nc.mark``, θ = 0.5), refinement
  of the marked cells (``nc.refine``) and, for comparison, DOLFINx's own ``dolfinx.mesh.refine`` of the same
  marked cells, as ``nc.refine`` calls it (children kept on their parent's rank, DOLFINx 0.5.2's
  ``redistribute=False``: "dolfinx") and by default ("dflt": on 0.5.2 the child partitioned anew, which on
  several ranks gives the ghost layer that ``nc.refine`` otherwise repairs; see
  ``common.dolfinx_refine_seconds`` for 0.9 and 0.11); output (XDMF of the mesh and u);
- (a) one linear elasticity solve K u = L on the same mesh, written independently in plain DOLFINx
  (``common.LinearFloor``: CG + GAMG + rigid-body modes as in DOLFINx's demo_elasticity.py, rtol 1e-8), and
  the same to the nonlinear solve's accuracy (true residual 1e-10 ‖L‖);
- the nested-iteration level: the adaptive loop's next level (on the refined mesh, the solution
  transferred with ``nc.transfer`` as initial guess), and its own linear solve;
- (b) the plain-dolfinx baseline (2D): ``NonlinearProblem`` + ``NewtonSolver`` on the full UFL residual,
  ``preonly`` + LU (PETSc's default LU type, and MUMPS), u = 0, Jacobian refactorised every iteration;
- the FFCx JIT: time spent in ``dolfinx.jit.ffcx_jit`` and the number of forms actually compiled.

The driver then runs (c) legacy FEniCS 2019 (``benchmarks/legacy_fenics.py``) in its own process on the
same 2D mesh, and checks that all solvers reach the same elastic energy and contact force.

Threads: workers run with OMP_NUM_THREADS = OPENBLAS_NUM_THREADS = 1, so one rank is one core.
"""
import argparse
import csv
import json
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from common import (LinearFloor, barrier_time, build_refinement_connectivity, current_rss_mb,  # noqa: E402
                    dofs, dolfinx_refine_seconds, format_table, launch, legacy_available, machine_load,
                    max_rss_mb, pc_available, pc_setup_seconds, rank_max, timed_solve)

DEFAULT_SIZES = ["1e4", "1.3e5", "5e5", "2e6"]
DEFAULT_PARALLEL_SIZES = ["1e4", "1.3e5", "5e5"]  # keeps the default run near 10 minutes on 2 cores
DEFAULT_SIZES_3D = ["1e5", "5e5", "2e6"]
DEFAULT_PARALLEL_SIZES_3D = ["1e5", "5e5"]
PROBLEMS = ("block", "corner", "box")
DIMENSION = {"block": 2, "corner": 2, "box": 3}

# The `box` case (issue 10): the block [0,2]x[0,1]x[0,1] clamped at x = 0, its weight and a traction
# growing along x on top, on a foundation c_n = 2e3 (1 + x)(1 + y/2), m_n = 1.5 along its base.
BOX = {"mesh": {"box": [[0.0, 0.0, 0.0], [2.0, 1.0, 1.0]], "cells": [8, 4, 4], "dirichlet": ["left"],
                "neumann": ["top", "right", "front", "back"], "contact": ["bottom"]},
       "material": {"E": 1.0e3, "nu": 0.3},
       "loads": {"f": ["0", "0", "-10"], "g": {"top": ["0", "0", "-20*x"]}},
       "contact": {"c_n": "2.0e3*(1 + x)*(1 + 0.5*y)", "m_n": 1.5}}


# ------------------------------------------------------------------------------------------------
# worker
# ------------------------------------------------------------------------------------------------

class JitMeter:
    """Time spent in dolfinx.jit.ffcx_jit and the number of FFCx compilations (disk-cache misses)."""

    def __init__(self):
        import dolfinx.jit
        import ffcx.codegeneration.jit as ffcx_jit_module
        self.time, self.calls, self.compiled = 0.0, 0, 0
        original, original_compile = dolfinx.jit.ffcx_jit, ffcx_jit_module._compile_objects

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                self.time += time.perf_counter() - start
                self.calls += 1

        def counted(*args, **kwargs):
            self.compiled += 1
            return original_compile(*args, **kwargs)

        dolfinx.jit.ffcx_jit = timed
        ffcx_jit_module._compile_objects = counted

    def snapshot(self):
        return self.time, self.calls, self.compiled

    def since(self, snap):
        return self.time - snap[0], self.calls - snap[1], self.compiled - snap[2]


def block_cells(target_dofs):
    """block is [0,2]x[0,1] with cells [2k, k]: 2 (2k+1)(k+1) dofs."""
    k = max(2, round((-6 + math.sqrt(36 + 16 * (target_dofs - 2))) / 8))
    return [2 * k, k]


def box_cells(target_dofs):
    """box is [0,2]x[0,1]x[0,1] with cells [2k, k, k]: 3 (2k+1)(k+1)² dofs."""
    k = min(range(1, 400), key=lambda k: abs(3 * (2 * k + 1) * (k + 1) ** 2 - target_dofs))
    return [2 * k, k, k]


def build_problem_domain(name, target_dofs, comm, overrides=()):
    """The problem and a mesh with about ``target_dofs`` dofs (corner: uniform refinements of the .msh)."""
    import nc_dolfinx as nc
    if name == "box":
        problem = nc.Problem.from_dict(BOX, "box").replace({"mesh.cells": box_cells(target_dofs),
                                                             **dict(overrides)})
        return problem, nc.build_domain(problem, comm)
    cells = {"mesh.cells": block_cells(target_dofs)} if name == "block" else {}
    problem = nc.load_problem(name, [f"{k}={v}" for k, v in {**cells, **dict(overrides)}.items()])
    domain = nc.build_domain(problem, comm)
    if name == "corner":  # each uniform refinement multiplies the dofs by about 4: the nearest on a log scale
        for _ in range(max(0, round(math.log(target_dofs / dofs(domain), 4)))):
            domain = nc.refine(domain)
    return problem, domain


def solve_options(args):
    """The keyword arguments of nc.solve that --preset/--petsc/--pc-matrix give (none: the shipped defaults)."""
    options = dict(parse_petsc(args.petsc))
    if args.preset:
        options["preset"] = args.preset
    return {"petsc_options": options or None, "preconditioner_matrix": args.pc_matrix}


def measured_solve(problem, domain, comm, jit, kwargs, initial=None):
    """nc.solve, with the set-up/solve split, PC set-up time and JIT: (Solution, dict)."""
    j0, pc0 = jit.snapshot(), pc_setup_seconds()
    solution, setup, solve = timed_solve(problem, domain, comm, initial=initial, **kwargs)
    stats = solution.stats
    out = {"setup": setup, "solve": solve, "pc_setup": rank_max(comm, pc_setup_seconds() - pc0),
           "newton": stats.newton_iterations, "krylov": stats.linear_iterations, "reason": stats.converged_reason,
           "preset": stats.preset, "pc_type": stats.pc_type, "pc_setups": stats.pc_setups,
           "recoveries": stats.recoveries}
    out["jit"], _, out["compiled"] = jit.since(j0)
    return solution, out


def floor_columns(problem, domain, prefix=""):
    """The linear floor on this mesh at its own tolerance and at the nonlinear solve's (true residual)."""
    floor = LinearFloor(problem, domain)
    try:
        t, its, residual = floor.solve()
        t_eq, its_eq, _ = floor.solve(1e-10, "unpreconditioned")
        t_ml, its_ml = floor.solve(amg="ml")[:2] if pc_available("ml") else (None, None)
        t_hypre, its_hypre, _ = floor.solve(amg="hypre")
    finally:
        floor.destroy()
    return {f"t_{prefix}linear": t, f"{prefix}linear_its": its, f"{prefix}linear_true_rel_residual": residual,
            f"t_{prefix}linear_eq": t_eq, f"{prefix}linear_eq_its": its_eq, f"t_{prefix}linear_ml": t_ml,
            f"{prefix}linear_ml_its": its_ml, f"t_{prefix}linear_hypre": t_hypre,
            f"{prefix}linear_hypre_its": its_hypre}


def contact_quantities(solution):
    import nc_dolfinx as nc
    q = nc.solution_quantities(solution.u, solution.fields)
    return {"energy": q["elastic_energy"], "contact_force": q["contact_resultant"]}


def adapt_step(solution, comm, warm):
    """ESTIMATE, MARK, REFINE on the solution's mesh, each timed (slowest rank), and DOLFINx's own
    refinement of the same marked cells. ``warm``: an untimed estimate first (as on a later level, where
    the estimator's forms exist already). Returns (child Domain, dict)."""
    import nc_dolfinx as nc
    if warm:
        nc.estimate(solution.u, solution.fields)
    t = barrier_time(comm)
    est = nc.estimate(solution.u, solution.fields)
    t_estimate = barrier_time(comm) - t
    marked = nc.mark(est, 0.5, "doerfler")
    t_mark = barrier_time(comm) - t - t_estimate
    t = barrier_time(comm)
    build_refinement_connectivity(solution.domain.mesh)
    t_edges = barrier_time(comm) - t
    t = barrier_time(comm)
    child = nc.refine(solution.domain, marked)
    t_refine = barrier_time(comm) - t
    t_dolfinx = dolfinx_refine_seconds(solution.domain, marked)
    t_default = dolfinx_refine_seconds(solution.domain, marked, default=True)
    return child, {"estimate": t_estimate, "mark": t_mark, "edges": t_edges, "refine": t_refine,
                   "refine_dolfinx": t_dolfinx, "refine_dolfinx_default": t_default,
                   "marked": comm.allreduce(len(marked))}


def write_xdmf(u, comm, directory):
    from dolfinx import io
    path = Path(directory) / "solution.xdmf"
    start = time.perf_counter()
    with io.XDMFFile(comm, str(path), "w") as xdmf:
        xdmf.write_mesh(u.function_space.mesh)
        xdmf.write_function(u)
    return time.perf_counter() - start


def plain_dolfinx(problem, domain, solver_type):
    """The baseline a user would write: NonlinearProblem + NewtonSolver, full UFL residual, LU each step."""
    import ufl
    import nc_dolfinx as nc
    from nc_dolfinx import dolfinx_versions as versions
    from petsc4py import PETSc
    from dolfinx import fem
    from dolfinx.nls.petsc import NewtonSolver
    comm = domain.comm
    start = time.perf_counter()
    fields = nc.bind(problem, domain)
    V = versions.p1_space(domain.mesh, (domain.mesh.geometry.dim,))
    u, v = fem.Function(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(domain.mesh)
    un = ufl.dot(u, n) - fields.gap
    ds_c = fields.ds_of("contact")(metadata={"quadrature_degree": nc.QUADRATURE_DEGREES["contact_form"]})
    F = (ufl.inner(fields.sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx
         + fields.c_n * ufl.conditional(ufl.gt(un, 0), un, 0) ** fields.m_n * ufl.dot(v, n) * ds_c
         - ufl.inner(fields.f, v) * ufl.dx)
    for group_id, g in fields.g.items():
        F -= ufl.inner(g, v) * fields.ds(group_id)
    nlp = versions.newton_problem(F, u, fields.boundary_conditions(V))
    newton = NewtonSolver(comm, nlp)
    newton.convergence_criterion = "residual"
    newton.rtol, newton.atol, newton.max_it = 1e-10, 1e-12, 50
    newton.error_on_nonconvergence = False
    ksp = newton.krylov_solver
    prefix = f"base_{solver_type}_"
    ksp.setOptionsPrefix(prefix)
    opts = PETSc.Options(prefix)
    opts["ksp_type"], opts["pc_type"] = "preonly", "lu"
    opts["pc_factor_mat_solver_type"] = solver_type
    ksp.setFromOptions()
    setup = time.perf_counter() - start
    t = time.perf_counter()
    its, converged = newton.solve(u)
    elapsed = time.perf_counter() - t
    used = ksp.getPC().getFactorSolverType()
    q = nc.solution_quantities(u, fields)
    result = {"setup": setup, "solve": elapsed, "newton": its, "converged": bool(converged), "lu_type": used,
              "energy": q["elastic_energy"], "contact_force": q["contact_resultant"]}
    newton.A.destroy()
    newton.b.destroy()
    return result


def export_mesh(domain, path):
    """Vertices and triangles of the (distributed) mesh, gathered into one .npz for legacy FEniCS."""
    import numpy as np
    from nc_dolfinx import dolfinx_versions as versions
    msh = domain.mesh
    comm = msh.comm
    node_map = msh.geometry.index_map()
    n_cells = msh.topology.index_map(2).size_local
    nodes = versions.geometry_nodes(msh)[:n_cells]
    cells = node_map.local_to_global(nodes.ravel()).reshape(-1, 3)
    n_local = node_map.size_local
    x = msh.geometry.x[:n_local, :2]
    offset = node_map.local_range[0]
    gathered = comm.gather((offset, x, cells), root=0)
    if comm.rank == 0:
        total = sum(len(g[1]) for g in gathered)
        points = np.zeros((total, 2))
        for off, xx, _ in gathered:
            points[off:off + len(xx)] = xx
        np.savez(path, points=points, cells=np.concatenate([g[2] for g in gathered]).astype(np.int64))
    comm.barrier()


def worker(args):
    from mpi4py import MPI
    from petsc4py import PETSc
    PETSc.Log.begin()
    import logging
    logging.getLogger().addFilter(lambda record: record.levelno >= logging.WARNING)
    import nc_dolfinx as nc
    from nc_dolfinx import dolfinx_versions as versions
    comm = MPI.COMM_WORLD
    jit = JitMeter()
    rss_start = current_rss_mb()
    kwargs = solve_options(args)
    row = {"problem": args.problem, "np": comm.size, "dim": DIMENSION[args.problem],
           "options": " ".join(args.petsc or []), "load_start": machine_load()}

    t = barrier_time(comm)
    problem, domain = build_problem_domain(args.problem, float(args.size), comm)
    row["t_mesh"] = barrier_time(comm) - t
    row.update(dofs=dofs(domain), cells=domain.num_cells())

    first = measured_solve(problem, domain, comm, jit, kwargs)[1] if args.warmup else None
    solution, s = measured_solve(problem, domain, comm, jit, kwargs)
    row.update({key: s[key] for key in ("newton", "krylov", "reason", "preset", "pc_type", "pc_setups", "recoveries")})
    row.update(t_setup=s["setup"], t_solve=s["solve"], t_pc_setup=s["pc_setup"],
               jit_s=(first or s)["jit"], compiled=(first or s)["compiled"])
    if first:
        row.update(t_setup_first=first["setup"], t_solve_first=first["solve"])
    row["mem_solve_MB"] = max_rss_mb()
    row.update(floor_columns(problem, domain))
    row["ratio_linear"] = row["t_solve"] / row["t_linear"]
    row["ratio_linear_eq"] = row["t_solve"] / row["t_linear_eq"]
    row.update(contact_quantities(solution))

    child, a = adapt_step(solution, comm, args.warmup)
    row.update({f"t_{k}": v for k, v in a.items() if k != "marked"}, marked=a["marked"])
    level_solve = row["t_setup"] + row["t_solve"]  # nc.solve as the adaptive loop calls it
    row["estimate_mark_fraction"] = (row["t_estimate"] + row["t_mark"]) / level_solve
    row["refine_over_dolfinx"] = row["t_refine"] / row["t_refine_dolfinx"]
    row["refine_over_dolfinx_default"] = row["t_refine"] / row["t_refine_dolfinx_default"]
    row["adapt_fraction"] = (row["t_estimate"] + row["t_mark"] + row["t_edges"] + row["t_refine"]) / level_solve
    outdir = comm.bcast(tempfile.mkdtemp(prefix="nc_bench_") if comm.rank == 0 else None, root=0)
    try:
        row["t_output"] = write_xdmf(solution.u, comm, outdir)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(outdir, ignore_errors=True)
    if args.export_mesh:
        export_mesh(domain, args.export_mesh)

    if not args.no_nested:
        j0 = jit.snapshot()
        V = versions.p1_space(child.mesh, (child.mesh.geometry.dim,))
        t = barrier_time(comm)
        initial = nc.transfer(solution.u, V)
        row["t_transfer"] = barrier_time(comm) - t
        if args.warmup:
            measured_solve(problem, child, comm, jit, kwargs, initial)
        nested, s2 = measured_solve(problem, child, comm, jit, kwargs, initial)
        row.update(nested_dofs=dofs(child), t_nested_setup=s2["setup"], t_nested_solve=s2["solve"],
                   nested_newton=s2["newton"], nested_krylov=s2["krylov"], nested_pc_type=s2["pc_type"],
                   nested_pc_setups=s2["pc_setups"])
        row.update(floor_columns(problem, child, "nested_"))
        row["ratio_nested"] = row["t_nested_solve"] / row["t_nested_linear"]
        row["ratio_nested_eq"] = row["t_nested_solve"] / row["t_nested_linear_eq"]
        row["ratio_nested_ml"] = (row["t_nested_solve"] / row["t_nested_linear_ml"]
                                  if row["t_nested_linear_ml"] else None)
        row["ratio_nested_hypre"] = row["t_nested_solve"] / row["t_nested_linear_hypre"]
        _, a2 = adapt_step(nested, comm, False)
        row.update({f"t_nested_{k}": v for k, v in a2.items() if k != "marked"})
        nested_level = row["t_nested_setup"] + row["t_nested_solve"]
        row["t_nested_adapt"] = a2["estimate"] + a2["mark"] + a2["edges"] + a2["refine"]
        row["nested_estimate_mark_fraction"] = (a2["estimate"] + a2["mark"]) / nested_level
        row["nested_adapt_fraction"] = row["t_nested_adapt"] / nested_level
        row["nested_refine_over_dolfinx"] = a2["refine"] / a2["refine_dolfinx"]
        row["nested_refine_over_dolfinx_default"] = a2["refine"] / a2["refine_dolfinx_default"]
        row["nested_jit_s"], _, row["nested_compiled"] = jit.since(j0)
        del nested, initial
    row["jit_total_s"], row["jit_calls"], row["compiled_total"] = jit.snapshot()

    # Peak memory of our pipeline, before the baselines (whose LU factors would dominate it).
    peaks = comm.allgather(max_rss_mb())
    starts = comm.allgather(rss_start)
    row["mem_peak_MB"] = max(peaks)
    row["mem_kB_per_dof"] = 1024 * (sum(peaks) - sum(starts)) / (row.get("nested_dofs") or row["dofs"])
    row["mem_solve_MB"] = max(comm.allgather(row["mem_solve_MB"]))

    if row["dim"] == 2 and row["dofs"] <= float(args.baseline_max_dofs):  # 3D: no factorisation (fill)
        # PETSc's default LU type: its own LU for a serial (seqaij) matrix, MUMPS for mpiaij (checked
        # with a fresh PC). dolfinx's NewtonSolver presets MUMPS, so the default is set explicitly.
        default_lu = "petsc" if comm.size == 1 else "mumps"
        done = {}
        for key, solver_type in (("lu", default_lu), ("mumps", "mumps")):
            if key not in args.baselines:
                continue
            b = done.get(solver_type) or plain_dolfinx(problem, domain, solver_type)
            done[solver_type] = b
            row[f"base_{key}_type"] = b["lu_type"]
            row[f"t_base_{key}"] = b["setup"] + b["solve"]
            row[f"base_{key}_newton"] = b["newton"]
            row[f"base_{key}_converged"] = b["converged"]
            row[f"base_{key}_energy_rdiff"] = abs(b["energy"] - row["energy"]) / abs(row["energy"])
            row[f"base_{key}_force_rdiff"] = abs(b["contact_force"] - row["contact_force"]) / abs(row["contact_force"])
            row[f"speedup_base_{key}"] = row[f"t_base_{key}"] / (row["t_setup"] + row["t_solve"])
    row["load_end"] = machine_load()
    if comm.rank == 0:
        Path(args.json).write_text(json.dumps(row, indent=1, default=str))


def parse_petsc(items):
    """``KEY=VALUE`` items (PETSc options without the prefix), VALUE optional."""
    for item in items or []:
        key, sep, value = item.partition("=")
        yield key.lstrip("-"), (value if sep else None)


# ------------------------------------------------------------------------------------------------
# driver
# ------------------------------------------------------------------------------------------------

def run_legacy(problem, nprocs, row, mesh_npz, tmp, args):
    out = Path(tmp) / f"legacy_{problem}_{nprocs}_{row['dofs']}.json"
    cmd = [HERE / "legacy_fenics.py", "--problem", problem, "--json", out]
    if problem == "block":
        cmd += ["--cells", *block_cells(float(row["size"]))]
    else:
        cmd += ["--mesh-npz", mesh_npz]
    runs = []
    for _ in range(args.repeat):  # the fastest of as many runs as ours
        proc = launch(cmd, nprocs, args.timeout)
        if proc.returncode != 0:
            print(f"  legacy FEniCS failed ({problem}, np={nprocs}):\n{proc.stderr[-2000:]}", file=sys.stderr)
            return {}
        runs.append(json.loads(out.read_text()))
    leg = min(runs, key=lambda r: r["setup"] + r["solve"])
    ours = row["t_setup"] + row["t_solve"]
    return {"t_legacy": leg["setup"] + leg["solve"], "legacy_newton": leg["newton"], "legacy_krylov": leg["krylov"],
            "legacy_energy_rdiff": abs(leg["energy"] - row["energy"]) / abs(row["energy"]),
            "legacy_force_rdiff": abs(leg["contact_force"] - row["contact_force"]) / abs(row["contact_force"]),
            "speedup_legacy": (leg["setup"] + leg["solve"]) / ours}


def worker_command(problem, size, out, args):
    cmd = [Path(__file__).resolve(), "--worker", "--problem", problem, "--size", size, "--json", out,
           "--baseline-max-dofs", args.baseline_max_dofs]
    for flag, value in (("--preset", args.preset), ("--pc-matrix", args.pc_matrix)):
        if value:
            cmd += [flag, value]
    if args.no_nested:
        cmd += ["--no-nested"]
    if not args.warmup:
        cmd += ["--no-warmup"]
    for item in args.petsc or []:
        cmd += ["--petsc", item]
    return cmd


def driver(args):
    rows, failed = [], False
    tmp = tempfile.mkdtemp(prefix="nc_bench_driver_")
    have_legacy = legacy_available() and not args.no_legacy
    if not have_legacy and not args.no_legacy:
        print("legacy FEniCS (python3-dolfin) not importable: its columns stay empty", file=sys.stderr)
    extra_env = {"XDG_CACHE_HOME": tempfile.mkdtemp(prefix="nc_bench_cache_")} if args.cold_jit_cache else None
    try:
        for problem, size, nprocs in cases(args):
            out = Path(tmp) / f"{problem}_{nprocs}_{size}.json"
            mesh_npz = Path(tmp) / f"{problem}_{size}.npz"
            legacy_here = have_legacy and DIMENSION[problem] == 2 and float(size) <= float(args.legacy_max_dofs)
            cmd = worker_command(problem, size, out, args)
            if legacy_here and problem != "block":
                cmd += ["--export-mesh", mesh_npz]
            start = time.perf_counter()
            repeats, error = [], None
            for repeat in range(args.repeat):  # baselines in the first process only
                proc = launch(cmd + ["--baselines", *(args.baselines if repeat == 0 else [])], nprocs,
                              args.timeout, extra_env)
                if proc.returncode != 0:
                    error = (proc.stderr.strip().splitlines() or ["?"])[-1]
                    print(f"worker failed: {problem} np={nprocs} size={size}\n{proc.stderr[-3000:]}",
                          file=sys.stderr)
                    break
                repeats.append(json.loads(out.read_text()))
            if error is not None:
                rows.append({"problem": problem, "np": nprocs, "dofs": size, "error": error})
                failed = True
                continue
            row = fastest(repeats)
            row["size"] = size
            if legacy_here and row["dofs"] <= float(args.legacy_max_dofs):
                row.update(run_legacy(problem, nprocs, row, mesh_npz, tmp, args))
            row["wall_process"] = time.perf_counter() - start
            rows.append(row)
            if not args.quiet:
                print(f"  done {problem} np={nprocs} dofs={row['dofs']} ({row['wall_process']:.0f} s, "
                      f"load {row['load_start']:.2f} -> {row['load_end']:.2f})", file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if extra_env:
            shutil.rmtree(extra_env["XDG_CACHE_HOME"], ignore_errors=True)
    add_scaling(rows)
    print_tables(rows)
    if args.csv:
        write_csv(rows, args.csv)
    if args.json_out:
        Path(args.json_out).write_text(json.dumps(rows, indent=1, default=str))
    if failed:
        sys.exit(1)
    return rows


def cases(args):
    """(problem, size, np) in the order they run: the rank counts of one size back to back, so that
    the speed-up compares runs minutes apart rather than the two ends of the benchmark (this VM's speed
    drifts by tens of per cent over a run)."""
    out = []
    for problem in args.problems:
        three = DIMENSION[problem] == 3
        serial = args.sizes or (DEFAULT_SIZES_3D if three else DEFAULT_SIZES)
        parallel = args.parallel_sizes or args.sizes or (DEFAULT_PARALLEL_SIZES_3D if three else DEFAULT_PARALLEL_SIZES)
        for size in sorted(dict.fromkeys(serial + parallel), key=float):
            for nprocs in args.np:
                if size in (parallel if nprocs > 1 else serial):
                    out.append((problem, size, nprocs))
    return out


def fastest(repeats):
    """The repeat with the smallest setup + solve (a whole row: its ratios come from one process), with
    the baseline columns of the first repeat, which alone ran them (their ratios are from that process)."""
    row = dict(min(repeats, key=lambda r: r["t_setup"] + r["t_solve"]))
    row.update({k: v for k, v in repeats[0].items() if "base_" in k})
    row["repeats"] = len(repeats)
    return row


def add_scaling(rows):
    """Time per dof (our setup + solve) and the speedup of np > 1 over the serial run of the same size."""
    rows = [r for r in rows if "error" not in r]
    serial = {(r["problem"], r["dofs"]): r for r in rows if r["np"] == 1}
    for r in rows:
        r["us_per_dof"] = 1e6 * (r["t_setup"] + r["t_solve"]) / r["dofs"]
        s = serial.get((r["problem"], r["dofs"]))
        if s is not None and r["np"] > 1:
            r["parallel_speedup"] = (s["t_setup"] + s["t_solve"]) / (r["t_setup"] + r["t_solve"])


# Column name -> (header, format) of the printed tables; the CSV has every key.
TABLES = {
    "phases [s]": [("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
                   ("t_mesh", "mesh", "{:.2f}"), ("t_setup", "setup", "{:.2f}"), ("t_solve", "solve", "{:.2f}"),
                   ("newton", "Nwt", "{}"), ("krylov", "Kry", "{}"), ("t_pc_setup", "pcset", "{:.2f}"),
                   ("t_estimate", "estim", "{:.2f}"), ("t_mark", "mark", "{:.3f}"),
                   ("t_refine", "refine", "{:.2f}"), ("t_refine_dolfinx", "dolfinx", "{:.2f}"),
                   ("t_output", "output", "{:.2f}"), ("jit_s", "jit", "{:.2f}"), ("compiled", "cmp", "{}"),
                   ("mem_peak_MB", "MB/rank", "{:.0f}"), ("mem_kB_per_dof", "kB/dof", "{:.2f}"),
                   ("us_per_dof", "us/dof", "{:.2f}"), ("parallel_speedup", "par", "{:.2f}")],
    "ratios to the linear solve": [
        ("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"), ("pc_type", "pc", "{}"),
        ("t_linear", "lin", "{:.2f}"), ("linear_its", "its", "{}"), ("ratio_linear", "cold/lin", "{:.2f}"),
        ("linear_eq_its", "its=", "{}"), ("ratio_linear_eq", "cold/lin=", "{:.2f}"),
        ("nested_dofs", "nest dofs", "{}"), ("nested_pc_type", "pc", "{}"), ("t_nested_solve", "nest", "{:.2f}"),
        ("nested_newton", "Nwt", "{}"), ("nested_krylov", "Kry", "{}"), ("t_nested_linear", "lin", "{:.2f}"),
        ("ratio_nested", "nest/lin", "{:.2f}"), ("ratio_nested_eq", "nest/lin=", "{:.2f}"),
        ("ratio_nested_ml", "(ML)", "{:.2f}"), ("ratio_nested_hypre", "(hypre)", "{:.2f}"),
        ("nested_compiled", "nest cmp", "{}"), ("nested_jit_s", "nest jit", "{:.2f}")],
    "estimate, mark, refine (issue 13: estimate + mark <= 5 % of the solve, refine <= 1.2 x DOLFINx's)": [
        ("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"), ("marked", "marked", "{}"),
        ("t_estimate", "estim", "{:.3f}"), ("t_mark", "mark", "{:.3f}"),
        ("estimate_mark_fraction", "(E+M)/solve", "{:.3f}"), ("t_edges", "edges", "{:.3f}"),
        ("t_refine", "refine", "{:.3f}"),
        ("t_refine_dolfinx", "dolfinx", "{:.3f}"), ("refine_over_dolfinx", "ratio", "{:.2f}"),
        ("t_refine_dolfinx_default", "dflt", "{:.3f}"), ("refine_over_dolfinx_default", "ratio", "{:.2f}"),
        ("nested_dofs", "nest dofs", "{}"), ("nested_estimate_mark_fraction", "(E+M)/solve", "{:.3f}"),
        ("t_nested_edges", "edges", "{:.3f}"),
        ("t_nested_refine", "refine", "{:.3f}"), ("t_nested_refine_dolfinx", "dolfinx", "{:.3f}"),
        ("nested_refine_over_dolfinx", "ratio", "{:.2f}"),
        ("t_nested_refine_dolfinx_default", "dflt", "{:.3f}"),
        ("nested_refine_over_dolfinx_default", "ratio", "{:.2f}"), ("adapt_fraction", "EMR/solve", "{:.2f}")],
    "baselines (total time to the solution on the mesh: setup + solve)": [
        ("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
        ("t_base_lu", "LU", "{:.2f}"), ("base_lu_type", "type", "{}"), ("base_lu_newton", "Nwt", "{}"),
        ("speedup_base_lu", "x", "{:.1f}"), ("base_lu_energy_rdiff", "dE", "{:.1e}"),
        ("t_base_mumps", "MUMPS", "{:.2f}"), ("base_mumps_newton", "Nwt", "{}"),
        ("speedup_base_mumps", "x", "{:.1f}"), ("base_mumps_energy_rdiff", "dE", "{:.1e}"),
        ("t_legacy", "legacy", "{:.2f}"), ("legacy_newton", "Nwt", "{}"), ("legacy_krylov", "Kry", "{}"),
        ("speedup_legacy", "x", "{:.1f}"), ("legacy_energy_rdiff", "dE", "{:.1e}"),
        ("legacy_force_rdiff", "dF", "{:.1e}")],
}
COLUMNS = sorted({key for table in TABLES.values() for key, _, _ in table})


def print_tables(rows):
    for title, columns in TABLES.items():
        print(f"\n{title}\n" + format_table(rows, columns))
    for r in rows:
        if "error" in r:
            print(f"FAILED: {r['problem']} np={r['np']} size={r['dofs']}: {r['error']}")


def write_csv(rows, path):
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--np", type=int, nargs="+", default=[1, 2], help="rank counts (default: 1 2)")
    p.add_argument("--sizes", nargs="+", default=None,
                   help=f"target dofs (default: 2D {' '.join(DEFAULT_SIZES)}, 3D {' '.join(DEFAULT_SIZES_3D)})")
    p.add_argument("--parallel-sizes", nargs="+",
                   help=f"sizes for np > 1 (default: 2D {' '.join(DEFAULT_PARALLEL_SIZES)}, "
                        f"3D {' '.join(DEFAULT_PARALLEL_SIZES_3D)}, or --sizes if given)")
    p.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=PROBLEMS)
    p.add_argument("--csv", help="write every measured column to this CSV file")
    p.add_argument("--json-out", help="write the rows as JSON")
    p.add_argument("--smoke", action="store_true", help="tiny sizes, seconds: for the tests")
    p.add_argument("--preset", choices=("auto", "direct", "iterative"),
                   help="solver preset (default: the problem's, i.e. the shipped 'auto')")
    p.add_argument("--pc-matrix", choices=("auto", "bulk", "jacobian"),
                   help="nc.solve's preconditioner_matrix (default: the problem's)")
    p.add_argument("--petsc", action="append", metavar="KEY[=VALUE]",
                   help="a PETSc option for nc.solve(petsc_options=...), without the nc_ prefix")
    p.add_argument("--baseline-max-dofs", default="2e5", help="plain-dolfinx baselines up to this size (2D)")
    p.add_argument("--baselines", nargs="*", default=["lu", "mumps"], choices=("lu", "mumps"))
    p.add_argument("--legacy-max-dofs", default="2e5", help="legacy FEniCS up to this size (2D)")
    p.add_argument("--no-legacy", action="store_true")
    p.add_argument("--no-nested", action="store_true", help="skip the nested-iteration level")
    p.add_argument("--repeat", type=int, default=1,
                   help="run every case this many times and keep the fastest (setup + solve)")
    p.add_argument("--no-warmup", dest="warmup", action="store_false",
                   help="time the first solve in each process (default: an identical untimed solve first)")
    p.add_argument("--cold-jit-cache", action="store_true",
                   help="workers use an empty FFCx cache (XDG_CACHE_HOME): shows compilation once per run")
    p.add_argument("--timeout", type=float, default=3600, help="seconds per worker process")
    p.add_argument("--quiet", action="store_true")
    # worker mode
    p.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    p.add_argument("--problem", help=argparse.SUPPRESS)
    p.add_argument("--size", help=argparse.SUPPRESS)
    p.add_argument("--json", help=argparse.SUPPRESS)
    p.add_argument("--export-mesh", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.worker:
        try:
            return worker(args)
        except BaseException:
            # An exception on one rank would leave the others waiting in a collective: abort them all.
            import traceback
            from mpi4py import MPI
            traceback.print_exc()
            sys.stderr.flush()
            if MPI.COMM_WORLD.size > 1:
                MPI.COMM_WORLD.Abort(1)
            raise
    if args.smoke:
        args.sizes = args.sizes or ["2e3"]
    return driver(args)


if __name__ == "__main__":
    main()
