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

import ufl
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
        stick spring let it slide away under a shear of μP/3 and 0.8 μP (SNES diverged). Returns the fallbacks
        used."""
        used, limit = [], int(float(self.options["friction_passes"]))
        epsilon = float(self.forms.epsilon.value)
        stages = self._stages(epsilon) if x.norm() == 0.0 else []
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
                used += self._solve_load_step(x, stats, factor, loose)
                stats.friction_passes += 1
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
        try:
            # right preconditioning: GMRES then stops on ‖F + J y‖ itself, not on its preconditioned norm, which
            # a stiff foundation makes far smaller (the step stalled at 400 times the target)
            ksp.setType(PETSc.KSP.Type.GMRES)
            ksp.setPCSide(PETSc.PC.Side.RIGHT)
            ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
            self.A.setOption(PETSc.Mat.Option.SPD, False)
            for _ in range(NEWTON_STEPS):
                self._stiffness_plus(self.A, self.consistent)
                ksp.setOperators(self.A, self.P)
                # inexact Newton (superlinear: the forcing term falls with ‖F‖), never past half the target
                ksp.setTolerances(rtol=max(min(0.1, fnorm / first_norm), 0.5 * self.target / fnorm),
                                  atol=0.5 * self.target, max_it=NEWTON_KRYLOV_ITS)
                ksp.solve(self.b, step)
                stats.newton_iterations += 1
                stats.friction_newton += 1
                stats.linear_iterations += ksp.getIterationNumber()
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
