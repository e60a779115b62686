"""The Newton driver for (7): PETSc SNES configured through an options prefix.

(7) minimises the convex, C¹ energy (``forms.energy``)
    Π(u) = ½a(u,u) − L(u) + ∫_Γ_C c_n/(m_n+1) (u_n − g_0)_+^{m_n+1},   F = ∇Π,  J = ∇²Π
(generalised for m_n < 2). SNES gets Π as its objective; the line search (a precheck) minimises Π along
each Newton step, checked against the objective, so no step increases Π. Every CG iterate started from
zero is a descent direction of Π (∇Π·d = −dᵀJd < 0), so inexact (Eisenstat–Walker, :mod:`.forcing`) steps
and Krylov solves stopped at their iteration limit are safe steps too. On a cold start with a gap and
m_n = 1 the first step may be the bilateral one (all of Γ_C in contact, see _bilateral_predictor). A failed
SNES solve goes to the recovery strategies (:mod:`.recovery`); a solve whose residual stalls or fails
within its own round-off (a stiff penalty with a gap) ends there, converged (see
NonlinearSolver._within_roundoff). The linear solver inside each step and the options' layers are
:mod:`.linear`'s.
"""
import math
import time
from dataclasses import dataclass

import numpy as np
from ufl.algorithms.apply_algebra_lowering import apply_algebra_lowering
from ufl.algorithms.apply_derivatives import apply_derivatives
from ufl.algorithms.map_integrands import map_integrand_dags
from ufl.corealg.multifunction import MultiFunction
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from .. import dolfinx_versions as versions
from ..errors import InputError
from .fixed_point import FrictionFixedPoint
from .forcing import Forcing
from .linear import OWN_DEFAULTS, PRECONDITIONER_MATRICES, option_is_true, resolve_options, rigid_body_modes
from .petsc_options import PREFIX, set_petsc_options, together
from .predictor import same_layout, tangent_prediction
from .recovery import Recoveries


@dataclass
class SolveStats:
    newton_iterations: int = 0
    linear_iterations: int = 0
    converged_reason: str = ""
    time: float = 0.0
    preconditioner_matrix: str = ""  # the configured mode ("auto", "bulk", "jacobian")
    preset: str = ""                # the preset in force ("auto" resolved)
    pc_setups: int = 0              # times the preconditioning matrix was (re)built
    recoveries: str = ""            # fallbacks taken after a failed SNES solve, e.g. "refresh,continuation"
    pc_type: str = ""               # the preconditioner in force (cholesky, gamg, hypre, or the user's)
    friction_passes: int = 0        # passes of the fixed point on the friction bound (0: no friction)
    friction_newton: int = 0        # of the Newton steps, those of the consistent Newton finish (fixed_point)
    predictor: str = ""             # "tangent" (or "tangent refused") if the tangent predictor ran (.predictor)
    predictor_its: int = 0          # its Krylov iterations (counted in linear_iterations too)


REASONS = {v: k for k, v in vars(PETSc.SNES.ConvergedReason).items() if isinstance(v, int)}
INDEFINITE = (PETSc.KSP.ConvergedReason.DIVERGED_INDEFINITE_PC, PETSc.KSP.ConvergedReason.DIVERGED_INDEFINITE_MAT)


class _LineSearchFailure(Exception):
    """No step along the Newton direction decreases Π: the SNES solve is abandoned (the fallbacks take
    over from the last iterate)."""


class _Creeping(Exception):
    """``creeping_steps`` Newton steps in a row were cut short by the line search: the contact zone grows a
    few points a step (see _retry_c_n_continuation); the SNES solve is abandoned for the c_n continuation
    (with friction, a warm pass's stick/slip front: for the ε-continuation, see FrictionFixedPoint)."""


class _ConvergedToRoundoff(Exception):
    """The residual of the current iterate lies within its own round-off (see _within_roundoff): the SNES
    solve ends there, converged."""


class _ClosedKinks(MultiFunction):
    """gt(a, b) -> ge(a, b): a conditional's kink taken on its active side."""
    expr = MultiFunction.reuse_if_untouched

    def gt(self, o, a, b):
        return ufl.ge(a, b)


def closed_jacobian(jacobian):
    """The Jacobian form with (·)_+ differentiated as active at its kink (u_n − g_0 = 0).

    Both one-sided derivatives at the kink belong to the generalised Jacobian, so semismooth Newton may
    use either; the two differ only where u_n − g_0 = 0 exactly — in practice on a cold start u_0 = 0
    without gap, where the usual choice drops the foundation (J(0) = K, m_n = 1) and the first step
    overshoots by ~c_n times the unsupported body's penetration. The closed choice gives the first
    Jacobian the foundation's stiffness (and the preconditioner built from it)."""
    return map_integrand_dags(_ClosedKinks(), apply_derivatives(apply_algebra_lowering(jacobian)))


# Preconditioner refresh ("auto"): the preconditioning matrix P is rebuilt from the current Jacobian J
# when (a) the last Krylov solve failed, or (b) it needed more than pc_refresh_growth times the fewest
# iterations per decade of residual reduction seen since P was built (and more than KRYLOV_MIN_ITS), or
# (c) J and P differ by more than pc_refresh_misfit along the last Newton step y: |yᵀ(J − P)y| / yᵀPy. (c) is
# what fires on the family's foundations with m_n > 1 after the first step from J(0) = K (misfit 2.6–44:
# CG then needed 41–47 iterations in all instead of 55–80). All are global numbers: every rank decides alike.
KRYLOV_MIN_ITS = 20
# Line minimisation (see _line_minimisation).
WOLFE_ETA = 0.5
LINE_TOL = 0.1
OBJECTIVE_ROUNDOFF = 1e-10
# Round-off of the residual (see _within_roundoff): checked when ‖F‖ no longer falls below STALL_RATIO times
# its last value, or when a solve fails.
STALL_RATIO = 0.5
# ... and a residual within its round-off ends a solve only while (7) holds to ROUNDOFF_MEANINGFUL ‖λL‖: above
# that the round-off is not what stops Newton. Measured: the stiffest penalties with a gap end at 1.2e-6 ‖L‖
# (c_n/E = 1e12, tests/mpi/roundoff.py); a 3D block loaded 1.002 times beyond its friction limit (the limit
# check disabled) slid 3.4e9 away and its round-off, ~ε K_ii ‖u‖_∞, reached 2e-3 ‖L‖.
ROUNDOFF_MEANINGFUL = 1e-4


def _check_finite(matrix_or_vector, message):
    """Raise InputError(message) on every rank if an entry is inf or NaN. (PETSc's norms would not say:
    their comparisons skip NaN. A matrix is multiplied by a vector of ones, which carries any inf or NaN
    entry into the product without a copy of the matrix.)"""
    vector = matrix_or_vector
    if isinstance(matrix_or_vector, PETSc.Mat):
        ones, vector = matrix_or_vector.createVecs()
        ones.set(1.0)
        matrix_or_vector.mult(ones, vector)
        ones.destroy()
    finite = np.all(np.isfinite(vector.getArray(readonly=True)))
    if vector is not matrix_or_vector:
        vector.destroy()
    if matrix_or_vector.getComm().tompi4py().allreduce(not finite, MPI.LOR):
        raise InputError(message)


class NonlinearSolver(Recoveries, FrictionFixedPoint):
    """SNES for (7): F(u) = K u + j_n(u, ·) − λ L = 0, J(u) = K + j_n'(u), with Dirichlet BCs u = λ u_D
    ((2) generalised; u_D = 0 on clamped groups and symmetry planes).

    The bulk stiffness K and the load vector L are assembled once (with the Dirichlet rows of K set to
    the identity and those of L to u_D, and L lifted: L − K u_D on the free rows, since K's Dirichlet
    columns are zeroed); a residual evaluation is then one mat-vec plus an assembly over Γ_C, and a
    Jacobian evaluation a copy of K plus the Γ_C contribution. The Dirichlet dofs of the iterate are set to
    λ u_D before each solve and every Newton step leaves them there (its Dirichlet entries are zero), so
    F's Dirichlet rows x_D − λ u_D vanish and the prescribed displacement ramps with the loads (load steps,
    the load continuation). With u_D = 0 the lifting adds nothing: the homogeneous problem of the paper.
    """

    def __init__(self, forms, u, bcs, options, preconditioner_matrix="auto", end_of_increment=None):
        """``options``: from ``solver_options`` (the preset's name and the user's layers).
        ``end_of_increment(u)``: called with u solved at the end of each load increment but the last (with
        friction: the law's state moves on, :func:`nc_dolfinx.physics.slip_state.advance`).
        ``preconditioner_matrix`` is the matrix the PC is built from:
        "auto": J(u_0) at the initial guess (K itself on a cold start, the contact stiffness of the
        transferred solution on a nested level), rebuilt from the current J when it no longer fits (see
        pc_refresh_growth) or a Krylov solve failed; "bulk": K, set up once per mesh; "jacobian": J at every
        Newton step.
        The objective Π = ½xᵀKx − Lᵀx + ``forms.contact_energy`` (its non-quadratic Γ_C part) drives the
        line search.
        """
        if preconditioner_matrix not in PRECONDITIONER_MATRICES:
            raise ValueError(f"preconditioner_matrix must be one of {PRECONDITIONER_MATRICES}")
        self.u, self.bcs, self.mode = u, bcs, preconditioner_matrix
        self.end_of_increment = end_of_increment
        self.configured_mode = preconditioner_matrix
        V = u.function_space
        self.comm = V.mesh.comm
        self._assemble_constant_parts(forms)
        dofs = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        self.preset, self.options = resolve_options(options, V.dofmap.index_map_bs, dofs,
                                                    versions.petsc_vec(u).norm() > 0, forms.j_t is not None)
        self.user_keys = {key.lstrip("-") for key in options}
        self.near_nullspace = rigid_body_modes(V)
        self._configure(self.K)
        self.A = self._copy_of_K()  # K's sparsity contains Γ_C's
        self.P = self.K if preconditioner_matrix == "bulk" else self._copy_of_K()
        self._create_snes()
        self.left_cg = False  # see _leave_cg
        self.bilateral_candidate = False  # see _bilateral_predictor
        self.extra_krylov = 0  # Krylov iterations SNES does not count (the predictor's)
        self.cut_steps, self.creeping_check, self.crept, self.creeping_limit = 0, False, False, 0  # see _Creeping
        self._reset_preconditioner_state()

    def _configure(self, matrix):
        matrix.setNearNullSpace(self.near_nullspace)
        matrix.setOption(PETSc.Mat.Option.SPD, True)  # K + j_n'(u) (+ j_t'(u), frozen bound): SPD

    def _copy_of_K(self):
        matrix = self.K.duplicate(copy=True)
        self._configure(matrix)
        return matrix

    def _assemble_constant_parts(self, forms):
        """Compile the forms; assemble K (Dirichlet rows: identity) and the lifted L (free rows: L − K u_D,
        Dirichlet rows: u_D) once."""
        self._use_contact_forms(forms)
        self.forms = forms  # (the c_n continuation builds its forms from them, when used)
        bulk = fem.form(forms.a)
        self.K = fem_petsc.assemble_matrix(bulk, bcs=self.bcs)
        self.K.assemble()
        self.operator_term = forms.operator_term  # (a term of (7) beside the forms: its sparsity joins K's)
        if self.operator_term is not None:
            self.K = self.operator_term.widen(self.K, self.bcs)
        self.load = fem_petsc.assemble_vector(fem.form(forms.L))
        versions.lift(self.load, bulk, self.bcs)
        self.load.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        fem_petsc.set_bc(self.load, self.bcs)
        _check_finite(self.K, "the stiffness matrix K of (7) overflows double precision: material.E (or a "
                              "region's E) is too large for this mesh")
        _check_finite(self.load, "the load vector L of (7) overflows double precision: loads.f or loads.g is "
                                 "too large")
        self.load_factor = 1.0
        self.load_abs = None  # |L|, made when _within_roundoff first needs it
        self.xKx = (None, None, 0.0)  # (x's handle, its state, xᵀKx): see _residual
        self.contact = versions.create_petsc_vector(self.j_n)
        self.b = versions.create_petsc_vector(self.j_n)
        self.work, self.trial, self.predicted = self.K.createVecRight(), versions.petsc_vec(self.u).copy(), self.K.createVecRight()

    def _use_contact_forms(self, forms):
        """Γ_C's forms of (7) (``forms``, or the c_n continuation's scaled ones), compiled: j_n (+ j_t with
        friction), its Jacobian with the kinks closed, the contact energy; the bilateral forms are compiled
        when used."""
        self.j_n = fem.form(forms.contact_residual)
        self.j_n_jacobian = fem.form(closed_jacobian(forms.contact_jacobian))
        self.contact_energy = fem.form(forms.contact_energy)
        self.bilateral = (forms.bilateral_jacobian, forms.gap_load, forms.separation)
        self.stiffened_jacobian = (None if forms.slip_stiffening is None else
                                   fem.form(closed_jacobian(forms.contact_jacobian + forms.slip_stiffening)))
        self.consistent = forms.consistent_jacobian  # (with friction: compiled when first used, FrictionFixedPoint)

    # what _use_contact_forms sets (the c_n continuation swaps them for its scaled forms and back)
    CONTACT_FORMS = ("j_n", "j_n_jacobian", "stiffened_jacobian", "contact_energy", "bilateral", "consistent")

    def _create_snes(self):
        """SNES and its KSP configured from the options (a PETSc error there, or in the rehearsal of the
        Krylov/PC set-up, is an InputError naming the user's options when the user gave any: see petsc_options.together)."""
        set_petsc_options({k: v for k, v in self.options.items() if k not in OWN_DEFAULTS})
        user = {k: v for k, v in self.options.items() if k in self.user_keys and k not in OWN_DEFAULTS}
        self.snes = PETSc.SNES().create(self.comm)
        self.snes.setOptionsPrefix(PREFIX)
        self.snes.setFunction(self._residual, self.b)
        self.snes.setJacobian(self._jacobian, self.A, self.P)
        self.snes.setObjective(self._objective)
        self.snes.setLineSearchPreCheck(self._precheck)
        ksp = self.snes.getKSP()

        def configure():
            self.snes.setFromOptions()
            ksp.setFromOptions()

        together(self.comm, configure, user)
        if user:
            together(self.comm, self._rehearse_set_up, user)
        ksp.setConvergenceHistory(reset=True)  # for the Krylov growth (see _krylov_grew)
        # Eisenstat–Walker's parameters as PETSc read them, applied by Forcing instead of PETSc's code
        self.forcing = Forcing(self.snes.getParamsEW()) if self.snes.getUseEW() else None
        self.snes.setUseEW(False)
        self.atol_given = "snes_atol" in self.options
        self.rtol, self.atol, _, _ = self.snes.getTolerances()  # SNES gets them as one target (_target)

    def _rehearse_set_up(self):
        """The first Krylov/PC set-up, rehearsed with the options in force on a small SPD matrix of J's
        block size and type, distributed like J (4 block rows per rank of 3 on the diagonal, −1 beside it):
        PETSc reads some options only at the set-up (a factorisation's solver package, which may not be built
        or not take this matrix; multigrid levels' and blocks' sub-solvers; hypre's AMS, which needs
        coordinates), and the real one happens inside the first Newton step. The rehearsal reads the options
        the real set-up reads (the same types), and takes milliseconds."""
        bs = self.K.getBlockSize()
        rows = 4 * bs
        A = PETSc.Mat().createAIJ(((rows, None), (rows, None)), bsize=bs, nnz=(3, 1), comm=self.comm)
        ksp = PETSc.KSP().create(self.comm)
        try:
            start, end = A.getOwnershipRange()
            size = A.getSize()[0]
            for i in range(start, end):
                A.setValue(i, i, 3.0)
                for j in (i - 1, i + 1):
                    if 0 <= j < size:
                        A.setValue(i, j, -1.0)
            A.assemble()
            A.setOption(PETSc.Mat.Option.SPD, True)
            ksp.setOptionsPrefix(PREFIX)
            ksp.setOperators(A, A)
            ksp.setFromOptions()
            ksp.setUp()
        finally:
            ksp.destroy()
            A.destroy()

    # --- evaluations -------------------------------------------------------------------------------

    def _update(self, x):
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        x.copy(versions.petsc_vec(self.u))
        versions.petsc_vec(self.u).ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def _assemble_contact(self, x):
        """j_n(x, ·) into self.contact (Dirichlet rows zero)."""
        self._update(x)
        with self.contact.localForm() as local:
            local.set(0.0)
        fem_petsc.assemble_vector(self.contact, self.j_n)
        self.contact.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        if self.operator_term is not None:
            self.operator_term.add_residual(self.contact)
        self.zero_dirichlet_rows(self.contact)
        return self.contact

    def _residual(self, snes, x, b):
        contact = self._assemble_contact(x)
        self.K.mult(x, b)  # Dirichlet rows: b = (K x)_D = x_D
        self.xKx = (x.handle, x.stateGet(), x.dot(b))  # for the line search's values of Π at x
        b.axpy(1.0, contact)
        b.axpy(-self.load_factor, self.load)

    def _objective(self, snes, x):
        """Π(x) = ½xᵀKx − λLᵀx + ∫_Γ_C c_n/(m_n+1) (x_n − g_0)_+^{m_n+1}."""
        self.K.mult(x, self.work)
        return 0.5 * x.dot(self.work) - self.load_factor * self.load.dot(x) + self._contact_energy(x)

    def _contact_energy(self, x):
        """Π's Γ_C part at x, ∫_Γ_C c_n/(m_n+1) (x_n − g_0)_+^{m_n+1}."""
        self._update(x)
        energy = self.comm.allreduce(fem.assemble_scalar(self.contact_energy), op=MPI.SUM)
        return energy if self.operator_term is None else energy + self.operator_term.energy()

    def _precheck(self, x, y):
        """Before SNES steps to x − λy: the step's Dirichlet entries set to zero, then (``line_minimisation``)
        λ chosen by :meth:`_line_minimisation`.

        J's Dirichlet rows are identity rows with F_D = x_D = 0, so the exact step has y_D = 0; a Krylov
        iterate does not (AMG aggregates mix constrained and free dofs: |y_D| reached 2 % of |y| on the
        3D box), and a step with y_D ≠ 0 moves the clamped dofs. Where Γ_D meets Γ_C, Π then depends on
        x_D while F_D does not carry j_n's part (its Dirichlet rows are x_D), so F is no longer ∇Π along y:
        the line search stalled at ‖F‖ ≈ 1e-4 ‖F_0‖ on the 3D box (65 Newton steps and three fallbacks).
        Zeroing y_D keeps x_D = λ u_D and leaves F·y (F_D = 0) unchanged: y stays a descent direction of Π."""
        self.zero_dirichlet_rows(y)
        self._predict(y)  # first: the bilateral predictor reassembles A
        if self.bilateral_candidate:
            self.bilateral_candidate = False
            if self._bilateral_predictor(x, y):
                self.predicted_full_step = False
                return True
        scaled = option_is_true(self.options["line_minimisation"]) and self._line_minimisation(x, y)
        self.predicted_full_step = not scaled
        self.cut_steps = self.cut_steps + 1 if scaled else 0
        if self.creeping_check and 0 < self.creeping_limit <= self.cut_steps:
            raise _Creeping()
        return True

    def _predict(self, y):
        """F at x − y by the linear model, F(x) − J y, kept for Forcing (one mat-vec)."""
        if self.forcing is not None:
            self.A.mult(y, self.predicted)
            self.predicted.aypx(-1.0, self.snes.getFunction()[0])

    def _remainder(self):
        """‖F − (the linear model's prediction)‖ at the current iterate, if the last step was taken in full."""
        if not self.predicted_full_step:
            return None
        self.predicted_full_step = False
        self.predicted.aypx(-1.0, self.snes.getFunction()[0])
        return self.predicted.norm()

    def _line_minimisation(self, x, y):
        """The line search: scale the Newton step y (SNES steps to x − λy) to a minimiser λ ∈ (0, 1] of Π.

        φ(λ) = Π(x − λy) is convex with φ'(λ) = −F(x − λy)·y. The quadratic part of φ' is known from one
        mat-vec (K symmetric), so each trial costs only an assembly over Γ_C. The full step is kept while
        φ'(1) <= WOLFE_ETA |φ'(0)| (near the solution φ'(1)/φ'(0) -> 0: Newton's local convergence is
        untouched); otherwise the root of φ' in (0, 1) is bracketed and found by safeguarded secant steps
        (Illinois) to |φ'| <= LINE_TOL |φ'(0)|. Last, SNES's objective Π must not increase (checked where
        the decrease exceeds Π's round-off; halving λ otherwise).
        """
        self.K.mult(y, self.work)
        yKy, xKy = y.dot(self.work), x.dot(self.work)
        Lx, Ly = (self.load_factor * self.load.dot(v) for v in (x, y))

        def trial(lam):  # x − λy
            x.copy(self.trial)
            self.trial.axpy(-lam, y)
            return self.trial

        def slope(lam):
            return -(xKy - lam * yKy - Ly + self._assemble_contact(trial(lam)).dot(y))

        def objective(lam):  # Π(x − λy), its quadratic part from the products above: no mat-vec
            quadratic = 0.5 * (self._xKx(x) - 2 * lam * xKy + lam ** 2 * yKy) - Lx + lam * Ly
            return quadratic + self._contact_energy(trial(lam))

        s0, lam = slope(0.0), 1.0
        s = slope(lam) if s0 < 0.0 else 0.0
        if s > WOLFE_ETA * abs(s0):
            lam, s = self._slope_root(slope, s0, s)
        lam = self._objective_decreases(objective, lam, 0.5 * lam * (s0 + s), Lx)
        if lam != 1.0:
            y.scale(lam)
        return lam != 1.0

    @staticmethod
    def _slope_root(slope, s0, s1):
        """λ in (0, 1) with |φ'(λ)| <= LINE_TOL |φ'(0)|, from φ'(0) = s0 < 0 < φ'(1) = s1 (Illinois)."""
        lo, hi, slo, shi, side = 0.0, 1.0, s0, s1, 0
        for _ in range(50):
            lam = (lo * shi - hi * slo) / (shi - slo)
            s = slope(lam)
            if abs(s) <= LINE_TOL * abs(s0):
                break
            if s < 0.0:
                lo, slo = lam, s
                shi, side = (shi / 2 if side == -1 else shi), -1  # halve the stale end's slope
            else:
                hi, shi = lam, s
                slo, side = (slo / 2 if side == 1 else slo), 1
        return lam, s

    @staticmethod
    def _objective_decreases(objective, lam, predicted, Lx):
        """λ, halved until φ(λ) = Π(x − λy) <= φ(0) = Π(x). Skipped where the predicted change (trapezoid
        of the slopes, < 0) is below OBJECTIVE_ROUNDOFF times Π's terms (~λ|Lᵀx|): the two values of Π
        cannot resolve it there, the slopes can. Raises _LineSearchFailure if no λ >= 2^-30 λ decreases Π."""
        if -OBJECTIVE_ROUNDOFF * abs(Lx) <= predicted <= 0.0:
            return lam
        value = objective(0.0)
        for _ in range(30):
            if objective(lam) <= value:
                return lam
            lam /= 2
        raise _LineSearchFailure()

    def _xKx(self, x):
        """xᵀKx, from the residual's evaluation at x if it was the last one (SNES's iterate)."""
        handle, state, value = self.xKx
        if handle == x.handle and state == x.stateGet():
            return value
        self.K.mult(x, self.work)
        return x.dot(self.work)

    # --- the preconditioner ------------------------------------------------------------------------

    def _reset_preconditioner_state(self):
        self.best_rate = math.inf   # fewest Krylov iterations per decade since P was built
        self.force_refresh = True   # P is built from J(u_0) on the first Jacobian
        self.first_jacobian = True
        self.pc_setups = 0

    def _last_krylov_solve(self):
        """(iterations, decades of residual reduction, failed) of the last Krylov solve."""
        ksp = self.snes.getKSP()
        history = ksp.getConvergenceHistory()
        its = ksp.getIterationNumber()
        decades = math.log10(history[0] / history[-1]) if len(history) > 1 and history[-1] > 0 else 0.0
        return its, decades, ksp.getConvergedReason() < 0

    def _wants_refresh(self, first, A):
        if self.mode == "bulk":
            return False
        if self.mode == "jacobian" or self.force_refresh:
            return True
        if not first and self._krylov_grew():  # (first: the KSP's last solve belongs to an earlier SNES solve)
            return True
        return self._misfit(A) > float(self.options["pc_refresh_misfit"])

    def _misfit(self, A):
        """|yᵀ(J − P)y| / yᵀPy for the last Newton step y: the part of J's energy along the solution's
        current direction of change that P misses. Smooth modes decide AMG's convergence, and a
        foundation changes their stiffness by ~c_n'·ℓ/E (ℓ the body's size), far more than the diagonal
        (~c_n'·h/E) shows."""
        y = self.snes.getSolutionUpdate()
        if y is None or y.norm() == 0.0:
            return 0.0
        A.mult(y, self.work)
        yAy = y.dot(self.work)
        self.P.mult(y, self.work)
        yPy = y.dot(self.work)
        misfit = abs(yAy - yPy) / yPy
        return misfit

    def _krylov_grew(self):
        """The last Krylov solve failed, or needed more than pc_refresh_growth times the fewest iterations per
        decade seen since P was built (solves of >= 3 iterations; the first, loose EW solves often need 1)."""
        its, decades, failed = self._last_krylov_solve()
        rate = its / max(decades, 0.5)
        if its >= 3:
            self.best_rate = min(self.best_rate, rate)
        growth = float(self.options["pc_refresh_growth"])
        grew = failed or (its > KRYLOV_MIN_ITS and rate > growth * self.best_rate)
        return grew

    def _stiffness_plus(self, matrix, contact_form):
        """matrix = K + the bilinear Γ_C form (Dirichlet rows: K's identity rows)."""
        self.K.copy(matrix, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        fem_petsc.assemble_matrix(matrix, contact_form, bcs=self.bcs)
        matrix.assemble()
        if self.operator_term is not None:  # (which of the Γ_C Jacobians: the term's own is the same kind)
            kind = ("consistent" if contact_form is self.consistent else
                    "stiffened" if contact_form is self.stiffened_jacobian else "frozen")
            self.operator_term.add_jacobian(matrix, kind)

    def _rebuild_preconditioner(self, A):
        """P = A; PETSc rebuilds the preconditioner at the next Krylov solve (while P is left untouched it
        sees an unchanged matrix and keeps it). If P was K itself ("bulk", left by the stronger_pc
        fallback), P becomes a matrix of its own first: copying A into it overwrote K, and every later
        residual then held the foundation twice (a stiff penalty ended "converged" 4.5 % off)."""
        if self.P is self.K:
            self.P = self._copy_of_K()
            self.snes.setJacobian(self._jacobian, self.A, self.P)
        A.copy(self.P, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self.force_refresh, self.best_rate = False, math.inf
        self.pc_setups += 1

    def _jacobian(self, snes, x, A, P):
        first = snes.getIterationNumber() == 0
        self._stiffness_plus(A, self._newton_jacobian(first))
        if self.first_jacobian:
            self._first_krylov_tolerance(A)
        fnorm = snes.getFunctionNorm()
        if not first and fnorm >= STALL_RATIO * self.previous_fnorm and self._within_roundoff(x, A):
            raise _ConvergedToRoundoff()  # (a stalled ‖F‖ that Newton cannot lower further)
        self.previous_fnorm = fnorm
        if not first and self._met_indefinite_preconditioner():
            self._leave_cg()
            self.left_cg = True  # reported in SolveStats.recoveries
        if self._wants_refresh(first, A):
            self._rebuild_preconditioner(A)
        if self.forcing is not None:
            rtol = self.forcing.tolerance(snes.getFunctionNorm(), None if first else self._remainder())
            snes.getKSP().setTolerances(rtol=rtol, atol=self.forcing.absolute)

    def _newton_jacobian(self, first):
        """The Γ_C Jacobian of this Newton step: j_n' (+ j_t' of the frozen bound); with friction, on the first
        step of a pass and after a step the line search cut, that Jacobian stiffened along the slip
        (:func:`~nc_dolfinx.physics.friction.slip_stiffening`), where the exact one lets slipping points run
        back through their stick zone. Elsewhere the exact one keeps Newton's convergence. Measured (Newton
        steps, cold / nested level, summed over benchmarks/family.py's nine 2D friction members at 128 cells):
        exact always 213 / 55, stiffened always 162 / 43 — but 47 instead of 18 on the 3D sheared layer in
        slip, where the stiffening held a uniform slip back —, only after a cut step 175 / 56, both (this
        rule) 161 / 44 and 17 on that layer."""
        if self.stiffened_jacobian is not None and (first or self.cut_steps > 0):
            return self.stiffened_jacobian
        return self.j_n_jacobian

    def _met_indefinite_preconditioner(self):
        """CG stopped on a preconditioner that is not positive definite. Rebuilding it from the same matrix
        rebuilds the same one: GAMG's coarse levels can hold rows with a vanishing diagonal (aggregates too
        small to carry the six rigid-body modes; seen on 3D meshes on 2 ranks, depending on the partition),
        where the Jacobi-Chebyshev smoother's eigenvalue estimate fails. CG then stopped after 2 iterations
        at every Newton step (50 steps for 1 % of ‖F‖ on manufactured3d, 2187 dofs)."""
        ksp = self.snes.getKSP()
        return (ksp.getType() == PETSc.KSP.Type.CG and ksp.getConvergedReason() in INDEFINITE
                and "ksp_type" not in self.user_keys)

    def _leave_cg(self):
        """GMRES instead of CG from here on in this solve: it needs no definite preconditioner (on an
        indefinite one, and in the stronger_pc fallback). Preconditioned on the right where CG stopped on
        the unpreconditioned residual (the iterative preset): GMRES has that norm on the right only, and a
        side set to LEFT explicitly (as the friction solver's consistent steps leave it) ended the fallback
        in PETSc's error 56 instead of a solve (3D friction, every time it was reached)."""
        ksp = self.snes.getKSP()
        if ksp.getType() == PETSc.KSP.Type.CG:
            if ksp.getNormType() == PETSc.KSP.NormType.UNPRECONDITIONED:  # (asked while CG: GMRES's left side raises)
                ksp.setPCSide(PETSc.PC.Side.RIGHT)
            ksp.setType(PETSc.KSP.Type.GMRES)

    def _first_krylov_tolerance(self, A):
        """Eisenstat–Walker's first tolerance (unless given): ew_rtol0_unsupported when J(u_0) holds no contact
        stiffness at all — the first step is then the unsupported body's response, which the line search
        cuts to a fraction (0.07–0.34 on the family's m_n > 1 members) — else the preset's."""
        self.first_jacobian = False
        if self.forcing is None or "snes_ksp_ew_rtol0" in self.user_keys:
            return
        unsupported = A.norm() == self.K.norm()  # (J(u_0) = K entry by entry, or an added contact term)
        # (reset on every solve: a solver may be solved again from a supported start)
        self.forcing.rtol0 = (float(self.options["ew_rtol0_unsupported"]) if unsupported
                              else self.forcing.params["rtol_0"])

    # --- solving -----------------------------------------------------------------------------------

    def _target(self, initial_norm):
        """‖F‖ <= max(snes_rtol ‖F(u_0)‖, atol_of_load ‖L‖) (or the given snes_atol): as an absolute
        tolerance, the same for every attempt of one load step (a retry starts from another ‖F‖)."""
        if not self.atol_given:
            self.atol = max(float(self.options["atol_of_load"]) * self.load.norm(), 1e-300)
        return max(self.atol, self.rtol * initial_norm)

    def _bilateral_predictor(self, x, y):
        """The first Newton step from a cold start (x = 0, m_n = 1), replaced by the step of the law with
        all of Γ_C in contact, c_n (u_n − g_0) without (·)_+, when that is the better guess (option
        bilateral_predictor, default true). Returns whether y was replaced.

        With a gap, J(0) = K sees no foundation: the first step is the unsupported body's response, which
        the line search stops where the first point touches; each later step then brings in a few more
        points (the 3D stiff penalty with a gap: 19 Newton steps, 10 preconditioner set-ups, 5.4x the
        linear floor). When that full step closes the gap everywhere on Γ_C, the body is likely to rest
        on all of it: then the bilateral step is solved (the preconditioner rebuilt from its Jacobian, as
        the next Newton step needs) and taken if the line search keeps all of it — the solution itself
        where the body does rest on all of Γ_C. Otherwise (a contact zone that the full step does not
        cover, as in Hertz's problem) nothing is done, and Newton runs exactly as without it. Without a
        gap the first step already is the bilateral one (see closed_jacobian)."""
        bilateral_jacobian, gap_load, separation = self.bilateral
        if bilateral_jacobian is None or not option_is_true(self.options["bilateral_predictor"]) or x.norm() > 0.0:
            return False
        x.copy(self.trial)
        self.trial.axpy(-1.0, y)
        self._update(self.trial)
        if self.comm.allreduce(fem.assemble_scalar(fem.form(separation)), op=MPI.SUM) > 0.0:
            return False
        rhs = fem_petsc.assemble_vector(fem.form(gap_load))  # ∫ c_n g_0 v_n
        rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        try:
            if rhs.norm() == 0.0:
                return False
            rhs.axpy(self.load_factor, self.load)
            self.zero_dirichlet_rows(rhs)
            step = self._bilateral_step(bilateral_jacobian, rhs)
            if not self._full_step_decreases(x, step):
                self.force_refresh = True  # P now holds the bilateral Jacobian
                return False
            step.copy(y)
            return True
        finally:
            rhs.destroy()

    def _bilateral_step(self, bilateral_jacobian, rhs):
        """The step y (x − y = 0 − y) of the bilateral law from 0: −(K + ∫ c_n du_n v_n)⁻¹ rhs, rhs = λL +
        ∫ c_n g_0 v_n, with SNES's KSP and the preconditioner rebuilt from that matrix (SNES assembles A
        again at the next step; P is kept if the step is taken). With preconditioner_matrix "bulk" P is K
        itself and stays so."""
        self._stiffness_plus(self.A, fem.form(bilateral_jacobian))
        if self.mode != "bulk":
            self._rebuild_preconditioner(self.A)
        ksp = self.snes.getKSP()
        ksp.setOperators(self.A, self.P)
        y = rhs.duplicate()
        tolerances = ksp.getTolerances()
        # The preset's first Eisenstat–Walker tolerance, relative to ‖F(0)‖ = ‖λL‖: c_n g_0 can dominate
        # rhs, and relative to it the step left ‖F‖ ≈ ‖F(0)‖ (8 Newton steps in all instead of 6).
        if self.forcing is not None:
            ratio = self.load_factor * self.load.norm() / rhs.norm()
            ksp.setTolerances(rtol=self.forcing.params["rtol_0"] * min(1.0, ratio))
        try:
            ksp.solve(rhs, y)
        finally:
            ksp.setTolerances(*tolerances)
        self.extra_krylov += ksp.getIterationNumber()  # (SNES counts its own solves only)
        y.scale(-1.0)
        self.zero_dirichlet_rows(y)  # the held dofs stay put
        return y

    def _full_step_decreases(self, x, y):
        """Whether the line search keeps all of the step y from x = 0 (y a descent direction of Π:
        φ'(0) = −F(0)·y = λLᵀy < 0). A shorter step means the guessed contact set was wrong (the
        foundation pulls the body down where it lifts off; on Hertz's problem λ = 0.06, and Newton from
        there needed 1.3–4x its Krylov iterations), so the step is dropped."""
        if not (math.isfinite(y.norm()) and self.load.dot(y) < 0.0):
            return False
        trial = y.copy()
        try:
            return not self._line_minimisation(x, trial)
        except _LineSearchFailure:
            return False
        finally:
            trial.destroy()

    def zero_dirichlet_rows(self, vector):
        """The Dirichlet entries of a step, or of a residual's part, set to zero (whatever u_D is)."""
        versions.set_dirichlet_rows(vector, self.bcs, 0.0)

    def impose_dirichlet_values(self, x):
        """x_D = λ u_D at the current load factor λ: the prescribed displacement ramps with the loads."""
        versions.set_dirichlet_rows(x, self.bcs, self.load_factor)

    def _snes_solve(self, x, stats, target):
        """SNES from x to ‖F‖ <= target, given as both atol and rtol ‖F(x)‖: then it never stops above the
        target (and Forcing never solves a linear system beyond half of it)."""
        self.impose_dirichlet_values(x)  # (the load continuation changes λ between solves)
        self._residual(self.snes, x, self.b)
        fnorm = self.b.norm()
        self.target = target  # (also when x already solves: the friction fixed point reads it)
        if fnorm <= target:  # (PETSc refuses rtol >= 1) an initial guess that already solves (7)
            stats.converged_reason = "CONVERGED_FNORM_ABS"
            return True
        self.snes.setTolerances(rtol=target / fnorm, atol=target)
        if self.forcing is not None:
            self.forcing.start(target)
        self.extra_krylov, self.predicted_full_step = 0, False
        self.target, self.previous_fnorm, self.cut_steps = target, math.inf, 0
        roundoff = False  # ended within the residual's round-off (see _within_roundoff)
        try:
            versions.solve_raising_callback_errors(self.snes, x)
            reason = self.snes.getConvergedReason()
        except _LineSearchFailure:  # x is still the iterate the line search started from
            reason = PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH
        except _ConvergedToRoundoff:  # x is the iterate whose residual was checked
            reason, roundoff = PETSc.SNES.ConvergedReason.CONVERGED_ITERATING, True
        except _Creeping:  # x is still the iterate the line search started from
            reason, self.crept = PETSc.SNES.ConvergedReason.DIVERGED_LINE_SEARCH, True
        if reason < 0 and self._residual_within_roundoff(x):
            roundoff = True  # the solve failed where Newton could not do better
        stats.newton_iterations += self.snes.getIterationNumber()
        stats.linear_iterations += self.snes.getLinearSolveIterations() + self.extra_krylov
        stats.converged_reason = "CONVERGED_ROUNDOFF" if roundoff else REASONS.get(reason, str(reason))
        return roundoff or reason > 0

    def _residual_within_roundoff(self, x):
        """F(x) and J(x) evaluated, then :meth:`_within_roundoff`."""
        self._residual(self.snes, x, self.b)
        self._stiffness_plus(self.A, self.j_n_jacobian)
        return self._within_roundoff(x, self.A)

    def _within_roundoff(self, x, A):
        """Whether the residual F = ``self.b`` at the iterate x, whose Jacobian is A, meets the target up to its
        own round-off: ‖(|F| − ν)_+‖ <= target, row by row, with
            ν_i = roundoff_factor ε (|J_ii| ‖x‖_∞ + λ |L_i|),   ε the machine epsilon.
        A row of F sums terms of the size of (|J| |x|)_i (the bulk: K's row times x; Γ_C: c_n (x_n − g_0)_+^{m_n},
        whose difference x_n − g_0 carries the round-off of x_n and g_0, both <= ‖x‖_∞ where the foundation
        is active, times the law's slope, in J_ii) and λ L_i; each is computed to ~ε of its size, and a row
        of J sums to a few times its diagonal. With a stiff foundation and a gap this floor lies far above the
        target 1e-10 ‖L‖: c_n = 1e8 E and g_0 = 0.01 on the unit square left ‖F‖ at 3e-12 against a target
        of 4e-13, where every Newton step only moved x by its round-off, and the solve failed after all
        fallbacks (c_n = 1e7 E converged). The excess over ν, not ‖F‖, must meet the target, so a residual
        above its round-off anywhere (in the bulk ν_i is ~10 ε K_ii ‖x‖_∞) still counts in full. The factor
        is the option ``roundoff_factor`` (0: off). Never where ‖F‖ > ROUNDOFF_MEANINGFUL ‖λL‖: an iterate
        that runs away without an equilibrium (a load beyond friction's limit) carries its round-off along."""
        if self.b.norm() > ROUNDOFF_MEANINGFUL * self.load_factor * self.load.norm():
            return False
        noise = A.getDiagonal()
        noise.abs()
        noise.scale(x.norm(PETSc.NormType.NORM_INFINITY))
        if self.load_abs is None:  # |L| (L is assembled once)
            self.load_abs = self.load.copy()
            self.load_abs.abs()
        noise.axpy(self.load_factor, self.load_abs)
        noise.scale(float(self.options["roundoff_factor"]) * np.finfo(float).eps)
        excess = np.maximum(np.abs(self.b.getArray(readonly=True)) - noise.getArray(readonly=True), 0.0)
        noise.destroy()
        return math.sqrt(self.comm.allreduce(float(excess @ excess), op=MPI.SUM)) <= self.target

    # Fallbacks after a failed SNES solve, in this order, each from the last good iterate. None costs
    # anything unless a solve fails.
    def _solve_load_step(self, x, stats, factor, loose=0.0, creeping_limit=0):
        """Solve at the current load factor from x (the previous step's solution); ``factor``: its
        increment; ``loose``: stop at this ‖F‖ if it is above the usual target; ``creeping_limit`` > 0: a
        solve whose line search cut that many steps in a row ends at once (``self.crept``, x the last
        iterate), without fallbacks (the friction fixed point's warm pass). Returns the fallbacks used."""
        self.impose_dirichlet_values(x)
        self._residual(self.snes, x, self.b)
        self.initial_norm = self.b.norm()
        target = max(self._target(self.initial_norm), loose)
        start = x.copy()
        used = []
        # (m_n = 1 only, where the bilateral forms exist: with m_n >= 2 the stages of the continuation took
        # 2-3 times the Newton steps of the creeping solve itself, 20-35 on the stiff members of extremes.py)
        self.crept = False
        self.creeping_check = option_is_true(self.options["fallbacks"]) and self.bilateral[0] is not None
        self.creeping_limit = float(self.options["creeping_steps"])
        if creeping_limit > 0:
            self.creeping_check, self.creeping_limit = True, creeping_limit
        try:
            self.bilateral_candidate = x.norm() == 0.0  # see _bilateral_predictor
            converged = self._snes_solve(x, stats, target)
            if self.crept and creeping_limit > 0:
                return used
            if converged or not option_is_true(self.options["fallbacks"]):
                if stats.converged_reason.startswith("CONVERGED"):
                    return used
                raise InputError(f"SNES diverged ({stats.converged_reason}) after {stats.newton_iterations} "
                                 "Newton iterations (fallbacks off); try -fallbacks true")
            retries = [("refresh", self._retry_refreshed), ("c_n_continuation", self._retry_c_n_continuation),
                       ("stronger_pc", self._retry_stronger)]
            if self.crept:  # (the contact zone crept: the continuation first)
                retries = [retries[1], retries[0], retries[2]]
            for name, retry in retries:
                used.append(name)
                if not np.all(np.isfinite(x.array)):
                    start.copy(x)
                if retry(x, stats, target, start):
                    return used
            used.append("continuation")
            if self._retry_continuation(x, stats, target, start, factor):
                return used
            if self._factorisation_error():
                raise InputError(self._factorisation_error())
            raise InputError(f"SNES diverged ({stats.converged_reason}) after {stats.newton_iterations} Newton "
                             f"iterations (fallbacks tried: {', '.join(used)}); try -snes_max_it, "
                             "--load-steps or a smaller c_n")
        finally:
            start.destroy()

    def solve(self, load_steps=1, tangent_from=None):
        """Solve from the current ``u`` (the initial guess), in ``load_steps`` increments of the loads.
        ``tangent_from``: the solver of the previous load state u = u_k (same mesh), whose preconditioner
        makes the tangent prediction of one increment first (:mod:`.predictor`)."""
        stats, start = SolveStats(), time.perf_counter()
        x = versions.petsc_vec(self.u).copy()  # (its Dirichlet dofs are set in each load step)
        self._reset_preconditioner_state()
        recoveries = []
        try:
            if tangent_from is not None and load_steps == 1 and same_layout(self, tangent_from):
                tangent_prediction(self, x, tangent_from, stats)
            for step in range(1, load_steps + 1):
                self.load_factor = step / load_steps
                if step > 1 and self.end_of_increment is not None:  # (the slip of this increment, not the last's)
                    self._update(x)
                    self.end_of_increment(self.u)
                try:
                    solve_increment = self._solve_load_step if self.forms.frozen is None else self._fixed_point
                    recoveries += solve_increment(x, stats, 1.0 / load_steps)
                except InputError as err:
                    where = f" in load step {step}/{load_steps}" if load_steps > 1 else ""
                    raise InputError(str(err).replace(" (fallbacks", where + " (fallbacks", 1)) from None
            self._update(x)
        finally:
            x.destroy()
        stats.time = time.perf_counter() - start
        stats.preconditioner_matrix = self.configured_mode  # (a fallback's mode is not carried to the next level)
        stats.preset = self.preset
        stats.pc_setups = self.pc_setups
        stats.pc_type = self.snes.getKSP().getPC().getType()
        stats.recoveries = ",".join((["gmres"] if self.left_cg else []) + recoveries)
        return stats

    def destroy(self):
        owned = [self.snes, self.A, self.K, self.b, self.contact, self.load, self.work, self.trial, self.predicted]
        owned += [self.P] if self.P is not self.K else []
        for obj in owned + ([self.load_abs] if self.load_abs is not None else []):
            obj.destroy()

