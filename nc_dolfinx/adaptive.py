"""SOLVE on one mesh, and the SOLVE → ESTIMATE → MARK → REFINE loop.

:func:`solve` binds a problem to a mesh and solves (7) with the nonlinear solver. :func:`run` repeats
it over levels: each level starts from the previous level's solution transferred to the refined mesh
(nested iteration; level 0 starts from zero, with load stepping if asked), evaluates the estimator of
Definition 5, records a history row, calls ``on_level`` and refines every cell (``uniform``) or the cells
marked by Dörfler's bulk criterion or the maximum strategy (``adaptive``). It stops at the level count,
the dof budget or the tolerance on η (absolute, or relative to η on level 0), whichever comes first, and
says which (``stop_reason``).
"""
import logging
import math
import time
from dataclasses import dataclass, field, fields as dataclass_fields
from functools import partial

from mpi4py import MPI

from dolfinx import fem

from . import dolfinx_versions as versions
from .estimator import indicators, marking
from .mesh import refinement, shape
from .mesh.balance import imbalance
from .output.columns import Row
from .physics import forms, quantities, slip_state
from .physics.binding import bind
from .problem import schema
from .errors import InputError
from .solver import NonlinearSolver, SolveStats, solver_options
from .solver.settling import settle

log = logging.getLogger("nc_dolfinx")


@dataclass
class Solution:
    """The discrete solution u_h of (7) on one mesh, the problem's fields there, and how it was solved."""
    u: fem.Function
    fields: object
    stats: SolveStats

    @property
    def domain(self):
        """The :class:`Domain` (mesh) of the solution."""
        return self.fields.domain


def solve(problem, domain, initial=None, petsc_options=None, load_steps=None, preconditioner_matrix=None,
          previous_state=None):
    """Solve (7) for ``problem`` on ``domain``.

    ``initial``: a P1 displacement on this mesh or on its parent mesh (transferred exactly), the Newton
    initial guess (default: zero). ``previous_state``: with friction, the previous load state (on this mesh
    or its parent), a :class:`~nc_dolfinx.physics.slip_state.SlipState` (as :func:`adapt` carries it: the
    displacement from which the slip increment Δu_t is measured and the tangential traction there) or a
    displacement alone (no traction); default: the unloaded body. With ``load_steps`` > 1 each
    increment moves it on. ``petsc_options``: PETSc options (no dash) over the problem's
    ``[solver] petsc_options``. ``load_steps``, ``preconditioner_matrix``: over the problem's [solver].
    Raises InputError if SNES does not converge.
    """
    return _solve_with(problem, domain, initial, petsc_options, load_steps, preconditioner_matrix, previous_state)[0]


def _solve_with(problem, domain, initial=None, petsc_options=None, load_steps=None, preconditioner_matrix=None,
                previous_state=None, tangent_from=None, keep_solver=False):
    """:func:`solve`, and (the tangent predictor of a load path) from ``tangent_from``, the kept solver of the
    previous state (``initial``) on this mesh; ``keep_solver``: the solver is returned alive, for the next
    increment's prediction (the caller destroys it), else destroyed. Returns (Solution, solver or None)."""
    settings = problem.values["solver"]
    fields = bind(problem, domain)
    V = versions.p1_space(domain.mesh, (domain.mesh.geometry.dim,))
    if initial is None:
        u = fem.Function(V)
    else:
        u = _on_mesh(initial, V)
    u.name = "displacement"
    if fields.friction is not None and previous_state is not None:
        state = previous_state if isinstance(previous_state, slip_state.SlipState) else \
            slip_state.SlipState(previous_state, None)
        fields.friction.previous.x.array[:] = _on_mesh(state.displacement, V).x.array
        if state.traction is not None:
            fields.friction.previous_traction.x.array[:] = _on_mesh(state.traction, V).x.array
    steps = load_steps or settings["load_steps"]
    if initial is None and fields.free_motions is not None:  # held by the foundation alone along them
        if fields.friction is not None:  # and by its friction along the sliding ones: stuck where it was
            u.x.array[:] = fields.friction.previous.x.array
        settle(u, fields, 1.0 / steps)
    options = solver_options(settings["preset"], settings["petsc_options"], petsc_options)
    solver = NonlinearSolver(forms.normal_compliance_forms(u, fields), u, fields.boundary_conditions(V),
                             options, preconditioner_matrix or settings["preconditioner_matrix"],
                             None if fields.friction is None else partial(slip_state.advance, fields=fields))
    try:
        stats = solver.solve(steps, tangent_from=tangent_from)
    except BaseException:
        solver.destroy()
        raise
    if not keep_solver:
        solver.destroy()
    return Solution(u, fields, stats), solver if keep_solver else None


def _on_mesh(function, V):
    """A P1 displacement on V's mesh or on its parent mesh, as a Function of V (transferred exactly)."""
    if function.function_space.mesh is V.mesh:
        copy = fem.Function(V)
        copy.x.array[:] = function.x.array
        return copy
    return refinement.transfer(function, V)


@dataclass(frozen=True)
class AdaptSettings:
    """How :func:`adapt` refines and when it stops (the problem's [adapt], see :meth:`from_problem`):
    ``refine`` none | uniform | adaptive; ``levels`` the number of solves; ``theta`` and ``marking`` the
    parameter and strategy of :func:`mark` (Dörfler's bulk criterion or the maximum strategy on the η_K
    of Definition 5); ``max_dofs``, ``tol`` (η ≤ tol) and ``rtol`` (η ≤ rtol·η of level 0) stop earlier."""
    refine: str = "none"        # none | uniform | adaptive
    levels: int = 1
    theta: float = 0.5
    marking: str = "doerfler"   # doerfler | maximum
    max_dofs: int = None
    tol: float = None           # stop when η <= tol
    rtol: float = None          # stop when η <= rtol * η(level 0)

    RELEVANT = {"none": (), "uniform": ("levels", "max_dofs", "tol", "rtol"),
                "adaptive": ("levels", "max_dofs", "tol", "rtol", "theta", "marking")}

    def __post_init__(self):
        for item in dataclass_fields(self):
            value = getattr(self, item.name)
            if value is not None:
                schema.convert(f"adapt.{item.name}", value, item.name)

    @classmethod
    def from_problem(cls, problem, **explicit):
        """The problem's [adapt] values, overridden by ``explicit`` ones (command line or API; None = not
        given). An explicit setting that has no effect in the resulting mode (``theta`` with uniform
        refinement, ``levels`` without refinement, one level of adaptive refinement) is refused; so is a
        problem file that contradicts itself. File values that do not apply to a mode chosen explicitly
        are ignored."""
        explicit = {k: v for k, v in explicit.items() if v is not None}
        unknown = set(explicit) - {f.name for f in dataclass_fields(cls)}
        if unknown:
            raise TypeError(f"unknown adapt setting(s) {sorted(unknown)}")
        file = problem.values["adapt"]
        file_given = {k.split(".", 1)[1] for k in problem.given if k.startswith("adapt.")}
        refine = schema.convert("adapt.refine", explicit.get("refine", file["refine"]), "refine")
        values = {"refine": refine}
        for name in ("levels", "theta", "marking", "max_dofs", "tol", "rtol"):
            relevant = name in cls.RELEVANT[refine]
            if name in explicit:
                if not relevant:
                    raise InputError(f"{name} has no effect with refine = '{refine}'")
                values[name] = schema.convert(f"adapt.{name}", explicit[name], name)
            elif name in file_given and relevant:
                values[name] = file[name]
            elif name in file_given and "refine" not in explicit:
                raise InputError(f"adapt.{name} has no effect with adapt.refine = '{refine}'")
        if refine == "none":
            values["levels"] = 1
        else:
            values.setdefault("levels", file["levels"])
            if values["levels"] < 2:
                raise InputError(f"refine = '{refine}' with {values['levels']} level refines nothing: "
                                 "give levels >= 2 or refine = 'none'")
        return cls(**values)


@dataclass
class Level:
    """What one level of :func:`adapt` leaves behind; ``on_level`` receives it (the last one is the final
    solution): the level's ``number``, its :class:`Solution` of (7), its :class:`Estimate` (Definition 5),
    the history ``row`` (dofs, η_1 … η_4, η, ζ, Newton iterations, :func:`solution_quantities`, errors),
    the ``marked`` cells and, on the last level, the ``stop_reason``."""
    number: int
    solution: Solution
    estimate: indicators.Estimate
    row: dict = field(default_factory=dict)
    marked: object = None          # local indices of the owned cells to refine (adaptive), else None
    stop_reason: str = None        # set on the last level (of each step): levels | max_dofs | tol | rtol
    last_of_state: bool = True     # no finer level of the same load state follows

    @property
    def u(self):
        """The level's displacement u_h."""
        return self.solution.u

    @property
    def fields(self):
        """The level's :class:`Fields`."""
        return self.solution.fields


@dataclass
class Result:
    """What :func:`adapt` returns: the ``history`` rows of every level (dofs, the estimator of
    Definition 5, quantities, errors, times) and the ``final`` :class:`Level`."""
    history: list
    final: Level

    @property
    def stop_reason(self):
        """Why the loop stopped: levels | max_dofs | tol | rtol."""
        return self.final.stop_reason


def adapt(problem, settings=None, domain=None, comm=None, petsc_options=None, on_level=None, **overrides):
    """Run SOLVE → ESTIMATE → MARK → REFINE: solve (7), evaluate the estimator of Definition 5, mark
    (:func:`mark`) and refine (:func:`refine`), each level starting Newton from the previous level's
    solution (nested iteration). Returns a :class:`Result`.

    A problem with a load path ([[steps]], :meth:`Problem.load_path`) solves each increment of each step
    from the previous state on the current mesh, and refines per ``settings`` after each step's last
    increment; the mesh only grows along the path (a state moves to a refined mesh exactly, see
    :func:`refine`). History rows then carry the ``step``, its ``increment`` and the path's ``load_time``.
    Each increment starts Newton from a prediction of its end state (``solver.predictor``: secant, tangent,
    none, or auto, per law and dimension: see _Loop); a step
    with ``increments = "auto"`` sizes its own increments, cutting in two those that fail or need more than
    ``solver.increment_newton_target`` Newton steps (rows: ``increment_cuts``, ``cut_reason``; see _Loop).

    ``settings``: AdaptSettings (default: the problem's [adapt], with ``overrides`` such as ``levels=3,
    refine="uniform"``: :meth:`AdaptSettings.from_problem`'s); ``domain``: the level-0 mesh (default:
    built from the problem's [mesh] on ``comm``, COMM_WORLD by default); ``on_level(level)`` is called
    after each level (before refinement). Progress goes to the ``nc_dolfinx`` logger (INFO, rank 0).
    """
    if settings is not None and overrides:
        raise TypeError(f"adapt: give settings or {', '.join(sorted(overrides))}, not both")
    settings = settings or AdaptSettings.from_problem(problem, **overrides)
    if problem.values["steps"] and problem.values["solver"]["load_steps"] != 1:  # (the command line says so first)
        raise InputError(f"solver.load_steps = {problem.values['solver']['load_steps']} splits the loads of a single "
                         "solve, and this problem is a load path: give its steps more increments instead "
                         "([[steps]].increments, e.g. increments = 3)")
    t0 = time.perf_counter()
    if domain is None:
        from .physics.binding import build_domain
        domain = build_domain(problem, comm or MPI.COMM_WORLD)
    loop = _Loop(settings, petsc_options, on_level, {"mesh": time.perf_counter() - t0})
    loop.path_parameters = list(dict.fromkeys(name for step in problem.values["steps"] for name in step["set"]))
    states = problem.load_path()
    state = next(states)
    try:
        for following in (*states, None):
            domain, level = loop.step(state, domain)
            if following is None:
                return Result(loop.history, level)
            state = following
    finally:
        loop.release_solvers()


class _Loop:
    """The levels of :func:`adapt`, step after step of a load path: what runs on from one to the next
    (the history, the last solution, the times of the refinement that made the mesh).

    **The predictor** (``solver.predictor``, default ``"auto"``: AUTO_PREDICTOR's choice for the law, with
    friction or without, and the dimension, from benchmarks/load_cycle.py). Each increment of a path starts
    Newton from a prediction of its end state. ``"secant"``: where the parameters move on along the line of
    the last increment, Δp_k+1 = α Δp_k with α > 0 (within a step: α = (t_k+1 − t_k)/(t_k − t_k−1)), the
    secant extrapolation u_k + α (u_k − u_k−1) of the last two converged states (on the same mesh);
    elsewhere (the first two solves, a turn of the path, a new mesh) the previous state u_k. ``"tangent"``:
    from the second solve on, on the same mesh, u_k plus the tangent response to the increment's loads and
    Dirichlet values, one linear solve with the preconditioner of u_k's solver
    (:mod:`nc_dolfinx.solver.predictor`; that solver is kept alive until the next state is accepted, a cut
    increment's is discarded, and after a solve that needed no Newton step, which built no preconditioner,
    the one before is kept). ``"none"``: u_k. Only the initial guess changes: the solver imposes the
    Dirichlet values itself, and the friction law's memory (``state_start``: u_prev and σ_t,prev) is the
    last converged state, whatever the guess. A solve from a prediction that fails is
    solved again from u_k before anything else is done.

    **Self-sizing increments** (a step's ``increments = "auto"``, :meth:`_auto_step`): the step is tried
    whole; an increment whose solve fails (InputError) or needs more than ``solver.increment_newton_target``
    Newton steps is discarded and solved again from the last converged state (u_k and the law's memory)
    in two halves, down to the step over 2^``solver.max_increment_cuts`` (where a failure is the error);
    an increment that needs at most half of the target lets the next double, never beyond the step's end.
    Rows of an auto step carry ``increment_cuts`` (how many halvings preceded the increment),
    ``cut_reason`` (why, "" if none) and ``time_cut`` (the time of the discarded solves). A step with a
    number of increments is solved exactly in them, as before (a failure is an error, never cut)."""

    def __init__(self, settings, petsc_options, on_level, times):
        self.settings, self.petsc_options, self.on_level, self.times = settings, petsc_options, on_level, times
        self.history, self.previous = [], None
        self.state_start = None  # with friction: u at the previous load state, on the current mesh
        self.path_parameters = []  # the parameters [[steps]] set: a column param_NAME each
        # the secant predictor's two last converged states: (u, parameters), the last first
        self.converged = []
        # the tangent predictor's solvers: that of self.previous (kept alive for its preconditioner), and that of
        # the last solve until it is accepted (discarded with a cut increment)
        self.kept_solver, self.pending_solver = None, None

    def step(self, state, domain):
        """Solve one state (a step with ``increments = "auto"``: every increment of it); after a step's last
        increment, go on adaptively per the settings. Returns the mesh the next state starts on and the
        last :class:`Level` (``stop_reason`` set at a step's end)."""
        if state.auto and state.fraction is None:
            return self._auto_step(state, domain)
        solution = self._solve(state, domain)
        return self._levels(state, domain, solution)

    def _guess(self, state, domain):
        """The Newton initial guess of ``state`` and the solver the tangent predictor starts from (or None): the
        secant prediction, or the previous state, with that state's solver for the tangent one (see the class)."""
        predictor = predictor_of(state.problem, domain.mesh.geometry.dim)
        if predictor == "tangent":
            kept = self.kept_solver
            usable = kept is not None and kept.u.function_space.mesh is domain.mesh is self.previous.function_space.mesh
            return self.previous, kept if usable else None
        return self._secant_guess(state, predictor), None

    def _secant_guess(self, state, predictor):
        if predictor == "none" or len(self.converged) < 2:
            return self.previous
        (u_k, p_k), (u_before, p_before) = self.converged
        if u_k is not self.previous or u_k.function_space.mesh is not u_before.function_space.mesh:
            return self.previous
        alpha = secant_ratio(p_before, p_k, state.problem.parameters)
        if alpha is None:
            return self.previous
        guess = fem.Function(u_k.function_space)
        guess.x.array[:] = u_k.x.array + alpha * (u_k.x.array - u_before.x.array)
        return guess

    def _solve(self, state, domain):
        """Solve ``state`` on ``domain`` from the guess (the predictor's, or from the previous state if that
        fails); the time in ``self.times["solve"]``."""
        number = len(self.history)
        t = time.perf_counter()
        guess, source = self._guess(state, domain)
        steps = None if number == 0 else 1
        # (kept for the next increment of a path; one kept on a coarser mesh is of no more use)
        keep = bool(state.step) and predictor_of(state.problem, domain.mesh.geometry.dim) == "tangent"
        self._drop_pending_solver()
        if source is None:
            self.release_solvers()
        try:
            solution, self.pending_solver = _solve_with(state.problem, domain, guess, self.petsc_options, steps,
                                                        previous_state=self.state_start, tangent_from=source,
                                                        keep_solver=keep)
        except InputError:
            if guess is self.previous and source is None:
                raise
            if domain.comm.rank == 0:
                log.info("the predicted initial guess failed: solved again from the previous state")
            solution, self.pending_solver = _solve_with(state.problem, domain, self.previous, self.petsc_options,
                                                        steps, previous_state=self.state_start, keep_solver=keep)
        self.times["solve"] = time.perf_counter() - t
        return solution

    def _auto_step(self, placeholder, domain):
        """Every increment of a step with ``increments = "auto"`` (see the class), each followed by
        :meth:`_levels` (refinement after the last). Returns what :meth:`step` returns."""
        settings = placeholder.end.values["solver"]
        smallest = 0.5 ** settings["max_increment_cuts"]
        target = settings["increment_newton_target"]
        done, size, increment, reasons, cut_time, tried = 0.0, 1.0, 0, [], 0.0, None
        while True:
            fraction = min(done + size, 1.0)
            state = placeholder.at(fraction, increment + 1)
            actual = fraction - done
            t = time.perf_counter()
            try:
                solution = self._solve(state, domain)
                newton = solution.stats.newton_iterations
                # (over the target, cut while halving pays: not when the half needed 3/4 of the whole's Newton
                # steps or more, as the first increment of a reversal under friction does at any size)
                slow = newton > target and not (tried is not None and newton >= 0.75 * tried)
                reason = f"{newton} Newton steps > {target}" if slow and actual > smallest * (1 + 1e-9) else None
                tried = newton if reason is not None else None
            except InputError as err:
                if actual <= smallest * (1 + 1e-9):
                    raise InputError(f"{err} (step {state.step}, increments = \"auto\": at its smallest "
                                     f"increment, 1/2^{settings['max_increment_cuts']} of the step, after "
                                     f"{len(reasons)} cuts; see solver.max_increment_cuts)") from None
                reason, tried = f"failed: {err}", None
            if reason is not None:
                self._drop_pending_solver()
                cut_time += time.perf_counter() - t
                reasons.append(reason)
                size = actual / 2
                if domain.comm.rank == 0:
                    log.info(f"step {state.step}, increment to {state.time:.6g}: {reason}; cut in two")
                continue
            increment += 1
            extra = {"increment_cuts": len(reasons), "cut_reason": "; ".join(reasons), "time_cut": cut_time}
            domain, level = self._levels(state, domain, solution, extra)
            if state.ends_step:
                return domain, level
            done, reasons, cut_time = fraction, [], 0.0
            size = 2 * actual if newton <= target // 2 else actual

    def _levels(self, state, domain, solution, extra=None):
        """The state's levels from its first ``solution``: after a step's last increment, refinement per the
        settings, each finer level solved from the coarser one. Returns the mesh and the last Level."""
        eta0 = None
        for number_in_step in range(self.settings.levels if state.ends_step else 1):
            number = len(self.history)
            if number_in_step > 0:
                solution = self._solve(state, domain)
            t = time.perf_counter()
            est = indicators.estimate(solution.u, solution.fields, **estimator_options(state.problem))
            self.times["estimate"] = time.perf_counter() - t
            eta0 = est.totals["eta"] if eta0 is None else eta0
            row = _row(number, domain, solution, est)
            if number == 0:
                solution.fields.warnings += shape.faceted_contact_warnings(domain, solution.fields.ids["contact"],
                                                                          row.get("max_penetration", 0.0))
            if state.step:
                row.update(step=state.step, increment=state.increment, load_time=state.time)
                row.update({f"param_{name}": float(state.problem.parameters[name]) for name in self.path_parameters})
            if extra is not None:
                row.update(extra if number_in_step == 0 else {"increment_cuts": 0, "cut_reason": "", "time_cut": 0.0})
            stop = _stop_reason(self.settings, number_in_step, row["dofs"], est.totals["eta"], eta0) \
                if state.ends_step else None
            marked = None
            if stop is None and state.ends_step and self.settings.refine == "adaptive":
                t = time.perf_counter()
                marked = marking.mark(est, self.settings.theta, self.settings.marking)
                self.times["mark"] = time.perf_counter() - t
                row["marked"] = domain.comm.allreduce(len(marked), MPI.SUM)
            row.update({f"time_{k}": v for k, v in self.times.items()})
            level = Level(number, solution, est, row, marked, stop, last_of_state=bool(stop) or not state.ends_step)
            self._record(level)
            self.previous, self.times = solution.u, {}
            self._accept_pending_solver(solution.stats)
            if level.last_of_state:  # (the predictor's states: each state's finest solution)
                self.converged = [(solution.u, dict(state.problem.parameters))] + self.converged[:1]
            if solution.fields.friction is not None:  # the next state slips from here; a finer level from the same
                self.state_start = (slip_state.state_after(solution.u, solution.fields) if level.last_of_state
                                    else slip_state.start_state(solution.fields.friction))
            if stop or not state.ends_step:
                return domain, level
            t = time.perf_counter()
            domain = refinement.refine(domain, marked)  # marked is None for uniform refinement
            self.times = {"refine": time.perf_counter() - t}

    def _drop_pending_solver(self):
        if self.pending_solver is not None:
            self.pending_solver.destroy()
        self.pending_solver = None

    def _accept_pending_solver(self, stats):
        """The last solve's solver becomes the tangent predictor's, the former one goes; unless the last solve
        built no preconditioner (it needed no Newton step: its P is K, not a Jacobian) and the former one lives
        on the same mesh: the former's is then the Jacobian of the nearest state."""
        pending, kept = self.pending_solver, self.kept_solver
        if pending is None:
            return
        if stats.pc_setups == 0 and kept is not None and kept.u.function_space.mesh is pending.u.function_space.mesh:
            self._drop_pending_solver()
            return
        if kept is not None:
            kept.destroy()
        self.kept_solver, self.pending_solver = pending, None

    def release_solvers(self):
        """Destroy the solvers kept for the tangent predictor (at the end of the path, or on an error)."""
        self._drop_pending_solver()
        if self.kept_solver is not None:
            self.kept_solver.destroy()
        self.kept_solver = None

    def _record(self, level):
        if self.on_level:
            t = time.perf_counter()
            self.on_level(level)
            level.row["time_output"] = time.perf_counter() - t
        self.history.append(level.row)
        if level.solution.domain.comm.rank == 0:
            log.info(progress_line(level.row))


# solver.predictor = "auto": the predictor per law (friction or not) and dimension, from benchmarks/load_cycle.py
# (docs/src/guide/load_paths.md, "The predictors measured")
AUTO_PREDICTOR = {(False, 2): "tangent", (True, 2): "secant", (False, 3): "secant", (True, 3): "secant"}


def predictor_of(problem, dim):
    """The predictor ``problem``'s increments use in dimension ``dim``: ``solver.predictor``, "auto" resolved by
    AUTO_PREDICTOR (with friction: μ > 0)."""
    predictor = problem.values["solver"]["predictor"]
    if predictor != "auto":
        return predictor
    return AUTO_PREDICTOR[(_frictional(problem), dim)]


def _frictional(problem):
    """Whether the problem has friction: the foundation's (``contact.friction`` or ``contact.c_t`` given, not 0;
    an expression counts) or a pair's (``friction`` given in a [[pairs]] entry)."""
    if any(pair.get("friction") is not None for pair in problem.values.get("pairs") or ()):
        return True
    for key in ("friction", "c_t"):
        value = problem.values["contact"].get(key)
        try:
            if value is None or float(value) == 0.0:
                continue
        except (TypeError, ValueError):  # (an expression)
            pass
        return True
    return False


def secant_ratio(p_before, p_k, p_next):
    """α with p_next − p_k = α (p_k − p_before), α > 0, if the parameters (dicts) move on along the line of
    the last increment (to 1e-9 of the increment), else None: where the secant predictor extrapolates."""
    names = sorted(set(p_before) | set(p_k) | set(p_next))
    old = [p_k.get(n, 0.0) - p_before.get(n, 0.0) for n in names]
    new = [p_next.get(n, 0.0) - p_k.get(n, 0.0) for n in names]
    old2 = sum(a * a for a in old)
    if old2 == 0.0:
        return None
    alpha = sum(a * b for a, b in zip(old, new)) / old2
    off = math.sqrt(sum((b - alpha * a) ** 2 for a, b in zip(old, new)))
    if not (alpha > 0.0 and off <= 1e-9 * math.sqrt(sum(b * b for b in new))):
        return None
    return alpha


def _row(number, domain, solution, est):
    """The history row of one level, a :class:`~nc_dolfinx.output.columns.Row`: a dict that also answers to
    the CSV's column names (``row["friction_force_x"]`` is ``row["friction_force"][0]``)."""
    stats, dim = solution.stats, domain.mesh.geometry.dim
    row = Row({"level": number, "dofs": dim * domain.num_vertices(), "cells": domain.num_cells(),
               "imbalance": imbalance(domain.mesh), **est.totals,
               "newton_iterations": stats.newton_iterations, "linear_iterations": stats.linear_iterations,
               "converged_reason": stats.converged_reason, "preconditioner_matrix": stats.preconditioner_matrix,
               "recoveries": stats.recoveries})
    if solution.fields.friction is not None:
        row["friction_passes"] = stats.friction_passes
        row["friction_newton"] = stats.friction_newton
    row.update(quantities.solution_quantities(solution.u, solution.fields))
    row.update(quantities.errors(solution.u, solution.fields))
    if "h1_error" in row:  # (no index when u_h is exact: a linear u, say)
        row["effectivity"] = est.totals["eta"] / row["h1_error"] if row["h1_error"] > 0 else None
        row["effectivity_augmented"] = (est.totals["eta"] / row["augmented_error"] if row["augmented_error"] > 0
                                        else None)
    _check_finite(row)
    return row


def _check_finite(row):
    """A level whose numbers overflowed is an error naming them, never a result (every rank holds the
    same row: the values are global)."""
    bad = [key for key, value in row.items() if isinstance(value, float) and not math.isfinite(value)]
    if bad:
        shown = ", ".join(f"{key} = {row[key]}" for key in bad[:4])
        raise InputError(f"{shown}: the problem's numbers overflow double precision in u_h or the estimator "
                         "(check the magnitudes of loads.f, loads.g, material.E and contact.c_n)")


def _stop_reason(settings, number, dofs, eta, eta0):
    if number == settings.levels - 1:
        return "levels"
    if settings.max_dofs is not None and dofs >= settings.max_dofs:
        return "max_dofs"
    if settings.tol is not None and eta <= settings.tol:
        return "tol"
    if settings.rtol is not None and eta <= settings.rtol * eta0:
        return "rtol"
    return None


def estimator_options(problem):
    """Quadrature degrees of the estimator given in the problem's [estimator] (others: the defaults)."""
    table = problem.values["estimator"]
    opts = {"contact_degree": table["contact_quadrature_degree"], "cell_degree": table["cell_quadrature_degree"]}
    return {k: v for k, v in opts.items() if v is not None}


def progress_line(row):
    """The progress line of a history row (logged at INFO on rank 0 as each level is recorded).

    Without [[steps]]: ``level k: …`` (the refinement level). On a load path: ``step s, increment k of N``
    (``increment k`` on a step that sizes its own increments, whose number is not known in advance), and
    ``, refined`` on a level solved again on the mesh refined after the step's last increment (the row's
    number in the history follows in brackets: increments are not levels). Then dofs, Newton and linear
    iterations, solve time and η; the H¹ error and the effectivity with an exact solution; with friction
    the largest slip of the increment (``max_slip``)."""
    if "step" in row:
        where = f"step {row['step']}, increment {row['increment']}"
        total = _increments_of(row)
        where += f" of {total}" if total else ""
        where += ", refined" if "time_refine" in row else ""
        where += f" (row {row['level']})"
    else:
        where = f"level {row['level']:2d}"
    text = (f"{where}: {row['dofs']:8d} dofs, {row['newton_iterations']:2d} Newton "
            f"({row['linear_iterations']} linear) its, solve {row['time_solve']:.2f} s, "
            f"eta = {row['eta']:.4e}")
    if "h1_error" in row:
        text += f", |u-u_h|_1 = {row['h1_error']:.4e}"
        text += f", eff = {row['effectivity']:.3f}" if row["effectivity"] is not None else ""
    if "max_slip" in row:
        text += f", max slip = {row['max_slip']:.3e}"
    return text


def _increments_of(row):
    """The number of increments of the row's step, from load_time = step − 1 + increment / increments, or
    None on a step that sizes its own increments (its rows carry ``increment_cuts``)."""
    if "increment_cuts" in row or "load_time" not in row:
        return None
    fraction = row["load_time"] - (row["step"] - 1)
    if fraction <= 0:
        return None
    total = round(row["increment"] / fraction)
    return total if total >= row["increment"] and abs(row["increment"] / total - fraction) < 1e-9 else None
