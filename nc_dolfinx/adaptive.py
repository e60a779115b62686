"""The SOLVE → ESTIMATE → MARK → REFINE loop.

Each level solves (7) on the current mesh starting from the previous level's solution interpolated onto it
(nested iteration; level 0 starts from zero, with load stepping if asked), evaluates the estimator of
Definition 5, records a history row, and refines: every cell (``uniform``) or the cells marked by
Dörfler's bulk criterion or the maximum strategy (``adaptive``). It stops at the level count, the dof
budget or the tolerance on η (absolute, or relative to η on level 0), whichever comes first.
"""
import time
from dataclasses import dataclass, field

import numpy as np
from mpi4py import MPI

from dolfinx import fem

from . import estimator, forms, marking, quantities, refinement
from .problem import bind, build_domain
from .solver import NonlinearSolver, solver_options


@dataclass
class AdaptSettings:
    refine: str = "none"        # none | uniform | adaptive
    levels: int = 1
    theta: float = 0.5
    marking: str = "doerfler"   # doerfler | maximum
    max_dofs: int = None
    tol: float = None           # stop when η <= tol
    rtol: float = None          # stop when η <= rtol * η(level 0)

    @classmethod
    def from_problem(cls, problem, **cli):
        """Problem file ``[adapt]`` values, overridden by the command line (None = not given)."""
        values = {k: v for k, v in problem.adapt.items() if k in cls.__dataclass_fields__}
        values.update({k: v for k, v in cli.items() if v is not None})
        s = cls(**values)
        if s.refine == "none":
            s.levels = 1
        return s.validated()

    def validated(self):
        from .errors import InputError
        for name, kind in (("levels", int), ("theta", float), ("max_dofs", int), ("tol", float), ("rtol", float)):
            value = getattr(self, name)
            if value is not None:
                try:
                    setattr(self, name, kind(value))
                except (TypeError, ValueError):
                    raise InputError(f"adapt.{name} must be a number, got {value!r}") from None
        if self.refine not in ("none", "uniform", "adaptive"):
            raise InputError(f"refine must be none, uniform or adaptive, got '{self.refine}'")
        if self.marking not in ("doerfler", "maximum"):
            raise InputError(f"marking must be doerfler or maximum, got '{self.marking}'")
        if not 0 < self.theta <= 1:
            raise InputError(f"theta must lie in (0, 1], got {self.theta}")
        if self.levels < 1:
            raise InputError(f"levels must be >= 1, got {self.levels}")
        return self


@dataclass
class Level:
    """What one level leaves behind (the last one is written as the final solution)."""
    fields: object
    u: fem.Function
    estimate: estimator.Estimate
    row: dict = field(default_factory=dict)


def dirichlet_bcs(V, fields):
    tags = fields.domain.facet_tags
    facets = tags.indices[np.isin(tags.values, fields.ids["dirichlet"])]
    dofs = fem.locate_dofs_topological(V, 1, facets)
    return [fem.dirichletbc(np.zeros(2, dtype=np.float64), dofs, V)]


def solve_level(problem, domain, options, initial=None, load_steps=1, preconditioner_matrix=None):
    """SOLVE on one mesh: returns (fields, u, solver stats)."""
    fields = bind(problem, domain)
    V = fem.VectorFunctionSpace(domain.mesh, ("CG", 1))
    u = refinement.transfer(initial, V) if initial is not None else fem.Function(V)
    u.name = "displacement"
    solver = NonlinearSolver(forms.normal_compliance_forms(u, fields), u, dirichlet_bcs(V, fields), options,
                             preconditioner_matrix or problem.preconditioner_matrix, forms.energy(u, fields))
    try:
        stats = solver.solve(load_steps)
    finally:
        solver.destroy()
    return fields, u, stats


def run(problem, comm, settings, cli_options=None, on_level=None, progress=None):
    """Run the loop; ``on_level(level)`` is called after each level (output), ``progress(text)`` prints."""
    options = solver_options(problem.preset, problem.petsc_options, cli_options)
    t0 = time.perf_counter()
    domain = build_domain(problem, comm)
    times = {"mesh": time.perf_counter() - t0}  # then, on later levels, the refinement that made the mesh
    history, previous, eta0 = [], None, None
    pc_matrix = problem.preconditioner_matrix  # "auto" turns into "jacobian" for good once it switches
    for number in range(settings.levels):
        t = time.perf_counter()
        fields, u, stats = solve_level(problem, domain, options, previous,
                                       problem.load_steps if number == 0 else 1, pc_matrix)
        pc_matrix = stats.preconditioner_matrix
        times["solve"] = time.perf_counter() - t
        t = time.perf_counter()
        est = estimator.estimate(u, fields, **_estimator_options(problem))
        times["estimate"] = time.perf_counter() - t
        eta0 = est.totals["eta"] if eta0 is None else eta0
        dofs = 2 * domain.num_vertices()
        row = {"level": number, "dofs": dofs, "cells": domain.num_cells(), **est.totals,
               "newton_iterations": stats.newton_iterations, "linear_iterations": stats.linear_iterations,
               "converged_reason": stats.converged_reason, "preconditioner_matrix": stats.preconditioner_matrix}
        row.update(quantities.solution_quantities(u, fields))
        row.update(quantities.errors(u, fields))
        if "h1_error" in row:
            row["effectivity"] = est.totals["eta"] / row["h1_error"]
            row["effectivity_augmented"] = est.totals["eta"] / row["augmented_error"]
        last = (number == settings.levels - 1
                or (settings.max_dofs is not None and dofs >= settings.max_dofs)
                or (settings.tol is not None and est.totals["eta"] <= settings.tol)
                or (settings.rtol is not None and est.totals["eta"] <= settings.rtol * eta0))
        marked = None
        if not last and settings.refine == "adaptive":
            t = time.perf_counter()
            marked = marking.mark(est.squares, comm, settings.theta, settings.marking)
            times["mark"] = time.perf_counter() - t
            row["marked"] = comm.allreduce(len(marked), MPI.SUM)
        level = Level(fields, u, est, row)
        if on_level:
            t = time.perf_counter()
            on_level(level)
            times["output"] = time.perf_counter() - t
        row.update({f"time_{k}": v for k, v in times.items()})
        history.append(row)
        if progress:
            progress(_progress_line(row))
        if last:
            break
        t = time.perf_counter()
        domain = refinement.refine(domain, marked)  # marked is None for uniform refinement
        times = {"refine": time.perf_counter() - t}
        previous = u
    return level, history


def _estimator_options(problem):
    opts = {}
    if "contact_quadrature_degree" in problem.estimator:
        opts["contact_degree"] = int(problem.estimator["contact_quadrature_degree"])
    if "cell_quadrature_degree" in problem.estimator:
        opts["cell_degree"] = int(problem.estimator["cell_quadrature_degree"])
    return opts


def _progress_line(row):
    text = (f"level {row['level']:2d}: {row['dofs']:8d} dofs, {row['newton_iterations']:2d} Newton "
            f"({row['linear_iterations']} linear) its, solve {row['time_solve']:.2f} s, "
            f"eta = {row['eta']:.4e}")
    if "h1_error" in row:
        text += f", |u-u_h|_1 = {row['h1_error']:.4e}, eff = {row['effectivity']:.3f}"
    return text
