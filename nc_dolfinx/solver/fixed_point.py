"""With friction: each load increment solved by a fixed point on the friction bound
(:mod:`nc_dolfinx.physics.friction`), a part of :class:`~nc_dolfinx.solver.newton.NonlinearSolver`.

The consistent Newton method on the frictional residual cycles between stick and slip from a cold start
(on the sheared layer of tests/mpi/sheared_layer.py, with full steps ‖F‖ alternated between 6.2e-3 and
7.3e-3; with PETSc's line searches (bt on this law, cp and l2 on the smooth one) Newton converged at
ε_r = 0.1 in 40–61 steps, at ε_r = 1e-3 not at all). So each pass freezes the bound F(ū), ε(ū) at ū = x and solves
the convex problem it leaves — the frictionless solver's own kind: SPD Jacobian, energy line search,
fallbacks — then sets ū = x, until the residual with x's own bound meets the target.
"""
from ..errors import InputError

# Each pass but the last solves to this fraction of the residual the previous pass left: the next pass changes
# the bound again, so more would be wasted.
FRICTION_PASS_REDUCTION = 0.1
# From a cold start the first pass (F̄ = 0) is the frictionless solve, after which every point of Γ_C lies far
# in slip: the passes lower ε_r from EPSILON_START by EPSILON_REDUCTION a pass, bringing the stick zone in a
# stage at a time (the layer stretched by its clamp: 32 Newton steps instead of 53).
EPSILON_START, EPSILON_REDUCTION = 10.0, 10.0


class FrictionFixedPoint:
    """The fixed point on the friction bound (see the module)."""

    def _copy_into(self, x, function):
        """A Function of u's space set to the iterate x (ghosts included)."""
        self._update(x)
        function.x.array[:] = self.u.x.array

    def _fixed_point(self, x, stats, factor):
        """Solve the increment from x: passes with the bound of ū = x frozen until the residual with x's own
        bound meets the first pass's target (or lies within its round-off). A warm start (a finer level, the
        next increment) keeps its stick zone: no continuation in ε. Nor does a body settled onto the foundation
        (:mod:`.settling`, x ≠ 0): its first pass already has the settled bound F(x) > 0, sticking along the
        motions only friction holds. With the continuation from there the blocks of tests/mpi/held_by_friction.py
        (2D, 3D; sheared up to 0.8 μP, twisted) took 19–39 Newton steps instead of 6–15, and on the 2D block's
        'right' mesh the soft first stick spring (ε = 10 ε_r (u_n − g_0)_+) let it slide away under a shear of
        μP/3 and 0.8 μP (SNES diverged). Returns the fallbacks used."""
        used, limit, loose, target = [], int(float(self.options["friction_passes"])), 0.0, None
        epsilon = float(self.forms.epsilon.value)
        regularisation = max(epsilon, EPSILON_START) if x.norm() == 0.0 else epsilon
        try:
            for passes in range(1, limit + 1):
                self._copy_into(x, self.forms.frozen)
                self.forms.epsilon.value = regularisation
                used += self._solve_load_step(x, stats, factor, loose)
                target = self._target(self.initial_norm) if target is None else target
                self._copy_into(x, self.forms.frozen)
                stats.friction_passes += 1
                if regularisation > epsilon:  # a stage of the continuation
                    regularisation = max(epsilon, regularisation / EPSILON_REDUCTION)
                    continue
                self._residual(self.snes, x, self.b)
                self.target = target
                if self.b.norm() <= target or self._residual_within_roundoff(x):
                    return used
                loose = FRICTION_PASS_REDUCTION * self.b.norm()
        finally:
            self.forms.epsilon.value = epsilon
        raise InputError(f"the fixed point on the friction bound did not converge in {limit} passes (‖F‖ = "
                         f"{self.b.norm():.3g} > {target:.3g}): the friction coefficient may be too large for "
                         "a unique solution; try smaller increments ([[steps]] increments, --load-steps) or "
                         "-friction_passes")
