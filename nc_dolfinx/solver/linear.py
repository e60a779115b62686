"""The linear-solver policy and the options' layers of the solver of (7).

Options are layered (later wins): Newton's and the solver's own defaults, the preset's, the problem file's
``[solver] petsc_options``, then ``-snes_*``/``-ksp_*``/``-pc_*`` flags from the command line. All are written
into the PETSc options database under the prefix ``nc_`` and read by ``setFromOptions``, so any PETSc option
works, as in dolfiny. The preset ``auto`` (the default) is resolved when the mesh is known (see
``choose_preset``); ``preset`` itself is an option of the same layers (``-preset iterative`` on the command
line). The rigid-body modes are the preconditioners' near-nullspace.
"""
import math

from petsc4py import PETSc

from ..errors import InputError
from .petsc_options import check_petsc_option


NEWTON_DEFAULTS = {
    "snes_type": "newtonls",
    # The line search is the precheck's minimisation of Π along the step (see _line_minimisation); SNES
    # then takes the step it chose. PETSc's bt on the objective cannot end a solve at these tolerances: it
    # compares two values of Π, whose difference near the solution (~‖F‖²) lies below Π's round-off
    # (~1e-16 |Π|): it failed at ‖F‖ ≈ 1e-11 ‖F_0‖ (measured). Slopes F·y stay accurate.
    "snes_linesearch_type": "basic",
    "snes_rtol": 1e-10,
    "snes_stol": 0.0,
    "snes_max_it": 50,
    # PETSc stops when ‖F‖ > 1e4 ‖F_0‖; on a stiff foundation ‖F‖ legitimately grows by c_n times the
    # first step's penetration while Π decreases (the iterative preset's DIVERGED_DTOL of issue 13).
    "snes_divergence_tolerance": -1.0,
    # A Krylov solve that stops at its iteration limit still returns a descent direction of Π: take the
    # step (the line search guards it) and refresh the preconditioner, instead of ending the solve.
    "snes_max_linear_solve_fail": 1000,
}
# The solver's own choices, options of the same layers (``-pc_refresh_misfit 1``, ``-line_minimisation
# false`` on the command line, ``[solver] petsc_options``); not passed to PETSc.
OWN_DEFAULTS = {
    "line_minimisation": True,     # the line search of _line_minimisation (false: SNES's own, on Π for bt)
    "pc_refresh_misfit": 0.3,      # see the preconditioner refresh below
    "pc_refresh_growth": 3.0,      # see the preconditioner refresh below
    "ew_rtol0_unsupported": 0.3,   # see _first_krylov_tolerance
    "fallbacks": True,             # false: a failed SNES solve ends the run at once
    # Unless an snes_atol is given, ‖F‖ <= atol_of_load ‖L‖ also counts as converged: with a good initial
    # guess (nested iteration) snes_rtol relative to ‖F(u_0)‖ can lie below round-off on large meshes.
    "atol_of_load": 1e-10,
    "bilateral_predictor": True,   # see _bilateral_predictor
    "roundoff_factor": 10.0,       # see _within_roundoff (0: the target alone ends a solve)
    "creeping_steps": 10,          # see _Creeping (0: never)
    "friction_passes": 100,        # the most passes of the fixed point on the friction bound (see _fixed_point)
    "friction_newton": True,       # the fixed point's consistent Newton finish (see _consistent_newton)
    "friction_creeping_steps": 3,  # a warm pass cut this often in a row: the ε-continuation (see _fixed_point)
}

# hypre's BoomerAMG, the iterative preset's preconditioner (cold and warm starts, 2D and 3D): classical AMG
# with low-complexity settings (HMIS coarsening, extended+i interpolation truncated to 4 entries per row,
# aggressive coarsening on the first level(s)), scalar AMG on the matrix as it is, without the rigid-body
# modes (hypre's nodal coarsening and interpolation of them set up 4x slower). The strength threshold is
# hypre's recommendation per dimension, 0.25 in 2D and 0.5 in 3D. The smoother is PETSc's default for it,
# symmetric hybrid Gauss–Seidel, in 2D; in 3D a Chebyshev polynomial (parallel as it is serial) with two
# levels of aggressive coarsening: more CG iterations, but each ~40 % cheaper and the set-up ~40 % faster.
# In 2D the aggressive level takes a point at distance 2 as strongly connected only through 2 paths
# (hypre's agg_num_paths; 1 by default), so it coarsens less aggressively, and CG needs half the
# iterations: one solve to Newton's accuracy on the family's square 16 instead of 35 (0.42 s instead of
# 0.57 s), on its two materials 19 instead of 39; 3 or 4 paths took twice the time; in 3D 25 instead of
# 35 iterations in the same time, so 1 path is kept there (benchmarks/README.md, "Two paths").
# Measured (benchmarks/README.md, "BoomerAMG and the forcing terms", benchmarks/amg.py: one linear solve to
# Newton's accuracy) against GAMG set up as DOLFINx's elasticity demo does (below): the family's 3D cube 2.0 s
# instead of 3.5 s serially, the 2D square 0.62 s instead of 1.46 s; GAMG needs 51–58 CG iterations on the
# two-material bodies where BoomerAMG needs 37–40; and on Plaza-refined meshes (the adaptive loop's nested
# levels) PETSc 3.18's GAMG aggregates poorly (operator complexity 3.1 instead of 1.3: 9.7 s against 1.7 s
# on the cube refined once).
HYPRE = {"pc_hypre_type": "boomeramg", "pc_hypre_boomeramg_coarsen_type": "HMIS",
         "pc_hypre_boomeramg_interp_type": "ext+i", "pc_hypre_boomeramg_P_max": 4}
HYPRE_BY_DIM = {2: {**HYPRE, "pc_hypre_boomeramg_agg_nl": 1, "pc_hypre_boomeramg_agg_num_paths": 2,
                    "pc_hypre_boomeramg_strong_threshold": 0.25},
                3: {**HYPRE, "pc_hypre_boomeramg_agg_nl": 2, "pc_hypre_boomeramg_strong_threshold": 0.5,
                    "pc_hypre_boomeramg_relax_type_all": "Chebyshev"}}
# Smoothed-aggregation AMG for elasticity (``-pc_type gamg``, or Trilinos ML: ``-pc_type ml``), set up as in
# DOLFINx's elasticity demo: the rigid-body near-nullspace (on the matrices, see NonlinearSolver), the SPD
# flag, Chebyshev/Jacobi smoothers with CG-based eigenvalue estimates (CG is the right estimator for an
# SPD operator and needs fewer steps than GMRES), and the interpolation kept when the preconditioning
# matrix is refreshed within a level (only the Galerkin products and smoothers are redone). ML sets up
# fast on refined meshes too, but PETSc 3.18's ML wrapper can fail in parallel (MatWrapML_MPIAIJ: "New
# nonzero caused a malloc" on one rank, seen on manufactured3d at 2 ranks), which no rank recovers from.
SMOOTHERS = {"mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi",
             "mg_levels_esteig_ksp_type": "cg", "mg_levels_ksp_chebyshev_esteig_steps": 10}
GAMG = {"pc_gamg_type": "agg", "pc_gamg_agg_nsmooths": 1, "pc_gamg_reuse_interpolation": True,
        # GAMG would hand the smoothers the eigenvalue estimates of its prolongator smoothing, which a
        # refresh with reused interpolation does not redo: after K -> K + 1e4 M_Γ CG then ran 10000
        # iterations (or stopped on an indefinite PC); with Chebyshev's own CG estimates 29 (fresh set-up:
        # 22, at 3x the set-up time).
        "pc_gamg_use_sa_esteig": False}
ML = {"pc_ml_reuse_interpolation": True}  # ML reads the rigid-body modes from the matrix (pc_ml_nullspace auto)


def preconditioner_settings(pc_type, dim):
    """The settings a preconditioner comes with, whichever layer chose it: BoomerAMG's for the dimension,
    GAMG's and ML's (DOLFINx's elasticity demo), none for others."""
    return {"hypre": HYPRE_BY_DIM[dim], "gamg": {**SMOOTHERS, **GAMG}, "ml": {**SMOOTHERS, **ML}}.get(pc_type, {})


# Both presets run CG on the Jacobian J = K + j_n'(u) (SPD); the preconditioner is built from J at the
# initial guess and refreshed when it no longer fits (see NonlinearSolver).
PRESETS = {
    # a Cholesky factorisation (MUMPS, AMF ordering: the fastest measured here); exact Newton steps
    "direct": {"ksp_type": "cg", "ksp_rtol": 1e-10, "pc_type": "cholesky",
               "pc_factor_mat_solver_type": "mumps", "mat_mumps_icntl_7": 2},
    # Inexact Newton with Eisenstat–Walker's forcing terms (version 3, applied by Forcing). The first Krylov
    # solve to 3e-2 (rtol0; PETSc's default 0.3): on a cold start the first step is nearly the answer when
    # the Jacobian already sees the foundation (m_n = 1, see closed_jacobian), and a loose one cost 2-4 more
    # Newton steps on the stiff members of benchmarks/family.py. CG measures the true residual ‖F + J y‖
    # (as cheap in CG as its preconditioned norm), so that Forcing's tolerances and Newton's ‖F‖ speak of
    # the same quantity.
    "iterative": {"ksp_type": "cg", "ksp_rtol": 1e-10, "ksp_norm_type": "unpreconditioned", "pc_type": "hypre",
                  "snes_ksp_ew": True, "snes_ksp_ew_version": 3, "snes_ksp_ew_rtol0": 0.03},
}
PRESET_NAMES = ("auto", *PRESETS)
PRECONDITIONER_MATRICES = ("auto", "bulk", "jacobian")


def solver_options(preset="auto", problem_options=None, cli_options=None):
    """The user's option layers over the preset's name (``preset`` may itself be overridden by a layer);
    the preset's options go under them in ``NonlinearSolver``, once the problem is known."""
    options = {"preset": preset}
    options.update(problem_options or {})
    options.update(cli_options or {})
    return options


def choose_preset(dim, dofs, warm_start, friction=False):
    """The linear strategy of ``preset = "auto"``, from what is known before solving (measured in
    benchmarks/README.md, "auto"):

    - 3D: CG + AMG (BoomerAMG, see HYPRE_BY_DIM) — a factorisation of the whole stiffness costs far more time and
      memory there.
    - 2D, up to COLD_DIRECT_MAX_DOFS: MUMPS Cholesky; both take < 0.05 s there, and exact Newton steps
      make the Newton counts independent of the partition.
    - 2D with a warm start (the adaptive loop's nested levels), up to WARM_DIRECT_MAX_DOFS: MUMPS
      Cholesky of J(u_0), nearly the final Jacobian: 1–4 CG iterations per level (nested levels of the
      family's square: 0.17–0.45 x the linear floor; spot checks with BoomerAMG 0.43–0.47 x); with GAMG
      the adaptive loops of block, hertz and manufactured ran 1.3–1.8x faster direct (corner: within 10 %).
      Not with ``friction``: there the stick and slip zones move during the solve, so J(u_0) is not the
      final Jacobian, and P is rebuilt up to ~20 times (the last increment of benchmarks/family.py's
      friction members: 1–19 set-ups); a Cholesky set-up costs twice BoomerAMG's (0.11 s against 0.05 s on
      the family's square at 128 cells) and a solve with it twice a V-cycle (0.016 s, 0.008 s). Measured
      there (the nine 2D friction members, 1 rank, ratios to the linear floor summed over the members,
      Cholesky -> BoomerAMG): the last increment of a load path 95 -> 68 at 33,282 dofs and 112 -> 90 at
      132,098 (within 2 x: 3 -> 5 and 2 -> 4 of 9), a nested level 14 -> 10 (within 2 x: 6 -> 8 of 9). In
      family.py itself (docs/src/performance.md, commit 6b341bc) the 2D increments within 2 x went 4 -> 9
      of 18 and the nested levels 13 -> 16; where one exact Newton step ends the solve (μ = 1) BoomerAMG
      takes 4 (1-1-mu1's increment 0.72 -> 1.27 x).
    - otherwise (2D cold starts, large meshes): CG + AMG, 1.4–2.8x faster than the factorisation on a
      cold start from 1e4 dofs on (block, corner, the family square).
    The number of ranks did not change these choices in the measurements.
    """
    warm_direct = warm_start and not friction and dofs <= WARM_DIRECT_MAX_DOFS
    if dim == 2 and (dofs <= COLD_DIRECT_MAX_DOFS or warm_direct):
        return "direct"
    return "iterative"


COLD_DIRECT_MAX_DOFS = 10_000
WARM_DIRECT_MAX_DOFS = 1_000_000


def resolve_options(options, dim, dofs, warm_start, friction=False):
    """NEWTON_DEFAULTS, OWN_DEFAULTS < the preset's options < the user's layers, with "auto" resolved by
    choose_preset, under the settings of the preconditioner in force (preconditioner_settings). The user's
    values are checked first (_check_own_option, check_petsc_option: InputError), numbers as parsed."""
    user = {k.lstrip("-"): v for k, v in options.items()}
    preset = str(user.pop("preset", "auto"))
    if preset not in PRESET_NAMES:
        raise InputError(f"solver preset must be one of {', '.join(PRESET_NAMES)}, got '{preset}'")
    name = choose_preset(dim, dofs, warm_start, friction) if preset == "auto" else preset
    resolved = {**NEWTON_DEFAULTS, **OWN_DEFAULTS, **PRESETS[name]}
    for key in user:
        if key in OWN_DEFAULTS:
            _check_own_option(key, user[key])
        else:
            user[key] = check_petsc_option(key, user[key])
    options = {**resolved, **user}
    return name, {**preconditioner_settings(options.get("pc_type"), dim), **options}


def _check_own_option(key, value):
    """The solver's own options are not PETSc's, so PETSc does not check them: a flag, or a finite number ≥ 0,
    whole where the solver counts with it (``-friction_passes 2.5`` is refused, not cut to 2; ``inf`` is
    refused everywhere: ``-atol_of_load inf`` would have taken u = 0 as converged)."""
    default = OWN_DEFAULTS[key]
    if isinstance(default, bool):
        if value is not None and str(value).lower() not in ("true", "false", "1", "0", "yes", "no", "on", "off"):
            raise InputError(f"solver option {key} must be true or false, got '{value}'")
        return
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    whole = isinstance(default, int)
    if not (math.isfinite(number) and number >= 0 and (number.is_integer() or not whole)):
        raise InputError(f"solver option {key} must be {'a whole number' if whole else 'a number'} >= 0, "
                         f"got '{value}'")


def option_is_true(value):
    """An option's truth value: true/false/1/0/yes/no (None: set without a value, i.e. true)."""
    return value is None or str(value).lower() in ("true", "1", "yes", "on")


def rigid_body_modes(V):
    """Near-nullspace of elasticity on the vector space V: the d translations and d(d−1)/2 infinitesimal
    rotations (2D: 3 modes, 3D: 6), d = the number of displacement components.

    The vectors live on the communicator of V's index map, which is freed with V: V must outlive the
    null space (BoomerAMG reads their communicator at its set-up; after V was freed it crashed in
    MPI_Comm_size, GAMG did not notice). NonlinearSolver keeps V through its ``u``."""
    index_map = V.dofmap.index_map
    bs = V.dofmap.index_map_bs
    x = V.tabulate_dof_coordinates()[:index_map.size_local, :bs]
    rotations = [(i, j) for i in range(bs) for j in range(i + 1, bs)]
    vectors = [PETSc.Vec().createMPI((index_map.size_local * bs, PETSc.DETERMINE), bsize=bs, comm=V.mesh.comm)
               for _ in range(bs + len(rotations))]
    arrays = [v.array.reshape(-1, bs) for v in vectors]
    for a in arrays:
        a[:] = 0.0
    for k in range(bs):
        arrays[k][:, k] = 1.0
    for a, (i, j) in zip(arrays[bs:], rotations):  # rotation in the (x_i, x_j) plane
        a[:, i] = -x[:, j]
        a[:, j] = x[:, i]
    for i, vector in enumerate(vectors):  # Gram–Schmidt, as dolfinx.la.orthonormalize of DOLFINx 0.5
        for previous in vectors[:i]:
            vector.axpy(-vector.dot(previous), previous)
        vector.normalize()
    return PETSc.NullSpace().create(vectors=vectors, comm=V.mesh.comm)
