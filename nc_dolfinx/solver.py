"""Nonlinear solver for (7): PETSc SNES configured through an options prefix.

Options are layered (later wins): the preset's defaults, the problem file's ``[solver] petsc_options``,
then ``-snes_*``/``-ksp_*``/``-pc_*`` flags from the command line. All are written into the PETSc
options database under the prefix ``nc_`` and read by ``setFromOptions``, so any PETSc option works,
as in dolfiny.
"""
import time
from dataclasses import dataclass

from petsc4py import PETSc

import dolfinx
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from .errors import InputError

PREFIX = "nc_"

NEWTON_DEFAULTS = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "bt",
    "snes_rtol": 1e-10,
    "snes_stol": 0.0,
    "snes_max_it": 50,
}
# Unless an snes_atol is given, ‖F‖ <= ATOL_OF_LOAD ‖L‖ also counts as converged: with a good initial
# guess (nested iteration) snes_rtol relative to ‖F(u_0)‖ can lie below round-off on large meshes.
ATOL_OF_LOAD = 1e-10
# Both presets run CG on the Jacobian J = K + j_n'(u); the preconditioner is built once per mesh from K or
# from J(u_0) (see NonlinearSolver): a Cholesky factorisation (MUMPS, AMF ordering: the fastest measured
# here) or GAMG with the rigid-body near-nullspace.
PRESETS = {
    "direct": {"ksp_type": "cg", "ksp_rtol": 1e-10, "pc_type": "cholesky",
               "pc_factor_mat_solver_type": "mumps", "mat_mumps_icntl_7": 2},
    # Eisenstat–Walker inexact Newton (with the basic line search: backtracking fails on inexact steps)
    # halved the nonlinear solve time with GAMG in benchmarks/ (version 3 measured best).
    "iterative": {"ksp_type": "cg", "ksp_rtol": 1e-10, "pc_type": "gamg",
                  "pc_gamg_type": "agg", "pc_gamg_agg_nsmooths": 1, "mg_levels_ksp_type": "chebyshev",
                  "mg_levels_pc_type": "jacobi", "snes_ksp_ew": True, "snes_ksp_ew_version": 3,
                  "snes_linesearch_type": "basic"},
}
# "auto": the PC built from K is kept while a Newton system needs at most this many Krylov iterations.
AUTO_SWITCH_ITERATIONS = 30
PRECONDITIONER_MATRICES = ("auto", "bulk", "jacobian")


def solver_options(preset, problem_options=None, cli_options=None):
    options = dict(NEWTON_DEFAULTS)
    options.update(PRESETS[preset])
    options.update(problem_options or {})
    options.update(cli_options or {})
    return options


_OPTIONS_SET = {}  # prefix -> keys set by the last call: PETSc's options database is global


def set_petsc_options(options, prefix=PREFIX):
    """Replace the options under ``prefix`` (those a previous solver set are removed first, so that one
    process can run several solvers with different settings)."""
    db = PETSc.Options(prefix)
    for key in _OPTIONS_SET.pop(prefix, ()):
        db.delValue(key)
    _OPTIONS_SET[prefix] = [key.lstrip("-") for key in options]
    for key, value in options.items():
        key = key.lstrip("-")
        if value is None or value is True:
            db[key] = None if value is None else "true"
        elif value is False:
            db[key] = "false"
        else:
            db[key] = value


def rigid_body_modes(V):
    """Near-nullspace of 2D elasticity: two translations and the infinitesimal rotation."""
    index_map = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    n_local = index_map.size_local
    x = V.tabulate_dof_coordinates()[:n_local]
    vectors = [dolfinx.la.create_petsc_vector(index_map, bs) for _ in range(3)]
    arrays = [v.array.reshape(-1, bs) for v in vectors]
    for i in range(3):
        arrays[i][:] = 0.0
    arrays[0][:, 0] = 1.0
    arrays[1][:, 1] = 1.0
    arrays[2][:, 0] = -x[:, 1]
    arrays[2][:, 1] = x[:, 0]
    dolfinx.la.orthonormalize(vectors)
    return PETSc.NullSpace().create(vectors=vectors, comm=V.mesh.comm)


@dataclass
class SolveStats:
    newton_iterations: int = 0
    linear_iterations: int = 0
    converged_reason: str = ""
    time: float = 0.0
    preconditioner_matrix: str = ""  # the mode at the end ("auto" may have switched to "jacobian")


REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}


class NonlinearSolver:
    """SNES for (7): F(u) = K u + j_n(u, ·) − λ L = 0, J(u) = K + j_n'(u), homogeneous Dirichlet BCs.

    The bulk stiffness K and the load vector L are assembled once (with the Dirichlet rows of K set to
    the identity and those of L to zero); a residual evaluation is then one mat-vec plus an assembly over
    Γ_C, and a Jacobian evaluation a copy of K plus the Γ_C contribution. The Dirichlet dofs of the
    iterate stay zero, so K's zeroed Dirichlet columns lose nothing.
    """

    def __init__(self, forms, u, bcs, options, preconditioner_matrix="auto"):
        """``preconditioner_matrix`` is the matrix the PC is built from:
        "bulk": K, set up once per mesh — cheap while the foundation is soft compared with the body;
        "jacobian": J, set up at every Newton step — robust for a stiff foundation (penalty);
        "auto": J(u_0) at the initial guess, set up once — K itself on a cold start without initial
        penetration, the contact stiffness of the transferred solution on a nested level — switching to
        J at every step for good once a Newton system needs more than AUTO_SWITCH_ITERATIONS Krylov
        iterations (a count, not a time, so that every rank and every run decides alike).
        """
        self.u, self.bcs = u, bcs
        a, L = fem.form(forms.a), fem.form(forms.L)
        self.j_n, self.j_n_jacobian = fem.form(forms.j_n), fem.form(forms.j_n_jacobian)
        self.K = fem_petsc.assemble_matrix(a, bcs=bcs)
        self.K.assemble()
        self.load = fem_petsc.assemble_vector(L)
        self.load.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.load, bcs)
        self.load_factor = 1.0
        self.contact = fem_petsc.create_vector(self.j_n)
        self.b = fem_petsc.create_vector(self.j_n)
        if preconditioner_matrix not in PRECONDITIONER_MATRICES:
            raise ValueError(f"preconditioner_matrix must be one of {PRECONDITIONER_MATRICES}")
        self.A = self.K.duplicate(copy=True)  # K's sparsity contains Γ_C's
        # "auto" copies J(u_0) into P once per solve (P unchanged afterwards: the PC is kept) until it
        # switches; "bulk" uses K itself.
        self.P = self.K if preconditioner_matrix == "bulk" else self.K.duplicate(copy=True)
        near_nullspace = rigid_body_modes(u.function_space)
        for matrix in (self.A, self.P):
            matrix.setNearNullSpace(near_nullspace)
        self.mode = preconditioner_matrix
        set_petsc_options(options)
        self.snes = PETSc.SNES().create(u.function_space.mesh.comm)
        self.snes.setOptionsPrefix(PREFIX)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A, self.P)
        self.snes.setFromOptions()
        self.snes.getKSP().setFromOptions()
        if "snes_atol" not in options:
            self.snes.setTolerances(atol=max(ATOL_OF_LOAD * self.load.norm(), 1e-300))

    def _update(self, x):
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(self.u.vector)
        self.u.vector.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def _residual(self, snes, x, b):
        self._update(x)
        with self.contact.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self.contact, self.j_n)
        self.contact.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.contact, self.bcs)  # Dirichlet rows: b = (K x)_D = x_D
        self.K.mult(x, b)
        b.axpy(1.0, self.contact)
        b.axpy(-self.load_factor, self.load)

    def _jacobian(self, snes, x, A, P):
        self.K.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        fem_petsc.assemble_matrix(A, self.j_n_jacobian, bcs=self.bcs)
        A.assemble()
        first = snes.getIterationNumber() == 0
        if self.mode == "auto" and not first and snes.getKSP().getIterationNumber() > AUTO_SWITCH_ITERATIONS:
            self.mode = "jacobian"
        if self.mode == "jacobian" or (self.mode == "auto" and first):
            # While P is left untouched PETSc sees an unchanged matrix and keeps its PC.
            A.copy(P, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)

    def solve(self, load_steps=1):
        """Solve from the current ``u`` (the initial guess), in ``load_steps`` increments of the loads."""
        stats, start = SolveStats(), time.perf_counter()
        x = self.u.vector.copy()
        fem_petsc.set_bc(x, self.bcs)  # homogeneous Dirichlet data: the guess must satisfy it
        for step in range(1, load_steps + 1):
            self.load_factor = step / load_steps
            self.snes.solve(None, x)
            reason = self.snes.getConvergedReason()
            stats.newton_iterations += self.snes.getIterationNumber()
            stats.linear_iterations += self.snes.getLinearSolveIterations()
            stats.converged_reason = REASONS.get(reason, str(reason))
            if reason <= 0:
                raise InputError(f"SNES diverged ({stats.converged_reason}) after "
                                 f"{self.snes.getIterationNumber()} Newton iterations"
                                 + (f" in load step {step}/{load_steps}" if load_steps > 1 else "")
                                 + "; try --load-steps, -snes_linesearch_type or a smaller c_n")
        self._update(x)
        x.destroy()
        stats.time = time.perf_counter() - start
        stats.preconditioner_matrix = self.mode
        return stats

    def destroy(self):
        owned = [self.snes, self.A, self.K, self.b, self.contact, self.load]
        for obj in owned + ([self.P] if self.P is not self.K else []):
            obj.destroy()
