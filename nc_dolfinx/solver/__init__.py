"""The solver of (7), in five rooms:

- :mod:`.newton`: the Newton driver (SNES with Π as its objective, the line minimisation, the
  preconditioner's refreshes, the bilateral predictor, the round-off test);
- :mod:`.linear`: the linear-solver policy (the presets, ``auto``'s choice, the options' layers, the
  rigid-body near-nullspace) and :mod:`.forcing`, how accurately each linear system is solved;
- :mod:`.recovery`: what is tried when a SNES solve fails;
- :mod:`.fixed_point`: with friction, the fixed point on the friction bound around each increment's solve;
- :mod:`.petsc_options`: the user's PETSc options, checked before the solve and after the first.
"""
from .forcing import Forcing
from .linear import (HYPRE_BY_DIM, PRECONDITIONER_MATRICES, PRESET_NAMES, PRESETS, choose_preset, resolve_options,
                     rigid_body_modes, solver_options)
from .newton import NonlinearSolver, SolveStats, closed_jacobian
from .petsc_options import PREFIX

__all__ = ["Forcing", "HYPRE_BY_DIM", "PRECONDITIONER_MATRICES", "PRESET_NAMES", "PRESETS", "PREFIX", "NonlinearSolver",
           "SolveStats", "choose_preset", "closed_jacobian", "resolve_options", "rigid_body_modes", "solver_options"]
