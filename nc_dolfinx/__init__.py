"""nc_dolfinx: frictionless normal compliance contact with a residual a posteriori estimator.

Implements Fernández & Hild, "A posteriori error analysis for the normal compliance problem": the
discrete problem (7) with P1 elements in 2D (plane strain) and 3D, the estimator of Definition 5 and the
SOLVE → ESTIMATE → MARK → REFINE loop, on DOLFINx 0.5.2, 0.9 and 0.11 (Debian bookworm, trixie, sid), serial or under mpirun.

    from mpi4py import MPI
    import nc_dolfinx as nc
    problem = nc.load_problem("block", ["contact.m_n=2"])     # a built-in case, a .toml file, or
    # problem = nc.Problem.from_dict({...})                   # the same keys in a dict
    domain = nc.build_domain(problem, MPI.COMM_WORLD)         # or nc.rectangle / box / from_gmsh_model …
    solution = nc.solve(problem, domain)                      # u_h of (7)
    est = nc.estimate(solution.u, solution.fields)            # η_1 … η_4, η, ζ as DG0 fields
    child = nc.refine(domain, nc.mark(est, theta=0.5))        # one adaptive step
    result = nc.adapt(problem, on_level=print)                # the whole loop

See the API page of the documentation (docs/src/api.md; build the site with docs/build.py) and demos/.
"""
__version__ = "0.2.0"

import os
import sys

# Reproducible parallel runs: Debian's PT-SCOTCH partitions with several threads, and the mesh partition
# (hence GAMG's aggregates, the Newton and Krylov counts, the last digits) then changed from one run of the
# same command to the next (3 different partitions of a 4x4x4 box in 5 runs on 2 ranks; none in 6 with
# one thread). Read by SCOTCH when it partitions; an explicit setting in the environment wins.
os.environ.setdefault("SCOTCH_PTHREAD_NUMBER", "1")

from .errors import UnsupportedDolfinx  # noqa: E402

try:
    from . import dolfinx_versions  # noqa: F401,E402 (first: it checks the installed DOLFINx's version)
except UnsupportedDolfinx as err:
    if os.path.basename(sys.argv[0]) in ("-m", "run_cases.py", "nc-dolfinx"):  # the command line
        os.write(2, f"nc_dolfinx: error: {err}\n".encode())  # one write: mpirun interleaved two ranks' print()
        sys.exit(1)
    raise

from .adaptive import AdaptSettings, Level, Result, Solution, adapt, solve
from .errors import InputError, UnsupportedDolfinx
from .estimator.indicators import CELL_DEGREE, CONTACT_DEGREE, Estimate, assemble_cellwise, estimate, patch_sum
from .estimator.marking import mark
from .log import quiet_compilers, show_progress
from .mesh.builtin import box, rectangle
from .mesh.domain import Domain
from .mesh.gmsh_io import from_gmsh, from_gmsh_model
from .mesh.refinement import refine, transfer
from .mesh.shape import resolve as resolve_shapes, snap
from .mesh.tagged import from_dolfinx
from .physics.binding import Fields, bind, build_domain
from .physics.elasticity import lame, normal_stress, sigma
from .physics.forms import CONTACT_QUADRATURE_DEGREE, contact_measure, contact_pressure, penetration
from .physics.friction import slip_increment, tangential_traction
from .physics.slip_state import SlipState, spring_stretch
from .physics.quantities import ERROR_DEGREE, contact_projection, errors, integrate, solution_quantities
from .pairs.quantities import pair_pressure, pair_quantities
from .physics.reference import compare_with_reference, hertz_line_contact, hertz_sphere_contact
from .problem.cases import case_names, case_path, case_titles
from .problem.problem import Problem, load_problem

quiet_compilers()

DEFAULT_CASE = "block"
"""The case the command line runs when none is named: the paper's setting (§2), adaptively."""

# Gauss degrees used by the package (the verification report quotes them)
QUADRATURE_DEGREES = {"contact_form": CONTACT_QUADRATURE_DEGREE, "contact_est": CONTACT_DEGREE,
                      "cell_est": CELL_DEGREE, "error": ERROR_DEGREE}
"""Gauss degrees in use: ``contact_form`` for the Γ_C terms of (7), ``contact_est`` and ``cell_est`` for
the contact and the cell/Neumann terms of the estimator (Definition 5), ``error`` for the errors of
Remark 9 (the [estimator] table of a problem may change the estimator's)."""

__all__ = [
    "Problem", "load_problem", "case_names", "case_path", "case_titles", "DEFAULT_CASE",
    "Domain", "build_domain", "rectangle", "box", "from_gmsh", "from_gmsh_model", "from_dolfinx",
    "Fields", "bind", "Solution", "solve",
    "Estimate", "estimate", "mark", "refine", "transfer", "resolve_shapes", "snap",
    "AdaptSettings", "Level", "Result", "adapt",
    "solution_quantities", "errors", "integrate", "contact_projection", "pair_quantities", "pair_pressure",
    "lame", "sigma", "normal_stress", "contact_pressure", "contact_measure", "penetration", "slip_increment",
    "tangential_traction", "SlipState", "spring_stretch",
    "assemble_cellwise", "patch_sum", "hertz_line_contact", "hertz_sphere_contact", "compare_with_reference",
    "InputError", "UnsupportedDolfinx", "quiet_compilers", "show_progress", "QUADRATURE_DEGREES",
    "dolfinx_versions",
]
