"""Problem files and the schema: strict keys, required physics, overrides, expressions, tractions."""
import numpy as np
import pytest
from mpi4py import MPI

from conftest import ROOT
import nc_dolfinx as nc
from nc_dolfinx.problem import schema
from nc_dolfinx.errors import InputError
from nc_dolfinx.problem.expressions import to_float
from nc_dolfinx.problem.reading import apply_overrides, read_toml

BLOCK = ROOT / "nc_dolfinx" / "cases" / "block.toml"
MINIMAL = {
    "mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [4, 4], "dirichlet": ["left"], "contact": ["bottom"]},
    "material": {"E": 1.0, "nu": 0.3},
    "loads": {"f": ["0", "-1"]},
    "contact": {"c_n": 1.0, "m_n": 1.0},
}


def with_(dotted, value, base=MINIMAL):
    import copy
    data = copy.deepcopy(base)
    *path, last = dotted.split(".")
    table = data
    for part in path:
        table = table.setdefault(part, {})
    if value is DELETE:
        del table[last]
    else:
        table[last] = value
    return data


DELETE = object()


def solve(overrides):
    problem = nc.load_problem(BLOCK, ["mesh.cells=[8,4]", *overrides])
    return nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD)).u.x.array.copy()


def test_a_traction_for_all_of_gamma_n_skips_groups_in_no_role():
    """g = [gx, gy] applies to the listed Neumann groups; a group in no role stays traction-free."""
    listed_only = solve(['mesh.neumann=["top"]', 'loads.g=["0", "-5"]'])
    explicit = solve(['mesh.neumann=["top", "right"]', 'loads.g={top = ["0", "-5"]}'])
    assert np.allclose(listed_only, explicit, rtol=1e-12, atol=1e-14)
    everywhere = solve(['mesh.neumann=["top", "right"]', 'loads.g=["0", "-5"]'])
    assert not np.allclose(listed_only, everywhere, rtol=1e-6)


def test_parameters_overrides_and_defaults():
    data = apply_overrides(with_("parameters", {"a": 2}), ["parameters.b=a*3", "contact.m_n=b"])
    problem = nc.Problem.from_dict(data, "t")
    assert problem.parameters == {"a": 2.0, "b": 6.0}
    assert problem["contact.m_n"] == 6.0
    assert problem["contact.gap"] == 0.0 and problem["mesh.neumann"] == [] and problem["adapt.refine"] == "none"
    assert "contact.gap" not in problem.given and "contact.c_n" in problem.given
    changed = problem.replace({"contact.c_n": "5*(1 + x)", "parameters.a": 3})
    assert changed["contact.c_n"] == "5*(1 + x)" and changed.parameters["b"] == 9.0 and problem["contact.c_n"] == 1.0
    with pytest.raises(InputError, match="KEY=VALUE"):
        apply_overrides({}, ["novalue"])


# Every key misspelt or missing names itself; none of these may run with a silent default.
STRICT = [
    (with_("material.Young", 1e3), "unknown key 'material.Young'"),
    (with_("contact.cn", 5), "unknown key 'contact.cn' (did you mean 'contact.c_n'?)"),
    (with_("contact.mn", 2), "did you mean 'contact.m_n'?"),
    (with_("loads.force", ["0", "1"]), "unknown key 'loads.force'"),
    (with_("material.regions", {"rubber": {"young": 50}}), "unknown key 'material.regions.rubber.young'"),
    (with_("material.regions", {"rubber": {"E": 50}}), "missing required key 'material.regions.rubber.nu'"),
    (with_("adapt.level", 3), "unknown key 'adapt.level' (did you mean 'adapt.levels'?)"),
    (with_("solver.presets", "iterative"), "did you mean 'solver.preset'?"),
    (with_("contacts", {"c_n": 1}), "unknown section '[contacts]' (did you mean '[contact]'?)"),
    (with_("material", DELETE), "missing required key 'material.E'"),
    (with_("material.E", DELETE), "missing required key 'material.E': Young's modulus has no default"),
    (with_("contact", DELETE), "missing required key 'contact.c_n'"),
    (with_("contact.m_n", DELETE), "missing required key 'contact.m_n'"),
    (with_("loads", DELETE), "the problem has no load"),
    (with_("mesh.contact", DELETE), "missing required key 'mesh.contact'"),
    (with_("material.E", float("nan")), "material.E"),
    (with_("material.E", float("inf")), "material.E"),
    (with_("contact.c_n", float("inf")), "contact.c_n must be a finite number"),
    (with_("material.E", "1e400"), "not a finite number"),
    (with_("contact.m_n", 0.5), "contact.m_n must be >= 1"),
    (with_("contact.c_n", -1), "contact.c_n must be >= 0"),
    (with_("contact.m_n", "2*x"), "cannot depend on the coordinates"),
    (with_("adapt.refine", "adaptve"), "did you mean 'adaptive'?"),
    (with_("mesh.cells", DELETE), "mesh.cells is required with mesh.rectangle"),
    (with_("mesh.cells", [4, 4, 4]), "mesh.cells must be 2 positive integers"),
    (with_("mesh.box", [[0, 0, 0], [1, 1, 1]]), "takes one of 'file', 'rectangle' or 'box', got rectangle, box"),
    (with_("loads.f", ["0", "-1", "0"]), "loads.f has 3 components but the mesh is 2D"),
    (with_("loads.from_exact", True), "loads.from_exact needs [exact] u"),
    (with_("loads.g", {"top": ["0", "1"]}), "'top', which is not a neumann group"),
    (with_("solver.load_steps", 2.5), "solver.load_steps must be an integer"),
    (with_("adapt.levels", True), "adapt.levels must be an integer"),
    (with_("mesh.dirichlet", ["bottom"]), "'bottom' is in both dirichlet and contact"),
    (with_("parameters.free", 1.0), "parameter name 'free' is not allowed"),
    (with_("loads.u_D", {"bottom": ["0", "0"]}), "'bottom', which is not a dirichlet group (it is a contact group"),
    (with_("loads.u_D", ["free", "free"]), "every component is \"free\""),
    (with_("loads.u_D", ["0.1", "Free"]),
     "loads.u_D[1]: unknown name 'Free' in expression 'Free' (did you mean \"free\"?)"),
    (with_("loads.u_D", {"left": ["0"]}), "loads.u_D.left must be a list of 2 (2D) or 3 (3D)"),
    (with_("loads.u_D", "0"), "loads.u_D must be a vector or a table"),
    (with_("loads", {"u_D": ["0", "free"]}), "the problem has no load: give loads.f, loads.g, a non-zero loads.u_D"),
]


def test_a_prescribed_displacement_alone_is_a_load():
    """u_D counts as a load when some held component may be non-zero (a number or an expression)."""
    for u_D in (["0.1", "free"], {"left": ["0", "y"]}, ["p", "0"]):
        data = with_("loads", {"u_D": u_D})
        data["parameters"] = {"p": 0.5}
        assert nc.Problem.from_dict(data, "t")["loads.u_D"] == u_D


@pytest.mark.parametrize("data, message", STRICT, ids=[s[1][:40] for s in STRICT])
def test_schema_refuses(data, message):
    with pytest.raises(InputError) as err:
        nc.Problem.from_dict(data, "t")
    assert message in str(err.value)


def test_the_minimal_problem_is_valid():
    """The control for STRICT: the same table without the fault validates."""
    problem = nc.Problem.from_dict(MINIMAL, "t")
    assert problem["material.E"] == 1.0 and problem.dimension == 2


def test_integer_tags_go_through_the_role_checks():
    """'bottom' is the rectangle's tag 3: naming it by its tag in Γ_D while Γ_C has it by name is refused."""
    problem = nc.Problem.from_dict(with_("mesh.dirichlet", ["left", 3]), "t")
    with pytest.raises(InputError, match=r"'bottom' \(tag 3\) is in both dirichlet and contact"):
        nc.bind(problem, nc.build_domain(problem, MPI.COMM_WORLD))


def test_a_contact_boundary_of_two_groups():
    """Γ_C may be a list of groups: the force is the sum over both (it crashed once)."""
    two = nc.load_problem(BLOCK, ['mesh.contact=["bottom", "right"]', 'mesh.neumann=["top"]',
                                  "mesh.cells=[8,4]"])
    solution = nc.solve(two, nc.build_domain(two, MPI.COMM_WORLD))
    force = nc.solution_quantities(solution.u, solution.fields)["contact_force"]
    assert force[1] > 0 and np.isfinite(force).all()


def test_every_case_file_validates_and_the_reference_lists_every_key():
    for name in nc.case_names():
        nc.load_problem(name)
    text = schema.reference_markdown()
    for key in schema.KEYS:
        if key.kind != "table":
            assert f"`{key.path}`" in text, key.path


@pytest.mark.parametrize("text,value", [("2*pi", 2 * np.pi), ("max(1, -2)**2 + pos(-3)", 1.0),
                                        ("sqrt(abs(-16)) / 2", 2.0), ("-2**2", -4.0)])
def test_expressions(text, value):
    assert to_float(text) == pytest.approx(value)


def test_case_files_are_read_as_toml():
    assert read_toml(BLOCK)["contact"]["m_n"] == 1.5
