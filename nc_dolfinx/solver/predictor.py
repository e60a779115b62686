"""The tangent predictor of a load path's increment (``solver.predictor = "tangent"``, issue 48): one linear
solve with the last increment's Jacobian, before Newton.

At the start of an increment the solver of the new state holds its loads and Dirichlet values; the solver of
the last converged state u_k (``source``) still holds its preconditioner, built from a Jacobian of (7) near
u_k (its last refresh: with friction the frozen bound's SPD Jacobian, K + j_n' + j_t'). The prediction is

    x̃ = u_k with x_D = u_D of the new state,   Δ = P_k⁻¹ F(x̃),   u_pred = x̃ − Δ  (Δ_D = 0),

F the new state's residual (its lifted load λL carries the moved Dirichlet values into the free rows, and
with friction its law's memory is u_k, whose traction σ_t,prev the return map left as it was: F(u_k) is
the old residual at u_k but for the load increment). So Δ is the tangent response to the increment of
the loads and of the prescribed displacement, from the Jacobian of the converged state; with the direct
preset it costs one back-substitution with P_k's factorisation (no new set-up: P_k is left untouched, so
PETSc keeps its factorisation), with the iterative one a few CG iterations on P_k with its AMG hierarchy
(to TANGENT_RTOL). u_pred is kept if ‖F(u_pred)‖ < ‖F(x̃)‖ (one residual evaluation), else Newton starts
from x̃ as without a predictor. Only the initial guess changes: the law's memory stays u_k, and Newton
solves to the same tolerance.
"""
import math

# relative residual of the prediction's linear solve with an iterative preconditioner (the prediction's own
# error, the nonlinearity of the increment, is far above it); a factorisation solves it exactly in one step
TANGENT_RTOL = 1e-3
TANGENT_MAX_ITS = 200


def tangent_prediction(solver, x, source, stats):
    """Move x (u_k, the increment's initial guess) to the tangent prediction (see the module), with the
    preconditioner of ``source`` (the NonlinearSolver of u_k, on the same mesh). Records in ``stats``:
    ``predictor`` ("tangent", or "tangent refused" if the prediction did not lower ‖F‖) and its Krylov
    iterations in ``linear_iterations`` and ``predictor_its``."""
    solver.impose_dirichlet_values(x)
    frozen = solver.forms.frozen
    if frozen is not None:  # (the residual of x itself: the bound of x)
        solver._copy_into(x, frozen)
    solver._residual(solver.snes, x, solver.b)
    start = solver.b.norm()
    if start <= solver._target(start) or not math.isfinite(start):
        return
    ksp = source.snes.getKSP()
    step, trial = x.duplicate(), x.duplicate()
    try:
        ksp.setOperators(source.P, source.P)  # (P unchanged: its factorisation or AMG hierarchy is kept)
        ksp.setTolerances(rtol=TANGENT_RTOL, atol=0.0, max_it=TANGENT_MAX_ITS)
        ksp.solve(solver.b, step)
        its = ksp.getIterationNumber()
        stats.linear_iterations += its
        stats.predictor_its += its
        solver.zero_dirichlet_rows(step)
        x.copy(trial)
        trial.axpy(-1.0, step)
        if frozen is not None:
            solver._copy_into(trial, frozen)
        solver._residual(solver.snes, trial, solver.b)
        predicted = solver.b.norm()
        if math.isfinite(predicted) and predicted < start:
            trial.copy(x)
            stats.predictor = "tangent"
        else:
            stats.predictor = "tangent refused"
        solver._update(x)
    finally:
        step.destroy()
        trial.destroy()


def same_layout(solver, source):
    """Whether ``source``'s preconditioner was built from a Jacobian (a Newton step ran: not K's copy, nor K
    itself with preconditioner_matrix "bulk") and acts on ``solver``'s vectors (the same mesh and dofs)."""
    return (source is not None and source.pc_setups > 0 and source.u.function_space.mesh is solver.u.function_space.mesh
            and source.P.getSizes() == solver.K.getSizes())

