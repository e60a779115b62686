"""What the benchmark scripts share: process launching, clocks, the linear floor, uniform refinement, tables.

The **linear floor** is written here independently of nc_dolfinx's solver, in plain DOLFINx/petsc4py, as
DOLFINx's ``demo_elasticity.py`` (v0.5) solves linear elasticity: K assembled from a(u, v) = (σ(u), ε(v)),
the rigid-body modes as GAMG's near-nullspace, the SPD flag, CG + GAMG with Chebyshev/Jacobi smoothers and
CG eigenvalue estimates (20 steps); the tolerance ``rtol`` 1e-8 in CG's default (preconditioned) norm.
Only the problem's data come from nc_dolfinx (``nc.bind``: the material, loads and Dirichlet conditions),
so the floor solves the same elasticity problem the nonlinear solver solves without the foundation.
"""
import math
import os
import subprocess
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PYTHON = "/usr/bin/python3"
FLOOR_RTOL = 1e-8

# DOLFINx's demo_elasticity.py (v0.5) options, with the tolerance of the floor; the same with Trilinos ML
# ("ml"), or hypre's BoomerAMG as the solver sets it up in 2D and 3D ("hypre", spelled out: the benchmarks use
# the public API only; tests/test_benchmark_smoke.py checks that they are the solver's), for context.
FLOOR_OPTIONS = {"ksp_type": "cg", "pc_type": "gamg", "mg_levels_ksp_type": "chebyshev",
                 "mg_levels_pc_type": "jacobi", "mg_levels_esteig_ksp_type": "cg",
                 "mg_levels_ksp_chebyshev_esteig_steps": 20}
_BOOMERAMG = {"ksp_type": "cg", "pc_type": "hypre", "pc_hypre_type": "boomeramg",
              "pc_hypre_boomeramg_coarsen_type": "HMIS", "pc_hypre_boomeramg_interp_type": "ext+i",
              "pc_hypre_boomeramg_P_max": 4}
FLOOR_HYPRE = {2: {**_BOOMERAMG, "pc_hypre_boomeramg_agg_nl": 1, "pc_hypre_boomeramg_agg_num_paths": 2,
                   "pc_hypre_boomeramg_strong_threshold": 0.25},
               3: {**_BOOMERAMG, "pc_hypre_boomeramg_agg_nl": 2, "pc_hypre_boomeramg_strong_threshold": 0.5,
                   "pc_hypre_boomeramg_relax_type_all": "Chebyshev"}}


def git(*args):
    """A git command's output in the repository, "" where there is no git (the CI's root file systems)."""
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=30).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def commit():
    """The commit measured, for a table's header ("unknown" without git)."""
    head = git("rev-parse", "--short", "HEAD") or "unknown"
    return head + (" + uncommitted changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def floor_amg_options(amg, dim):
    """The floor's options for ``amg`` (gamg, ml or hypre) on a mesh of dimension ``dim``."""
    return {"gamg": FLOOR_OPTIONS, "ml": {**FLOOR_OPTIONS, "pc_type": "ml"}, "hypre": FLOOR_HYPRE[dim]}[amg]


def pc_available(pc_type):
    """Whether this PETSc has the preconditioner ``pc_type``. Trilinos ML ("ml") is in Debian bookworm's
    PETSc 3.18, not in trixie's 3.22 nor sid's 3.25: there the ML columns stay empty."""
    from petsc4py import PETSc
    pc = PETSc.PC().create(PETSc.COMM_SELF)
    try:
        pc.setType(pc_type)
        return True
    except PETSc.Error:
        return False
    finally:
        pc.destroy()


# --- processes ------------------------------------------------------------------------------------

def launch(cmd, nprocs, timeout, extra_env=None):
    """Run ``cmd`` (a script and its arguments) with /usr/bin/python3 on ``nprocs`` ranks, one thread each."""
    prefix = [] if nprocs == 1 else ["mpirun", "--allow-run-as-root", "--oversubscribe", "-n", str(nprocs)]
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1",
               **(extra_env or {}))
    return subprocess.run(prefix + [PYTHON, *map(str, cmd)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=timeout)


def run_harness(parser, argv, worker, driver, hidden=(), timeout=1800):
    """What a benchmark whose driver launches itself as ``--worker`` processes shares: ``--timeout`` (per
    worker process), ``--json-out``, and the worker's hidden arguments (``hidden``: names, or (name, type)
    pairs); parses ``argv`` and runs the worker or the driver."""
    import argparse
    parser.add_argument("--timeout", type=float, default=timeout)
    parser.add_argument("--json-out")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    for name, kind in (item if isinstance(item, tuple) else (item, str) for item in hidden):
        parser.add_argument(name, type=kind, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    return worker(args) if args.worker else driver(args)


def legacy_available():
    """Whether legacy FEniCS 2019 (Debian's python3-dolfin) is importable."""
    return subprocess.run([PYTHON, "-c", "import dolfin"], capture_output=True).returncode == 0


def machine_load():
    """The 1-minute load average (what the timed tables record next to their figures)."""
    return os.getloadavg()[0]


# --- clocks ---------------------------------------------------------------------------------------

def barrier_time(comm):
    comm.barrier()
    return time.perf_counter()


def rank_max(comm, value):
    from mpi4py import MPI
    return comm.allreduce(value, op=MPI.MAX)


def max_rss_mb():
    import resource
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def current_rss_mb():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2 ** 20


def pc_setup_seconds():
    """PETSc's accumulated PCSetUp time in this process (PETSc.Log.begin() must have been called)."""
    from petsc4py import PETSc
    return PETSc.Log.Event("PCSetUp").getPerfInfo()["time"]


def timed_solve(problem, domain, comm, **kwargs):
    """``nc.solve`` timed between barriers: (Solution, setup s, solve s). ``solve`` is the SNES time of
    ``Solution.stats.time`` (the slowest rank), ``setup`` the rest of the call (binding, forms, K and L,
    the transfer of ``initial`` from the parent mesh, the solver's creation)."""
    import nc_dolfinx as nc
    start = barrier_time(comm)
    solution = nc.solve(problem, domain, **kwargs)
    total = barrier_time(comm) - start
    solve = rank_max(comm, solution.stats.time)
    return solution, total - solve, solve


# --- the linear floor (independent of nc_dolfinx's solver) -------------------------------------------

def rigid_body_modes(V):
    """The d translations and d(d−1)/2 rotations of the vector P1 space V, orthonormalised (as
    demo_elasticity.py's build_nullspace, for any dimension; Gram–Schmidt written out, as DOLFINx 0.5's
    ``la.orthonormalize`` does it: later versions orthonormalise only their own ``la.Vector``)."""
    from petsc4py import PETSc
    index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    x = V.tabulate_dof_coordinates()[:index_map.size_local, :bs]
    planes = [(i, j) for i in range(bs) for j in range(i + 1, bs)]
    basis = [PETSc.Vec().createMPI((index_map.size_local * bs, PETSc.DETERMINE), bsize=bs, comm=V.mesh.comm)
             for _ in range(bs + len(planes))]
    with_arrays = [b.array.reshape(-1, bs) for b in basis]
    for a in with_arrays:
        a[:] = 0.0
    for k in range(bs):
        with_arrays[k][:, k] = 1.0
    for a, (i, j) in zip(with_arrays[bs:], planes):
        a[:, i], a[:, j] = -x[:, j], x[:, i]
    for i, vector in enumerate(basis):
        for previous in basis[:i]:
            vector.axpy(-vector.dot(previous), previous)
        vector.normalize()
    return PETSc.NullSpace().create(vectors=basis, comm=V.mesh.comm)


class LinearFloor:
    """One linear elasticity solve K u = L on the problem's mesh (the nonlinear problem without its
    foundation), assembled once; :meth:`solve` times the PC set-up and the CG solve (not the assembly)."""

    def __init__(self, problem, domain):
        import ufl
        import nc_dolfinx as nc
        from nc_dolfinx import dolfinx_versions as versions
        from dolfinx import fem
        from dolfinx.fem import petsc as fem_petsc
        from petsc4py import PETSc
        self.comm = domain.comm
        fields = nc.bind(problem, domain)
        V = versions.p1_space(domain.mesh, (domain.mesh.geometry.dim,))
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        a = ufl.inner(fields.sigma(u), ufl.sym(ufl.grad(v))) * ufl.dx
        L = ufl.inner(fields.f, v) * ufl.dx
        for group_id, g in fields.g.items():
            L += ufl.inner(g, v) * fields.ds(group_id)
        bcs = fields.boundary_conditions(V)
        a = fem.form(a)
        self.K = fem_petsc.assemble_matrix(a, bcs=bcs)
        self.K.assemble()
        self.L = fem_petsc.assemble_vector(fem.form(L))
        fem_petsc.apply_lifting(self.L, [a], bcs=[bcs])
        self.L.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.L, bcs)
        self.K.setNearNullSpace(rigid_body_modes(V))
        self.V = V  # the null space's vectors live on V's communicator (see solver.rigid_body_modes)
        self.K.setOption(PETSc.Mat.Option.SPD, True)

    def solve(self, rtol=FLOOR_RTOL, norm="preconditioned", amg="gamg", settings=None):
        """(wall s, CG iterations, true residual ‖L − Ku‖/‖L‖) of a fresh KSP: PC set-up + solve. ``amg``:
        gamg, ml or hypre (floor_amg_options), or the name of the KSP/PC ``settings`` given instead."""
        from petsc4py import PETSc
        prefix = f"floor_{amg}_"
        options = PETSc.Options(prefix)
        if settings is None:
            settings = floor_amg_options(amg, self.V.mesh.geometry.dim)
        for key, value in {**settings, "ksp_rtol": rtol, "ksp_norm_type": norm}.items():
            options[key] = value
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(prefix)
        ksp.setOperators(self.K)
        ksp.setFromOptions()
        x = self.K.createVecRight()
        start = barrier_time(self.comm)
        ksp.solve(self.L, x)
        wall = barrier_time(self.comm) - start
        its, reason = ksp.getIterationNumber(), ksp.getConvergedReason()
        r = self.L.duplicate()
        self.K.mult(x, r)
        r.aypx(-1.0, self.L)
        residual = r.norm() / self.L.norm()
        for obj in (ksp, x, r):
            obj.destroy()
        if reason <= 0:
            raise RuntimeError(f"the linear floor did not converge (KSP reason {reason})")
        return wall, its, residual

    def destroy(self):
        self.K.destroy()
        self.L.destroy()


# --- meshes ---------------------------------------------------------------------------------------

def owned_cells(domain):
    import numpy as np
    return np.arange(domain.mesh.topology.index_map(domain.tdim).size_local, dtype=np.int32)


def refine_uniformly(domain):
    """Every cell refined (Plaza with every edge marked): ``nc.refine`` of all owned cells."""
    import nc_dolfinx as nc
    return nc.refine(domain, owned_cells(domain))


def build_refinement_connectivity(msh):
    """The connectivity DOLFINx 0.5's Plaza refinement creates on its first call on a mesh (edges → cells,
    and in 3D faces → edges: ~0.3 s at 1e5 dofs in 3D), built before either refinement is timed: the one
    timed first would otherwise pay for both (``nc.refine`` first made our 3D ratio 1.4–1.5 instead of
    ~1.25)."""
    tdim = msh.topology.dim
    msh.topology.create_entities(1)
    msh.topology.create_connectivity(1, tdim)
    if tdim == 3:
        msh.topology.create_connectivity(2, 1)


def dolfinx_refine_seconds(domain, cells, default=False):
    """DOLFINx's own refinement of the same marked cells (the edges of the marked cells), and nothing else:
    its wall time (slowest rank). By default as ``nc.refine`` calls it, children on their parent's rank:
    on 0.9 and 0.11 ``versions.refine_keeping_ranks`` (on 0.9 with nc_dolfinx's partitioner, which builds
    the ghost layer), on 0.5.2 ``refine(redistribute=False)`` alone (it may ghost a cell twice, which
    ``nc.refine`` then repairs by re-creating the mesh: not timed here). ``default=True``: DOLFINx's plain
    ``refine(msh, edges)`` (0.5.2 partitions the child anew, 0.9 too but builds no ghost cells; 0.11
    keeps the children on their parent's rank and ghosts them, as ``nc.refine``)."""
    from dolfinx import mesh as dmesh
    from nc_dolfinx import dolfinx_versions as versions
    msh = domain.mesh
    start = barrier_time(msh.comm)
    msh.topology.create_entities(1)
    edges = versions.incident_edges(msh, cells)
    if default:
        dmesh.refine(msh, edges)
    elif versions.V05:
        dmesh.refine(msh, edges, redistribute=False)
    else:
        versions.refine_keeping_ranks(msh, edges)
    return barrier_time(msh.comm) - start


def dofs(domain):
    return domain.mesh.geometry.dim * domain.num_vertices()


# --- tables ---------------------------------------------------------------------------------------

def format_table(rows, columns):
    """``columns``: (key, header, format); missing values print as '-'."""
    def cell(r, key, fmt):
        value = r.get(key)
        if value is None or value == "" or (isinstance(value, float) and math.isnan(value)):
            return "-"
        return fmt.format(value)
    header = [h for _, h, _ in columns]
    body = [[cell(r, k, fmt) for k, _, fmt in columns] for r in rows]
    widths = [max(len(x) for x in col) for col in zip(header, *body)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(header, widths)), "  ".join("-" * w for w in widths)]
    lines += ["  ".join(c.rjust(w) for c, w in zip(line, widths)) for line in body]
    return "\n".join(lines)
