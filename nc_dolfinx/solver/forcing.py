"""Inexact Newton's forcing terms: how accurately each linear system of (7) is solved (Eisenstat–Walker)."""


class Forcing:
    """The Krylov tolerance η_k of each Newton step (inexact Newton: ‖F_k + J_k y‖ <= η_k ‖F_k‖), in place of
    PETSc's own Eisenstat–Walker code and with its parameters (``-snes_ksp_ew_version``, ``_rtol0``,
    ``_rtolmax``, ``_gamma``, ``_alpha``, ``_alpha2``, ``_threshold``), plus two rules that read the
    *remainder* of the last step, ρ = ‖F_k − (F_{k−1} − J_{k−1} y)‖: what its linear model did not
    predict (known when the step was taken in full):

    - Finish: if Newton's quadratic convergence from there, ρ (‖F_k‖/‖F_{k−1}‖)², leaves the next step's
      remainder below half the target, the next system is solved to half the target, and that step ends
      the solve. Where the law is linear across the steps (m_n = 1 with a settled contact set) ρ ≈ 0:
      2 Newton steps instead of 4–5 on the family's m_n = 1 members; on the others the last step no longer
      stops just above the target (seen: 1.6e-12 against 2e-13, one more Newton step).
    - Otherwise η_k <= ρ/‖F_{k−1}‖ (Eisenstat–Walker's choice 1): no looser than the last step's
      nonlinearity warrants.

    No system is solved beyond half the target (the Krylov solve's absolute tolerance, in the true residual
    the iterative preset measures): version 3's guard against oversolving, aimed below the target."""

    def __init__(self, params):
        self.params = params  # SNES.getParamsEW()
        self.rtol0, self.target, self.last = params["rtol_0"], 0.0, None

    def start(self, target):
        """A new SNES solve towards ‖F‖ <= target."""
        self.target, self.last = target, None

    @property
    def absolute(self):
        """The Krylov solve's absolute tolerance: half the Newton target."""
        return 0.5 * self.target

    def tolerance(self, fnorm, remainder=None):
        """η_k for the step from an iterate with ‖F‖ = ``fnorm``; ``remainder``: ρ of the step that led
        there, if it was taken in full (else None)."""
        p = self.params
        if self.last is None:
            eta = self.rtol0
        else:
            f_prev, eta_prev = self.last
            eta = self._eisenstat_walker(fnorm, f_prev, eta_prev, remainder)
            if remainder is not None:
                if remainder * (fnorm / f_prev) ** 2 <= self.absolute:
                    eta = 0.0  # the absolute tolerance decides
                eta = min(eta, remainder / f_prev)
        eta = min(eta, p["rtol_max"])
        self.last = (fnorm, eta)
        return eta

    def _eisenstat_walker(self, fnorm, f_prev, eta_prev, remainder):
        """PETSc's versions 1–3 (SNESKSPSetParametersEW), version 3 without its oversolving guard."""
        p = self.params
        if p["version"] == 1:
            if remainder is None:
                return eta_prev
            eta, guard = remainder / f_prev, eta_prev ** p["alpha2"]
        else:
            eta, guard = p["gamma"] * (fnorm / f_prev) ** p["alpha"], p["gamma"] * eta_prev ** p["alpha"]
            if p["version"] == 3:
                return min(self.rtol0, max(eta, guard))
        return max(eta, guard) if guard > p["threshold"] else eta
