"""Problem files: expressions, overrides, and how tractions reach the boundary groups."""
import numpy as np
import pytest
from mpi4py import MPI

from conftest import ROOT
from nc_dolfinx import adaptive, problem as problem_module
from nc_dolfinx.errors import InputError
from nc_dolfinx.expressions import to_float
from nc_dolfinx.solver import solver_options

BLOCK = ROOT / "nc_dolfinx" / "cases" / "block.toml"


def solve(overrides):
    problem = problem_module.load_problem(BLOCK, ["mesh.cells=[8,4]", *overrides])
    domain = problem_module.build_domain(problem, MPI.COMM_WORLD)
    return adaptive.solve_level(problem, domain, solver_options("direct"))[1].x.array.copy()


def test_a_traction_for_all_of_gamma_n_skips_groups_in_no_role():
    """g = [gx, gy] applies to the listed Neumann groups; a group in no role stays traction-free."""
    listed_only = solve(['mesh.neumann=["top"]', 'loads.g=["0", "-5"]'])
    explicit = solve(['mesh.neumann=["top", "right"]', 'loads.g={top = ["0", "-5"]}'])
    assert np.allclose(listed_only, explicit, rtol=1e-12, atol=1e-14)
    everywhere = solve(['mesh.neumann=["top", "right"]', 'loads.g=["0", "-5"]'])
    assert not np.allclose(listed_only, everywhere, rtol=1e-6)


def test_parameters_and_overrides():
    data = problem_module.apply_overrides({"parameters": {"a": 2}}, ["parameters.b=a*3", "contact.m_n=2"])
    problem = problem_module.problem_from_data(
        {**data, "mesh": {"rectangle": [[0, 0], [1, 1]], "dirichlet": ["left"], "contact": ["bottom"]}}, "t")
    assert problem.parameters == {"a": 2.0, "b": 6.0}
    assert problem.m_n == 2.0
    with pytest.raises(InputError, match="KEY=VALUE"):
        problem_module.apply_overrides({}, ["novalue"])


@pytest.mark.parametrize("text,value", [("2*pi", 2 * np.pi), ("max(1, -2)**2 + pos(-3)", 1.0),
                                        ("sqrt(abs(-16)) / 2", 2.0), ("-2**2", -4.0)])
def test_expressions(text, value):
    assert to_float(text) == pytest.approx(value)
