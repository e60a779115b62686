#!/usr/bin/env python3
"""Performance harness for nc_dolfinx (issue 5): phases, iterations, memory and baselines per mesh size.

One command (1 and 2 ranks, the default sizes, tables on stdout, every column in the CSV; see
benchmarks/README.md for the columns)::

    /usr/bin/python3 benchmarks/run.py --csv benchmarks/results.csv

The script is a *driver*: for every rank count, problem and size it launches itself as a *worker*
(``mpirun --allow-run-as-root --oversubscribe -n NP /usr/bin/python3 benchmarks/run.py --worker ...``,
plain ``/usr/bin/python3`` for one rank), one process per (problem, size), so ``ru_maxrss`` is the peak of
that size alone. The worker measures, on one mesh and in one process:

- the phases of one level of the adaptive loop: mesh, setup (bind, function space, forms, K/L assembly,
  SNES), nonlinear solve from u = 0, estimator, Dörfler marking (θ = 0.5), refinement of the marked cells,
  output (XDMF of the mesh and u);
- (a) one linear elasticity solve K u = L with the same KSP/PC options and the same matrices
  (near-nullspace included) as the nonlinear solver;
- the nested-iteration level: the adaptive loop's next level (on the refined mesh, the solution
  transferred as initial guess), and its own linear solve;
- (b) the plain-dolfinx baseline: ``NonlinearProblem`` + ``NewtonSolver`` on the full UFL residual,
  ``preonly`` + LU (PETSc's default LU type, and MUMPS), u = 0, Jacobian refactorised every iteration;
- the FFCx JIT: time spent in ``dolfinx.jit.ffcx_jit`` and the number of forms actually compiled.

The driver then runs (c) legacy FEniCS 2019 (``benchmarks/legacy_fenics.py``) in its own process on the
same mesh, and checks that all solvers reach the same elastic energy and contact force.

Threads: workers run with OMP_NUM_THREADS = OPENBLAS_NUM_THREADS = 1, so one rank is one core.
"""
import argparse
import csv
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PYTHON = "/usr/bin/python3"
HERE = Path(__file__).resolve().parent

DEFAULT_SIZES = ["1e4", "1.3e5", "5e5", "2e6"]
DEFAULT_PARALLEL_SIZES = ["1e4", "1.3e5", "5e5"]  # keeps the default run near 10 minutes on 2 cores
EW3 = ["snes_ksp_ew=true", "snes_ksp_ew_version=3", "snes_linesearch_type=basic"]
# Named solver settings (--settings): PETSc options for solver_options(cli_options=...) and the
# preconditioner matrix. "shipped" measures the preset exactly as nc_dolfinx ships it.
SETTINGS = {
    "shipped": ([], None, False),
    # Eisenstat-Walker v3 (its oversolving safeguard stops the last Newton system at the SNES target),
    # no line search (bt rejects inexact steps: DIVERGED_LINE_SEARCH), PC from K once per mesh, and the
    # absolute tolerance snes_atol = snes_rtol * ||L||: a nested level then stops at the accuracy of a cold
    # start instead of 1e-10 * ||F(u_0)||, which lies below the round-off floor of ||F|| at 2e6 dofs
    # (DIVERGED_MAX_IT with ||F|| stagnating at ~3e-11).
    "ew3-bulk": (EW3, "bulk", True),
    # the same with the PC built once from the first Jacobian J(u_0): K on a cold start, the Jacobian
    # at the transferred solution on a nested level
    "ew3-jac-once": (EW3 + ["snes_lag_preconditioner=100"], "jacobian", True),
}
DEFAULT_SETTINGS = "shipped"
PROBLEMS = ("block", "corner")


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


def pc_setup_time():
    from petsc4py import PETSc
    return PETSc.Log.Event("PCSetUp").getPerfInfo()["time"]


def max_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def current_rss_mb():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def block_overrides(target_dofs):
    """block is [0,2]x[0,1] with cells [2k, k]: 2 (2k+1)(k+1) dofs."""
    k = max(2, round((-6 + math.sqrt(36 + 16 * (target_dofs - 2))) / 8))
    return [f"mesh.cells=[{2 * k},{k}]"]


def build_problem_domain(name, target_dofs, comm, extra_overrides=()):
    """The problem and a mesh with about ``target_dofs`` dofs (corner: uniform refinements of the .msh)."""
    from nc_dolfinx import cases, refinement
    from nc_dolfinx.problem import build_domain, load_problem
    overrides = list(extra_overrides)
    if name == "block":
        overrides = block_overrides(target_dofs) + overrides
    problem = load_problem(cases.resolve(name), overrides)
    domain = build_domain(problem, comm)
    if name != "block":
        # each uniform refinement multiplies the dofs by about 4: refine to the nearest on a log scale
        refinements = max(0, round(math.log(target_dofs / (2 * domain.num_vertices()), 4)))
        for _ in range(refinements):
            domain = refinement.refine(domain)
    return problem, domain


def linear_solve(K, load, options, prefix, nullspace=None, extra=None):
    """One solve K u = L with the KSP/PC options of ``options`` (the snes_* ones dropped) and the
    near-nullspace of the nonlinear solver's preconditioning matrix."""
    from petsc4py import PETSc
    from nc_dolfinx.solver import set_petsc_options
    if nullspace is not None and nullspace.handle != 0:
        K.setNearNullSpace(nullspace)
    set_petsc_options({**{k: v for k, v in options.items() if not k.startswith("snes_")}, **(extra or {})},
                      prefix)
    ksp = PETSc.KSP().create(K.getComm())
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(K)
    ksp.setFromOptions()
    x = K.createVecRight()
    pc0 = pc_setup_time()
    start = time.perf_counter()
    ksp.solve(load, x)
    elapsed = time.perf_counter() - start
    its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
    pc_time = pc_setup_time() - pc0
    r = load.duplicate()
    K.mult(x, r)
    r.aypx(-1.0, load)
    true_rel_residual = r.norm() / load.norm()  # what the nonlinear solve's snes_rtol is measured in
    for obj in (ksp, x, r):
        obj.destroy()
    if reason <= 0:
        raise RuntimeError(f"linear solve diverged (reason {reason})")
    return elapsed, its, pc_time, true_rel_residual


def our_solve(problem, domain, options, pc_matrix, initial=None, nullspace_on_K=False, jit=None,
              atol_from_load=False):
    """Set up and run NonlinearSolver as adaptive.solve_level does, timing setup and solve separately.

    Returns (fields, u, solver, stats dict); the caller destroys the solver."""
    from dolfinx import fem
    from nc_dolfinx import forms, refinement
    from nc_dolfinx.adaptive import dirichlet_bcs
    from nc_dolfinx.problem import bind
    from nc_dolfinx.solver import NonlinearSolver, rigid_body_modes
    out = {}
    j0 = jit.snapshot()
    start = time.perf_counter()
    fields = bind(problem, domain)
    V = fem.VectorFunctionSpace(domain.mesh, ("CG", 1))
    t = time.perf_counter()
    u = refinement.transfer(initial, V) if initial is not None else fem.Function(V)
    out["transfer"] = time.perf_counter() - t if initial is not None else 0.0
    u.name = "displacement"
    solver = NonlinearSolver(forms.normal_compliance_forms(u, fields), u, dirichlet_bcs(V, fields), options,
                             pc_matrix, forms.energy(u, fields))
    pmat = solver.snes.getJacobian()[1]  # the matrix the PC is built from (GAMG reads its near-nullspace)
    if nullspace_on_K and pmat.getNearNullSpace().handle == 0:  # exploration: give it the rigid-body modes
        pmat.setNearNullSpace(rigid_body_modes(V))
    if atol_from_load:  # ||F|| <= snes_rtol * ||L|| is enough, whatever the initial guess
        rtol, atol, stol, max_it = solver.snes.getTolerances()
        solver.snes.setTolerances(atol=max(atol, rtol * solver.load.norm()))
    out["snes_atol"] = solver.snes.getTolerances()[1]
    out["nullspace"] = pmat.getNearNullSpace()
    out["pc_has_nullspace"] = out["nullspace"].handle != 0
    out["setup"] = time.perf_counter() - start
    out["jit_setup"], _, out["compiled_setup"] = jit.since(j0)
    pc0 = pc_setup_time()
    stats = solver.solve()
    out["solve"] = stats.time
    out["pc_setup"] = pc_setup_time() - pc0
    out["newton"], out["krylov"] = stats.newton_iterations, stats.linear_iterations
    out["reason"] = stats.converged_reason
    out["pc_mode"] = getattr(stats, "preconditioner_matrix", "") or pc_matrix
    return fields, u, solver, out


def warm_up(solve_here, domain, initial, enabled):
    """One untimed set-up and solve on ``domain`` before the timed one (None when not ``enabled``).

    The timed solve then excludes what only the first solve in a process pays: JIT cache look-ups,
    PETSc/MPI first use, and first-touch of fresh memory. The last is large on this VM: its balloon
    driver hands freed pages back to the host within ~3 s, and touching them again costs 1.1-1.6 s/GB
    instead of 0.07-0.16 s/GB (see benchmarks/README.md)."""
    if not enabled:
        return None
    _, _, solver, stats = solve_here(domain, initial)
    solver.destroy()
    return stats


def quantities(u, fields):
    import ufl
    from nc_dolfinx import forms
    from nc_dolfinx.quantities import integrate
    comm = fields.domain.comm
    p = forms.contact_pressure(u, fields)
    return {"energy": integrate(forms.elastic_energy(u, fields), comm),
            "contact_force": integrate(p * forms.contact_measure(fields), comm),
            "u_norm": math.sqrt(integrate(ufl.inner(u, u) * ufl.dx, comm))}


def plain_dolfinx(problem, domain, solver_type):
    """The baseline a user would write: NonlinearProblem + NewtonSolver, full UFL residual, LU each step."""
    import ufl
    from petsc4py import PETSc
    from dolfinx import fem
    from dolfinx.fem.petsc import NonlinearProblem
    from dolfinx.nls.petsc import NewtonSolver
    from nc_dolfinx.adaptive import dirichlet_bcs
    from nc_dolfinx.problem import bind, sigma
    comm = domain.comm
    start = time.perf_counter()
    fields = bind(problem, domain)
    V = fem.VectorFunctionSpace(domain.mesh, ("CG", 1))
    u, v = fem.Function(V), ufl.TestFunction(V)
    n = ufl.FacetNormal(domain.mesh)
    un = ufl.dot(u, n) - fields.gap
    ds_c = fields.ds_of("contact")(metadata={"quadrature_degree": 8})
    F = (ufl.inner(sigma(u, fields.lmbda, fields.mu), ufl.sym(ufl.grad(v))) * ufl.dx
         + fields.c_n * ufl.conditional(ufl.gt(un, 0), un, 0) ** fields.m_n * ufl.dot(v, n) * ds_c
         - ufl.inner(fields.f, v) * ufl.dx)
    for group_id, g in fields.g.items():
        F -= ufl.inner(g, v) * fields.ds(group_id)
    nlp = NonlinearProblem(F, u, bcs=dirichlet_bcs(V, fields))
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
    result = {"setup": setup, "solve": elapsed, "newton": its, "converged": bool(converged), "lu_type": used,
              **quantities(u, fields)}
    newton.A.destroy()
    newton.b.destroy()
    return result


def write_xdmf(u, comm, directory):
    from dolfinx import io
    path = Path(directory) / "solution.xdmf"
    start = time.perf_counter()
    with io.XDMFFile(comm, str(path), "w") as xdmf:
        xdmf.write_mesh(u.function_space.mesh)
        xdmf.write_function(u)
    return time.perf_counter() - start


def export_mesh(domain, path):
    """Vertices and triangles of the (distributed) mesh, gathered into one .npz for legacy FEniCS."""
    import numpy as np
    msh = domain.mesh
    comm = msh.comm
    node_map = msh.geometry.index_map()
    n_cells = msh.topology.index_map(2).size_local
    nodes = msh.geometry.dofmap.array.reshape(-1, 3)[:n_cells]
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
    sys.path.insert(0, str(ROOT))
    from nc_dolfinx import estimator, marking, refinement
    from nc_dolfinx.solver import solver_options
    comm = MPI.COMM_WORLD
    jit = JitMeter()
    rss_start = current_rss_mb()
    settings_options, settings_pc, atol_from_load = SETTINGS[args.settings]
    cli_options = dict(parse_petsc(settings_options + (args.petsc or [])))
    row = {"problem": args.problem, "np": comm.size}

    t = time.perf_counter()
    problem, domain = build_problem_domain(args.problem, float(args.size), comm)
    row["t_mesh"] = time.perf_counter() - t
    if args.preset:
        problem.preset = args.preset
    pc_matrix = args.pc_matrix or settings_pc or problem.preconditioner_matrix
    options = solver_options(problem.preset, problem.petsc_options, cli_options)
    row.update(settings=args.settings, preset=problem.preset,
               options=" ".join(f"{k}={v}" for k, v in cli_options.items()),
               dofs=2 * domain.num_vertices(), cells=domain.num_cells())

    def solve_here(mesh_domain, initial):
        return our_solve(problem, mesh_domain, options, pc_matrix, initial, args.nullspace_on_K, jit,
                         atol_from_load)
    first = warm_up(solve_here, domain, None, args.warmup)
    fields, u, solver, s = solve_here(domain, None)
    row.update(t_setup=s["setup"], t_solve=s["solve"], t_pc_setup=s["pc_setup"], newton=s["newton"],
               krylov=s["krylov"], jit_s=(first or s)["jit_setup"], compiled=(first or s)["compiled_setup"],
               pc_mode=s["pc_mode"], pc_has_nullspace=s["pc_has_nullspace"])
    if first:
        row.update(t_setup_first=first["setup"], t_solve_first=first["solve"])
    row["t_linear"], row["linear_its"], row["t_linear_pc_setup"], row["linear_true_rel_residual"] = \
        linear_solve(solver.K, solver.load, solver.options, "lin_", s["nullspace"])
    # the same solve to the nonlinear solve's accuracy: true residual ||L - K u|| <= snes_rtol ||L||
    equal = {"ksp_norm_type": "unpreconditioned", "ksp_rtol": solver.options.get("snes_rtol", 1e-10)}
    row["t_linear_eq"], row["linear_eq_its"], _, _ = linear_solve(solver.K, solver.load, solver.options, "lineq_",
                                                                  s["nullspace"], equal)
    row["snes_atol"] = s["snes_atol"]
    solver.destroy()
    row["ratio_linear"] = row["t_solve"] / row["t_linear"]
    row["ratio_linear_eq"] = row["t_solve"] / row["t_linear_eq"]
    row["mem_solve_MB"] = max_rss_mb()
    row.update(quantities(u, fields))

    if args.warmup:  # as on a later level of the loop: the estimator's forms were created once before
        estimator.estimate(u, fields)
    t = time.perf_counter()
    est = estimator.estimate(u, fields)
    row["t_estimate"] = time.perf_counter() - t
    t = time.perf_counter()
    marked = marking.mark(est.squares, comm, 0.5, "doerfler")
    row["t_mark"] = time.perf_counter() - t
    t = time.perf_counter()
    child = refinement.refine(domain, marked)
    row["t_refine"] = time.perf_counter() - t
    row["adapt_fraction"] = (row["t_estimate"] + row["t_mark"] + row["t_refine"]) / (row["t_setup"] + row["t_solve"])
    outdir = comm.bcast(tempfile.mkdtemp(prefix="nc_bench_") if comm.rank == 0 else None, root=0)
    try:
        row["t_output"] = write_xdmf(u, comm, outdir)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(outdir, ignore_errors=True)
    if args.export_mesh:
        export_mesh(domain, args.export_mesh)

    if not args.no_nested:
        j0 = jit.snapshot()
        warm_up(solve_here, child, u, args.warmup)
        fields2, u2, solver2, s2 = solve_here(child, u)
        row.update(nested_dofs=2 * child.num_vertices(), t_nested_setup=s2["setup"], t_transfer=s2["transfer"],
                   t_nested_solve=s2["solve"], nested_newton=s2["newton"], nested_krylov=s2["krylov"],
                   nested_pc_mode=s2["pc_mode"])
        row["t_nested_linear"], row["nested_linear_its"], _, _ = linear_solve(
            solver2.K, solver2.load, solver2.options, "lin_", s2["nullspace"])
        row["t_nested_linear_eq"], row["nested_linear_eq_its"], _, _ = linear_solve(
            solver2.K, solver2.load, solver2.options, "lineq_", s2["nullspace"], equal)
        solver2.destroy()
        row["ratio_nested"] = row["t_nested_solve"] / row["t_nested_linear"]
        row["ratio_nested_eq"] = row["t_nested_solve"] / row["t_nested_linear_eq"]
        t = time.perf_counter()
        est2 = estimator.estimate(u2, fields2)
        marked2 = marking.mark(est2.squares, comm, 0.5, "doerfler")
        refinement.refine(child, marked2)
        row["t_nested_adapt"] = time.perf_counter() - t
        row["nested_adapt_fraction"] = row["t_nested_adapt"] / (row["t_nested_setup"] + row["t_nested_solve"])
        row["nested_jit_s"], _, row["nested_compiled"] = jit.since(j0)
        del fields2, u2, solver2, est2
    row["jit_total_s"], row["jit_calls"], row["compiled_total"] = jit.snapshot()

    # Peak memory of our pipeline, before the baselines (whose LU factors would dominate it).
    peaks = comm.allgather(max_rss_mb())
    starts = comm.allgather(rss_start)
    row["mem_peak_MB"] = max(peaks)
    row["mem_kB_per_dof"] = 1024 * (sum(peaks) - sum(starts)) / (row.get("nested_dofs") or row["dofs"])
    row["mem_solve_MB"] = max(comm.allgather(row["mem_solve_MB"]))

    if row["dofs"] <= float(args.baseline_max_dofs):
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

def launch(cmd, nprocs, timeout, extra_env=None):
    prefix = [] if nprocs == 1 else ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(nprocs)]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               **(extra_env or {}))
    return subprocess.run(prefix + [PYTHON, *map(str, cmd)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


def run_legacy(problem, nprocs, row, mesh_npz, tmp, args):
    out = Path(tmp) / f"legacy_{problem}_{nprocs}_{row['dofs']}.json"
    cmd = [HERE / "legacy_fenics.py", "--problem", problem, "--json", out]
    if problem == "block":
        cmd += ["--cells", *row["block_cells"]]
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


def legacy_available():
    proc = subprocess.run([PYTHON, "-c", "import dolfin"], capture_output=True)
    return proc.returncode == 0


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
            legacy_here = have_legacy and float(size) <= float(args.legacy_max_dofs)
            cmd = [Path(__file__).resolve(), "--worker", "--problem", problem, "--size", size,
                   "--json", out, "--baseline-max-dofs", args.baseline_max_dofs]
            cmd += ["--settings", args.settings]
            if args.preset:
                cmd += ["--preset", args.preset]
            if args.pc_matrix:
                cmd += ["--pc-matrix", args.pc_matrix]
            if args.nullspace_on_K:
                cmd += ["--nullspace-on-K"]
            if args.no_nested:
                cmd += ["--no-nested"]
            if not args.warmup:
                cmd += ["--no-warmup"]
            if legacy_here and problem != "block":
                cmd += ["--export-mesh", mesh_npz]
            for item in args.petsc or []:
                cmd += ["--petsc", item]
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
            if problem == "block":
                row["block_cells"] = block_overrides(float(size))[0].split("=")[1].strip("[]").split(",")
            if legacy_here and row["dofs"] <= float(args.legacy_max_dofs):
                row.update(run_legacy(problem, nprocs, row, mesh_npz, tmp, args))
            row.pop("block_cells", None)
            row["wall_process"] = time.perf_counter() - start
            rows.append(row)
            if not args.quiet:
                print(f"  done {problem} np={nprocs} dofs={row['dofs']} "
                      f"({row['wall_process']:.0f} s)", file=sys.stderr, flush=True)
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
        sizes = list(dict.fromkeys(args.sizes + (args.parallel_sizes or [])))
        for size in sorted(sizes, key=float):
            for nprocs in args.np:
                if size in (args.parallel_sizes or args.sizes if nprocs > 1 else args.sizes):
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
                   ("t_refine", "refine", "{:.2f}"), ("t_output", "output", "{:.2f}"),
                   ("jit_s", "jit", "{:.2f}"), ("compiled", "cmp", "{}"),
                   ("mem_peak_MB", "MB/rank", "{:.0f}"), ("mem_kB_per_dof", "kB/dof", "{:.2f}"),
                   ("us_per_dof", "us/dof", "{:.2f}"), ("parallel_speedup", "par", "{:.2f}")],
    "ratios to the linear solve": [
        ("problem", "problem", "{}"), ("np", "np", "{}"), ("dofs", "dofs", "{}"),
        ("t_linear", "lin", "{:.2f}"), ("linear_its", "its", "{}"), ("ratio_linear", "cold/lin", "{:.2f}"),
        ("linear_eq_its", "its=", "{}"), ("ratio_linear_eq", "cold/lin=", "{:.2f}"),
        ("nested_dofs", "nest dofs", "{}"), ("t_nested_solve", "nest", "{:.2f}"),
        ("nested_newton", "Nwt", "{}"), ("nested_krylov", "Kry", "{}"), ("t_nested_linear", "lin", "{:.2f}"),
        ("ratio_nested", "nest/lin", "{:.2f}"), ("ratio_nested_eq", "nest/lin=", "{:.2f}"),
        ("adapt_fraction", "EMR/solve", "{:.2f}"),
        ("nested_adapt_fraction", "nest EMR/solve", "{:.2f}"), ("nested_compiled", "nest cmp", "{}"),
        ("nested_jit_s", "nest jit", "{:.2f}")],
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


def format_table(rows, columns):
    header = [h for _, h, _ in columns]
    body = [[(fmt.format(r[k]) if r.get(k) is not None else "-") for k, _, fmt in columns] for r in rows]
    widths = [max(len(x) for x in col) for col in zip(header, *body)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(header, widths)),
             "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.rjust(w) for c, w in zip(line, widths)) for line in body]
    return "\n".join(lines)


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
    p.add_argument("--sizes", nargs="+", default=None, help=f"target dofs (default: {' '.join(DEFAULT_SIZES)})")
    p.add_argument("--parallel-sizes", nargs="+",
                   help=f"sizes for np > 1 (default: {' '.join(DEFAULT_PARALLEL_SIZES)}, or --sizes if given)")
    p.add_argument("--problems", nargs="+", default=list(PROBLEMS), choices=PROBLEMS)
    p.add_argument("--csv", help="write every measured column to this CSV file")
    p.add_argument("--json-out", help="write the rows as JSON")
    p.add_argument("--smoke", action="store_true", help="tiny sizes, seconds: for the tests")
    p.add_argument("--preset", choices=("direct", "iterative"), default="iterative",
                   help="solver preset (default: iterative, the scalable one)")
    p.add_argument("--settings", choices=list(SETTINGS), default=DEFAULT_SETTINGS,
                   help=f"named solver settings, extended by --petsc/--pc-matrix (default: {DEFAULT_SETTINGS})")
    p.add_argument("--pc-matrix", help="NonlinearSolver preconditioner_matrix (default: the problem's)")
    p.add_argument("--petsc", action="append", metavar="KEY[=VALUE]",
                   help="PETSc option for solver_options(cli_options=...), without the nc_ prefix")
    p.add_argument("--nullspace-on-K", action="store_true",
                   help="exploration: attach the rigid-body near-nullspace to the PC matrix if it has none")
    p.add_argument("--baseline-max-dofs", default="2e5", help="plain-dolfinx baselines up to this size")
    p.add_argument("--baselines", nargs="*", default=["lu", "mumps"], choices=("lu", "mumps"))
    p.add_argument("--legacy-max-dofs", default="2e5", help="legacy FEniCS up to this size")
    p.add_argument("--no-legacy", action="store_true")
    p.add_argument("--no-nested", action="store_true", help="skip the nested-iteration level")
    p.add_argument("--repeat", type=int, default=1,
                   help="run every case this many times and keep the fastest (setup + solve)")
    p.add_argument("--no-warmup", dest="warmup", action="store_false",
                   help="time the first solve in each process (default: an identical untimed solve first)")
    p.add_argument("--cold-jit-cache", action="store_true",
                   help="workers use an empty FFCx cache (XDG_CACHE_HOME): shows compilation once per run")
    p.add_argument("--timeout", type=float, default=1800, help="seconds per worker process")
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
    if not args.sizes:
        args.sizes, args.parallel_sizes = DEFAULT_SIZES, args.parallel_sizes or DEFAULT_PARALLEL_SIZES
    return driver(args)


if __name__ == "__main__":
    main()
