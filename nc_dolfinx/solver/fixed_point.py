"""With friction: each load increment solved by a fixed point on the friction bound
(:mod:`nc_dolfinx.physics.friction`), finished by Newton's method with the consistent Jacobian; a part of
:class:`~nc_dolfinx.solver.newton.NonlinearSolver`.

The consistent Newton method on the frictional residual alone cycles between stick and slip from a cold
start (on the sheared layer of tests/mpi/sheared_layer.py, with full steps ‖F‖ alternated between 6.2e-3 and
7.3e-3; with PETSc's line searches (bt on this law, cp and l2 on the smooth one) Newton converged at
ε_r = 0.1 in 40–61 steps, at ε_r = 1e-3 not at all): its Jacobian is not symmetric, so there is no energy
for a line search to decrease. So the increment is globalised by a fixed point: each pass freezes the bound
F(ū), ε(ū) at ū = x and solves the convex problem it leaves — the frictionless solver's own kind: SPD
Jacobian, energy line search, fallbacks — then sets ū = x. Its tail converges linearly (a factor ~0.13 a
pass on benchmarks/family.py), so once a pass has left the stick and slip zones near their final shape, the
increment is finished by Newton's method on the full residual, the bound of x itself: the consistent,
non-symmetric Jacobian K + j_n'(x) + (d/dx) j_t(x, ·), GMRES preconditioned by the passes' own
preconditioner (built from the frozen-bound Jacobian, which differs from the consistent one on Γ_C only).
A Newton step is kept only if it at least halves ‖F‖; else the passes go on from the last kept iterate.
"""
import math

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem

from ..errors import InputError
from .linear import option_is_true

# Each pass (a stage of the continuation too) solves to this fraction of the residual it starts from: the next
# pass changes the bound again, and Newton's basin is reached long before the bound's own fixed point.
FRICTION_PASS_REDUCTION = 0.1
# From a cold start the first pass (F̄ = 0) is the frictionless solve, after which every point of Γ_C lies far
# in slip: stages lower ε_r from EPSILON_START by EPSILON_REDUCTION a stage, bringing the stick zone in a
# stage at a time. Measured on benchmarks/family.py's 2D members at 64 cells, Newton steps of the cold solve
# of 1e4-1-mu0.3, 1e4-1-mu0.1, 100-2-mu0.3, 1-1-mu0.3, 1e4-1-mu1: no continuation diverged; from 10, stages
# to 1e-3 of their residual 60, 33, 20, 15, 36; from 100, to a tenth 39, 28, 19, 15, 32 (from 1000: 34, 29,
# 20, 16, 29; by factors of 100: 127, 59, 19, 12, 63).
EPSILON_START, EPSILON_REDUCTION = 100.0, 10.0
# A consistent Newton step is kept when it lowers ‖F‖ to this fraction at least (a step that does not is
# crossing between stick and slip, where the passes are safe and Newton is not; damped steps, kept when
# ‖F‖ fell by λ/2, left the passes a worse start: 55 Newton steps instead of 17 on the family's 1e4-1-mu0.3).
NEWTON_REDUCTION = 0.5
NEWTON_STEPS = 20
# GMRES's most iterations in a consistent step (a preconditioner that does not fit J: the passes do better)
NEWTON_KRYLOV_ITS = 200
# A factorisation P is rebuilt from the frozen bound's Jacobian at the iterate when the last step's GMRES
# needed more iterations than this: the stick and slip zones moved, and a set-up (a Cholesky factorisation:
# 0.11 s on the family's square at 128 cells; one of its solves 0.016 s) costs less than the iterations P no
# longer saves. The last increment of benchmarks/family.py's 1-1-mu0.1 (8 Newton steps): 79 GMRES
# iterations, 1 set-up, 10.5 x the linear floor without; 21, 3, 5.1 x with. Not with AMG, which needs more
# than 4 iterations anyway and whose set-up costs more against them (its 3D members: the same iterations,
# one more set-up, 0.9–1.0 -> 1.35–1.39 x).
NEWTON_REFRESH_ITS = 4
FACTORISATIONS = (PETSc.PC.Type.CHOLESKY, PETSc.PC.Type.LU)


class FrictionFixedPoint:
    """The fixed point on the friction bound and its consistent Newton finish (see the module)."""

    def _copy_into(self, x, function):
        """A Function of u's space set to the iterate x (ghosts included)."""
        self._update(x)
        function.x.array[:] = self.u.x.array

    def _fixed_point(self, x, stats, factor):
        """Solve the increment from x to the target of its residual F(x) (the bound of x itself): a warm start
        (a finer level, the next increment), whose stick zone is nearly right, by consistent Newton steps at
        once; then, and from a cold start after the stages in ε, passes with the bound of ū = x frozen, each
        followed by consistent Newton steps. A body settled onto the foundation (:mod:`.settling`, x ≠ 0) starts
        warm too: its settled bound F(x) > 0 already sticks along the motions only friction holds. With the
        continuation from there the blocks of tests/mpi/held_by_friction.py (2D, 3D; sheared up to 0.8 μP,
        twisted) took 19–39 Newton steps instead of 6–15, and on the 2D block's 'right' mesh the soft first
        stick spring let it slide away under a shear of μP/3 and 0.8 μP (SNES diverged).

        A load increment (x = u_prev: no slip yet) whose warm pass cuts ``friction_creeping_steps`` line
        search steps in a row is creeping: the stick/slip front moves a few points a step under stiff stick
        springs (the increment extended the slip zone under a stiff foundation). The stages of the cold start
        then take over from its last iterate. On the last increment of benchmarks/family.py's 1e4-1-mu0.1
        (128 cells) the passes at ε_r took 40 Newton steps, 472 Krylov iterations, 22 set-ups (12 cut steps
        in a row); with the stages 22, 108, 14. Where they took over from every warm start at once,
        creeping or not, the family's 3D increments took 14–15 Newton steps instead of 11; where they took
        over from creeping nested levels too, 1e4-1-mu0.3's took 23 instead of 10. Returns the fallbacks
        used."""
        used, limit = [], int(float(self.options["friction_passes"]))
        epsilon = float(self.forms.epsilon.value)
        stages = self._stages(epsilon) if x.norm() == 0.0 else []
        creeping_limit = int(float(self.options["friction_creeping_steps"])) if self._at_previous_state(x) else 0
        self._copy_into(x, self.forms.frozen)
        self.impose_dirichlet_values(x)
        self._residual(self.snes, x, self.b)
        self.target = target = self._target(self.b.norm())
        try:
            if not stages and self._finished(x, stats):
                return used
            for _ in range(limit):
                stage = stages.pop(0) if stages else None
                self.forms.epsilon.value = epsilon if stage is None else stage
                self._copy_into(x, self.forms.frozen)
                self._residual(self.snes, x, self.b)
                loose = FRICTION_PASS_REDUCTION * self.b.norm()
                # (a warm pass: P is the consistent steps' J(u_0), without the stiffening of its first step;
                # CG then needed 56 and 274 iterations on its first two steps on family.py's 1e4-1-mu0.1)
                self.force_refresh = self.force_refresh or creeping_limit > 0
                used += self._solve_load_step(x, stats, factor, loose, creeping_limit)
                stats.friction_passes += 1
                if self.crept and creeping_limit:
                    stages, creeping_limit = self._stages(epsilon), 0
                    self.force_refresh = True  # (P holds the stiff springs of ε_r, the first stage soft ones)
                    continue
                if stage is not None:
                    continue
                self._copy_into(x, self.forms.frozen)
                self._residual(self.snes, x, self.b)
                self.target = target
                if self._finished(x, stats):
                    return used
        finally:
            self.forms.epsilon.value = epsilon
        raise InputError(f"the fixed point on the friction bound did not converge in {limit} passes (‖F‖ = "
                         f"{self.b.norm():.3g} > {target:.3g}): the friction coefficient may be too large for "
                         "a unique solution; try smaller increments ([[steps]] increments, --load-steps) or "
                         "-friction_passes")

    def _at_previous_state(self, x):
        """Whether x is u_prev on every rank: the start of a load increment (not a cold start, nor a finer level's
        transferred solution)."""
        size = x.norm(PETSc.NormType.NORM_INFINITY)
        change = np.abs(x.getArray(readonly=True) - self.forms.previous.x.array[:x.getLocalSize()])
        return size > 0.0 and self.comm.allreduce(float(change.max(initial=0.0)), op=MPI.MAX) <= 1e-12 * size

    @staticmethod
    def _stages(epsilon):
        """The continuation's values of ε_r above ``epsilon``: EPSILON_START, EPSILON_START/EPSILON_REDUCTION, …"""
        stages = []
        while EPSILON_START / EPSILON_REDUCTION ** len(stages) > epsilon:
            stages.append(EPSILON_START / EPSILON_REDUCTION ** len(stages))
        return stages

    def _finished(self, x, stats):
        """Whether the residual F(x) in ``self.b`` meets the target, at once or after consistent Newton steps
        (its converged reason then in ``stats``)."""
        if self.b.norm() <= self.target:
            stats.converged_reason = "CONVERGED_FNORM_ABS"
            return True
        return self._consistent_newton(x, stats)

    def _ended_in_roundoff(self, x, stats):
        """Whether ‖F(x)‖ lies within its round-off (NonlinearSolver._within_roundoff); leaves F(x) in self.b."""
        if self._residual_within_roundoff(x):
            stats.converged_reason = "CONVERGED_ROUNDOFF"
            return True
        return False

    def _consistent_newton(self, x, stats):
        """Newton steps on the full residual F(x) (``self.b``, the bound of x frozen as x) with the consistent
        Jacobian, each kept if it lowers ‖F‖ to NEWTON_REDUCTION of the last; True when ‖F‖ meets the
        target or, once a step is refused, lies within its round-off. On return x is the last kept iterate,
        ``self.b`` its residual and ``forms.frozen`` x."""
        if not option_is_true(self.options["friction_newton"]):
            return self._ended_in_roundoff(x, stats)
        if isinstance(self.consistent, ufl.Form):  # (compiled once, when first needed)
            self.consistent = fem.form(self.consistent)
        if self.force_refresh and self.mode != "bulk":  # (no pass yet: P is not J(u_0) yet, see _jacobian)
            self._stiffness_plus(self.A, self.j_n_jacobian)
            self._rebuild_preconditioner(self.A)
        ksp = self.snes.getKSP()
        kind, tolerances, side, norm = ksp.getType(), ksp.getTolerances(), ksp.getPCSide(), ksp.getNormType()
        step, trial = x.duplicate(), x.duplicate()
        first_norm = fnorm = self.b.norm()
        its = 0  # GMRES's iterations in the last step
        try:
            # right preconditioning: GMRES then stops on ‖F + J y‖ itself, not on its preconditioned norm, which
            # a stiff foundation makes far smaller (the step stalled at 400 times the target)
            ksp.setType(PETSc.KSP.Type.GMRES)
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            self.A.setOption(PETSc.Mat.Option.SPD, False)
            for _ in range(NEWTON_STEPS):
                if its > NEWTON_REFRESH_ITS and self.mode != "bulk" and ksp.getPC().getType() in FACTORISATIONS:
                    self._stiffness_plus(self.A, self.j_n_jacobian)  # (P: symmetric, the frozen bound's)
                    self._rebuild_preconditioner(self.A)
                self._stiffness_plus(self.A, self.consistent)
                ksp.setOperators(self.A, self.P)
                # inexact Newton (superlinear: the forcing term falls with ‖F‖), never past half the target
                ksp.setTolerances(rtol=max(min(0.1, fnorm / first_norm), 0.5 * self.target / fnorm),
                                  atol=0.5 * self.target, max_it=NEWTON_KRYLOV_ITS)
                ksp.solve(self.b, step)
                its = ksp.getIterationNumber()
                stats.newton_iterations += 1
                stats.friction_newton += 1
                stats.linear_iterations += its
                x.copy(trial)
                trial.axpy(-1.0, step)
                self._copy_into(trial, self.forms.frozen)
                self._residual(self.snes, trial, self.b)
                trial_norm = self.b.norm()
                if not (math.isfinite(trial_norm) and trial_norm <= NEWTON_REDUCTION * fnorm):
                    self._copy_into(x, self.forms.frozen)
                    return self._ended_in_roundoff(x, stats)
                trial.copy(x)
                fnorm = trial_norm
                if fnorm <= self.target:
                    stats.converged_reason = "CONVERGED_FNORM_ABS"
                    return True
            return False
        finally:
            ksp.setPCSide(side)
            ksp.setNormType(norm)
            ksp.setType(kind)
            ksp.setTolerances(*tolerances)
            self.A.setOption(PETSc.Mat.Option.SPD, True)
            ksp.setOperators(self.A, self.P)
            step.destroy()
            trial.destroy()
