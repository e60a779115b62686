"""The nonlinear solver: presets, load stepping, preconditioner modes and PETSc options all reach the
same solution, and options given on the command line or in the problem file take effect."""
import numpy as np
import pytest
from mpi4py import MPI

from conftest import ROOT, run_cli, summary
from nc_dolfinx import adaptive, problem as problem_module
from nc_dolfinx.solver import solver_options

BLOCK = ROOT / "nc_dolfinx" / "cases" / "block.toml"


def solve(overrides=(), preset="direct", load_steps=1, preconditioner_matrix=None, cli_options=None):
    problem = problem_module.load_problem(BLOCK, ["mesh.cells=[24,12]", *overrides])
    domain = problem_module.build_domain(problem, MPI.COMM_WORLD)
    _, u, stats = adaptive.solve_level(problem, domain, solver_options(preset, cli_options=cli_options),
                                       load_steps=load_steps, preconditioner_matrix=preconditioner_matrix)
    return u.x.array.copy(), stats


@pytest.fixture(scope="module")
def reference():
    return solve()[0]


def close(a, b, rtol=1e-8):
    return np.linalg.norm(a - b) <= rtol * np.linalg.norm(b)


def test_iterative_preset_matches_direct(reference):
    u, stats = solve(preset="iterative")
    assert close(u, reference) and stats.linear_iterations > stats.newton_iterations


@pytest.mark.parametrize("mode", ["bulk", "jacobian", "auto"])
def test_preconditioner_matrices_agree(reference, mode):
    u, stats = solve(preconditioner_matrix=mode)
    assert close(u, reference)
    if mode == "jacobian":  # an exact factorisation of J: one CG iteration per Newton step
        assert stats.linear_iterations == stats.newton_iterations


def test_auto_switches_to_the_jacobian_for_a_stiff_foundation():
    soft = solve(["contact.m_n=1"], preconditioner_matrix="auto")[1]
    stiff_bulk = solve(["contact.m_n=1", "contact.c_n=1e8"], preconditioner_matrix="bulk")[1]
    stiff_auto = solve(["contact.m_n=1", "contact.c_n=1e8"], preconditioner_matrix="auto")[1]
    assert soft.preconditioner_matrix == "auto" and stiff_auto.preconditioner_matrix == "jacobian"
    assert stiff_auto.linear_iterations < stiff_bulk.linear_iterations


def test_auto_builds_the_preconditioner_from_the_jacobian_at_the_initial_guess():
    """On a nested level (the solution of the parent mesh as initial guess) "auto" factorises J(u_0),
    nearly the Jacobian of every Newton step: at most two CG iterations per step, against ~11 with
    "bulk" (Cholesky of K) (measured: 4 against 22 over 2 steps); both reach the same solution."""
    from nc_dolfinx import refinement
    problem = problem_module.load_problem(BLOCK, ["mesh.cells=[24,12]"])
    domain = problem_module.build_domain(problem, MPI.COMM_WORLD)
    _, parent, _ = adaptive.solve_level(problem, domain, solver_options("direct"))
    child = refinement.refine(domain)
    results = {mode: adaptive.solve_level(problem, child, solver_options("direct"),
                                          initial=parent, preconditioner_matrix=mode)
               for mode in ("auto", "bulk")}
    (_, u_auto, auto), (_, u_bulk, bulk) = results["auto"], results["bulk"]
    assert auto.newton_iterations == bulk.newton_iterations
    assert auto.linear_iterations <= 2 * auto.newton_iterations
    assert bulk.linear_iterations >= 4 * auto.linear_iterations
    assert close(u_auto.x.array, u_bulk.x.array, rtol=1e-9)


def test_load_stepping_reaches_the_same_solution(reference):
    u, stats = solve(load_steps=4)
    assert close(u, reference)
    assert stats.newton_iterations >= 4


def test_petsc_options_from_the_command_line_and_the_problem_file(tmp_path):
    def newton_iterations(*args):
        out = tmp_path / str(len(list(tmp_path.iterdir())))
        proc = run_cli(["block", "--refine", "none", "--quiet", "--out", out, *args])
        assert proc.returncode == 0, proc.stdout + proc.stderr
        return summary(out)["newton_iterations"]
    default = newton_iterations()
    assert newton_iterations("-snes_rtol", "1e-2") < default
    assert newton_iterations("--set", "solver.petsc_options={snes_rtol = 1e-2}") < default
    # the command line wins over the problem file
    assert newton_iterations("--set", "solver.petsc_options={snes_rtol = 1e-2}", "-snes_rtol", "1e-10") == default
