"""What the Newton driver does when a SNES solve of (7) fails, tried in turn before the run ends: the
preconditioner refreshed (with MUMPS's workspace widened if it ran out), continuation in c_n from a soft
foundation (first, when the contact zone creeps: 10 steps in a row cut by the line search), a stronger
preconditioner (P = J at every step, GMRES), then continuation in the load. Each is a method of
:class:`Recoveries`, a part of :class:`~nc_dolfinx.solver.newton.NonlinearSolver` that works on its state.
"""
from petsc4py import PETSc

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from .linear import OWN_DEFAULTS
from .petsc_options import set_petsc_options

# MUMPS's INFOG(1) when an internal array sized from the analysis's estimate is too small (-9, the main
# workspace S, is the one seen here); for each, MUMPS's user guide advises a larger ICNTL(14).
MUMPS_WORKSPACE_ERRORS = (-8, -9, -11, -12, -14, -17, -20)
# The c_n continuation (a fallback, see _retry_c_n_continuation): the first stage's foundation against the
# body's stiffness, and the factor from one stage to the next.
C_N_SOFT = 0.03
C_N_CONTINUATION_FACTOR = 100.0


class Recoveries:
    """The recovery strategies of :class:`~nc_dolfinx.solver.newton.NonlinearSolver` (see the module)."""

    def _retry_refreshed(self, x, stats, target, start):
        """Rebuild P from J at the current iterate (a stale P is the cheap cause of a stall); if MUMPS ran
        out of workspace, with a larger one."""
        self._widen_mumps_workspace()
        self.force_refresh = True
        return self._snes_solve(x, stats, target)

    def _widen_mumps_workspace(self):
        """After a MUMPS factorisation stopped for lack of workspace, four times the margin MUMPS adds to its
        estimate (ICNTL(14), in percent; default 20) for the next one. Seen on 3 ranks: the Cholesky
        factorisation of a nested 3D level (6,591 dofs, tests/mpi/nested_level_3d.py) failed with INFOG(1)
        = -9 at the first Newton step (KSP: DIVERGED_PC_FAILED), and every fallback failed the same way;
        with ICNTL(14) = 50 it runs."""
        pc = self.snes.getKSP().getPC()
        if pc.getType() not in ("cholesky", "lu") or pc.getFactorSolverType() != "mumps":
            return
        factor = pc.getFactorMatrix()
        if factor.getMumpsInfog(1) in MUMPS_WORKSPACE_ERRORS:
            # an option, since MUMPS reads its controls anew when the factorisation is set up again
            self.options["mat_mumps_icntl_14"] = 4 * max(factor.getMumpsIcntl(14), 20)
            set_petsc_options({k: v for k, v in self.options.items() if k not in OWN_DEFAULTS})
            pc.reset()

    def _factorisation_error(self):
        """What MUMPS said if the last factorisation failed (INFOG(1) < 0), else None: the same on every
        rank. A failure that the workspace cannot mend (e.g. -38 when ``-mat_mumps_icntl_28 2`` asks for a
        parallel ordering that Debian's MUMPS is built without) makes every fallback fail the same way, and
        is then what the user needs to read, not Newton's divergence."""
        pc = self.snes.getKSP().getPC()
        if pc.getType() not in ("cholesky", "lu") or pc.getFactorSolverType() != "mumps":
            return None
        infog = pc.getFactorMatrix().getMumpsInfog(1)
        if infog >= 0 or infog in MUMPS_WORKSPACE_ERRORS:
            return None
        return (f"the MUMPS factorisation failed with INFOG(1) = {infog} (MUMPS's user guide, §"
                "'Error diagnostics'); check the -mat_mumps_* options, or use --set solver.preset=iterative")

    def _retry_stronger(self, x, stats, target, start):
        """P = J at every Newton step and GMRES instead of CG (robust to a PC that is not SPD, as seen
        with CG + GAMG on a 3D penalty problem)."""
        self.mode, self.force_refresh = "jacobian", True
        self._leave_cg()
        return self._snes_solve(x, stats, target)

    def _retry_c_n_continuation(self, x, stats, target, start):
        """Continuation in c_n from the initial guess: the law with s·c_n, s from a soft foundation up by
        C_N_CONTINUATION_FACTOR per stage, each stage solved from the last, then c_n itself. A stiff foundation
        and a contact zone that the first step does not cover (a cantilever sagging onto it: its tip
        touches first) make Newton's line search stop each step where the next points touch; with c_n/E =
        1e9 the zone grew by a few nodes a step and every other fallback failed (177–242 Newton steps, a
        10 × 1 cantilever; `benchmarks/extremes.py`). On a soft foundation the zone settles in a few steps,
        and each stiffer stage starts from nearly its own contact zone (the same cantilever: 9 creeping steps,
        then 5 stages and c_n itself in 34 Newton steps). The stages' forms (c_n times a Constant) are
        compiled on the first use. Skipped where c_n is soft already (s would be >= 1)."""
        scale = fem.Constant(self.u.function_space.mesh, PETSc.ScalarType(1.0))
        s = self._soft_c_n_scale()
        if s >= 1.0:
            return False
        original = {name: getattr(self, name) for name in self.CONTACT_FORMS}
        self._use_contact_forms(self.forms.with_c_n_scale(scale))
        start.copy(x)
        self.creeping_check = False  # (each stage runs to its end)
        try:
            while s < 1.0:
                scale.value = s
                self.force_refresh, self.bilateral_candidate = True, x.norm() == 0.0
                if not self._snes_solve(x, stats, target):
                    return False
                s *= C_N_CONTINUATION_FACTOR
        finally:
            for name, forms in original.items():
                setattr(self, name, forms)
        self.force_refresh = True
        return self._snes_solve(x, stats, target)

    def _soft_c_n_scale(self):
        """The scale s of the first stage of the c_n continuation: s·c_n against the body's stiffness,
        max_i (s C_ii / K_ii) with C = ∫_Γ_C c_n du_n v_n, equal to C_N_SOFT (on the cantilever of
        _retry_c_n_continuation s·c_n = 2.5 E; cold solves there took 6 Newton steps with c_n = E, 9 with
        10 E, 24 with 1e3 E)."""
        C = fem_petsc.assemble_matrix(fem.form(self.forms.c_n_mass))  # (Γ_C's pattern only: no bcs)
        C.assemble()
        c, k = C.getDiagonal(), self.K.getDiagonal()
        c.pointwiseDivide(c, k)
        self.zero_dirichlet_rows(c)  # (the held dofs: zero)
        ratio = c.max()[1]
        for obj in (C, c, k):
            obj.destroy()
        return C_N_SOFT / ratio if ratio > 0.0 else 1.0

    def _retry_continuation(self, x, stats, target, start, factor):
        """Load continuation from the initial guess: increments of the load factor, halved on failure."""
        start.copy(x)
        last = x.copy()  # the last converged increment
        done, step, final = self.load_factor - factor, factor / 4, self.load_factor
        try:
            while done < final - 1e-12:
                self.load_factor = min(done + step, final)
                if self._snes_solve(x, stats, target * self.load_factor / final):
                    done = self.load_factor
                    x.copy(last)
                elif step < factor / 64:
                    return False
                else:
                    last.copy(x)
                    step /= 2
            return True
        finally:
            self.load_factor = final
            last.destroy()
