"""The front door against inputs beyond the schema's types (issue 31): numbers that overflow, expressions
that are too deep, too long or not finite on the mesh, hostile names and titles, references that do not
fit, mesh groups in no role. Each refusal is one line naming the key, exit 1 (``assert_bad_input``); each
input that is valid runs to exit 0 with finite numbers only.

The limits themselves (``expressions.MAX_DEPTH``, ``schema.MAX_TITLE`` …) are read from the package, so
that a test holds the rule, not a copy of its number.
"""
import json
import math

import numpy as np
import pytest

from conftest import ROOT, summary
from test_bad_input import FAST, assert_bad_input, cli

from nc_dolfinx.problem import expressions
from nc_dolfinx.problem import schema
from nc_dolfinx.errors import InputError, brief, brief_text

DEEP_SUM = "+".join(["x"] * (expressions.MAX_DEPTH + 1))  # a sum of n terms nests n deep
SIGNS = "-" * (expressions.MAX_DEPTH + 1) + "1"

CASES = [
    # numbers a float cannot hold, in every place a number goes
    ("huge_integer", ["--set", f"material.nu=1{'0' * 400}"], "material.nu must be a finite number"),
    ("huge_integer_parameter", ["--set", f"parameters.k=1{'0' * 400}"], "parameters.k must be a finite number"),
    ("huge_option", ["--set", f"solver.petsc_options={{snes_rtol=1{'0' * 400}}}"],
     "solver.petsc_options.snes_rtol must be"),
    # expressions: overflow on the mesh, in every role an expression has
    ("load_overflows", ["--set", 'loads.f=["exp(1000*(x + 2))", "0"]'], "loads.f[0] = 'exp(1000*(x + 2))' is not finite"),
    ("traction_overflows", ["--set", 'loads.g={top=["0", "(2 + x*x)**1e9"]}'], "loads.g.top[1]"),
    ("c_n_singular", ["--set", 'contact.c_n="1/(x - x)"'], "contact.c_n = '1/(x - x)' is not finite"),
    ("gap_nan", ["--set", 'contact.gap="sqrt(-1 - x*x)"'], "contact.gap"),
    ("exact_overflows", ["--set", 'exact.u=["exp(1e3*(y + 1))", "0"]'], "exact.u[0]"),
    # data that overflow inside the solve (finite, but not in double precision)
    ("stiffness_overflows", ["--set", "material.E=1e308"], "material.E"),
    ("estimator_overflows", ["--set", 'loads.f=["0", "-1e307"]'], "loads.f"),
    # expressions too deep or too long for the parser, UFL and FFCx; control characters
    ("deep_sum", ["--set", f'contact.c_n="{DEEP_SUM}"'], f"nested more than {expressions.MAX_DEPTH} deep"),
    ("many_signs", ["--set", f'contact.c_n="{SIGNS}"'], "contact.c_n"),
    ("too_long", ["--set", f'contact.c_n="{"1+" * (expressions.MAX_LENGTH // 2)}1"'], "contact.c_n"),
    ("nul_byte", ["--set", 'contact.c_n="1\\u0000"'], "contact.c_n: expression '1\\x00' contains a control"),
    # names, titles and sizes
    ("title_too_long", ["--set", f'title="{"t" * (schema.MAX_TITLE + 1)}"'], "title must be one printable line"),
    ("title_two_lines", ["--set", 'title="a\\nb"'], "title must be one printable line"),
    ("group_name_control", ["--set", 'mesh.neumann=["top\\u0007"]'], "mesh.neumann: group name"),
    ("cells_beyond_indices", ["--set", "mesh.cells=[10000000000000000000000, 2]"], "mesh.cells"),
    ("too_many_levels", ["--refine", "uniform", "--levels", str(schema.MAX_LEVELS + 1)], "levels must be <="),
    ("quadrature_degree", ["--set", "estimator.cell_quadrature_degree=1000000"],
     "estimator.cell_quadrature_degree must be <="),
    ("problem_file_name_too_long", [], "problem file '…aaaaa"),  # (made in the test: its end is shown)
    ("nested_toml", [], "nests arrays or tables too deeply"),  # the file is made in the test
    ("nested_dotted_keys", [], "deep"),  # (made in the test; Python 3.13's tomllib refuses it itself)
    ("nested_set", ["--set", ".".join(["contact"] * 3000) + "=1"], "'contact.contact.contact"),
    ("integer_beyond_python", ["--set", f"material.E=1{'0' * 5000}"], "--set value"),
    ("cells_of_400_digits", ["--set", f"mesh.cells=[6, 1{'0' * 400}]"], "mesh.cells"),
    # a reference that does not fit the mesh, caught before the solve (a gmsh mesh has no dimension
    # in the problem file)
    ("hertz_sphere_on_2d", ["hertz", "--set", 'reference.hertz="sphere"'], "reference.hertz = 'sphere' does not fit a 2D mesh"),
]


def _args(name, tmp_path, args):
    if name == "problem_file_name_too_long":
        return [str(tmp_path / ("a" * 300 + ".toml")), *FAST]
    if name == "nested_toml":
        path = tmp_path / "deep.toml"
        path.write_text("title = " + "[" * 3000 + "]" * 3000 + "\n")
        return [str(path), *FAST]
    if name == "nested_dotted_keys":
        path = tmp_path / "deep.toml"
        path.write_text(".".join(["deep"] * 3000) + " = 1\n")
        return [str(path), *FAST]
    if args and args[0] == "hertz":
        return [*args, "--refine", "none", "--quiet"]
    return ["block", *FAST, *args]


@pytest.mark.parametrize("name, args, expected", CASES, ids=[c[0] for c in CASES])
def test_refused_with_one_line(tmp_path, name, args, expected):
    out = tmp_path / "out"
    result = cli([*_args(name, tmp_path, args), "--out", out])
    assert_bad_input(result, expected, out)


@pytest.mark.parametrize("name", ["load_overflows", "estimator_overflows"])
def test_refused_with_one_line_on_two_ranks(tmp_path, name):
    """The check on the mesh (each rank holds part of it) and the one after the estimate end every rank."""
    out = tmp_path / "out"
    _, args, expected = next(c for c in CASES if c[0] == name)
    result = cli([*_args(name, tmp_path, args), "--out", out], nprocs=2)
    assert_bad_input(result, expected, out, nprocs=2)


def test_hertz_reference_without_contact_force_is_a_warning(tmp_path):
    """c_n = 0 is valid input: the run completes, and the summary says why no reference is given."""
    out = tmp_path / "out"
    result = cli(["hertz", "--refine", "none", "--quiet", "--set", "contact.c_n=0", "--out", out])
    assert result.returncode == 0, result.stdout + result.stderr
    data = summary(out)
    assert data["status"] == "completed" and data["reference"] == []
    assert any("contact force is zero" in w for w in data["warnings"])
    assert "contact force is zero" in result.stdout


@pytest.mark.parametrize("nprocs", [1, 2])
def test_groups_in_no_role_are_reported(tmp_path, nprocs):
    """'right' left out of mesh.neumann is traction-free, as before, and now said so once."""
    out = tmp_path / "out"
    result = cli(["block", *FAST, "--set", 'mesh.neumann=["top"]', "--set", 'loads.g={top=["0", "-20*x"]}',
                  "--out", out], nprocs=nprocs)
    assert result.returncode == 0, result.stdout + result.stderr
    lines = [line for line in result.stdout.splitlines() if "in no role" in line]
    assert len(lines) == 1 and "'right'" in lines[0] and lines[0].startswith("nc_dolfinx: warning:")
    assert [w for w in summary(out)["warnings"] if "in no role" in w] == [lines[0].split("warning: ", 1)[1]]


def test_built_in_cases_warn_of_nothing(tmp_path):
    """The shipped cases name every group and fit their references (a warning there would teach users to
    ignore warnings)."""
    cases = [line.split()[0] for line in cli(["--list"]).stdout.splitlines() if line.strip()]
    assert len(cases) >= 8 and all((ROOT / "nc_dolfinx" / "cases" / f"{name}.toml").is_file() for name in cases)
    result = cli([*cases, "--refine", "none", "--quiet", "--out", tmp_path / "out"], timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    for warning in ("in no role", "no Hertz contact"):  # (manufactured: large u on purpose, doubtful)
        assert warning not in result.stdout, result.stdout


def test_valid_extremes_run_with_finite_numbers(tmp_path):
    """Large data whose squares (in η) are still doubles run: every number of the history is finite."""
    out = tmp_path / "out"
    result = cli(["block", *FAST, "--set", "material.E=1e100", "--set", 'loads.f=["0", "-1e100"]',
                  "--set", "contact.c_n=1e100", "--set", 'loads.g={top=["0", "-1e100*x"]}', "--out", out])
    assert result.returncode == 0, result.stdout + result.stderr
    rows = json.loads((out / "history.json").read_text())
    assert all(math.isfinite(v) for row in rows for v in row.values() if isinstance(v, float))


# --- the pieces, in the process -------------------------------------------------------------------------

def test_values_at_follows_the_forms_arithmetic():
    points = np.array([[0.0, 0.0], [1.0, 2.0], [-3.0, 0.5]])
    x, y = points.T
    assert np.allclose(expressions.values_at("2*(1 + x) - pos(y - 1)**1.5 + max(x, 0)", points, {}),
                       2 * (1 + x) - np.maximum(y - 1, 0) ** 1.5 + np.maximum(x, 0))
    assert np.allclose(expressions.values_at("k*sin(pi*x)", points, {"k": 3.0}), 3 * np.sin(np.pi * x))
    assert np.all(expressions.values_at(2.5, points) == 2.5)
    assert np.isinf(expressions.values_at("exp(1000*(x + 2))", points)).any()
    assert np.isnan(expressions.values_at("sqrt(-1 - x*x)", points)).all()


def test_depth_limit_is_the_nesting_not_the_length():
    ok = "+".join(["x*y"] * (expressions.MAX_DEPTH - 1))  # as deep as allowed: 498 sums, a product, a name
    expressions.check(ok)
    with pytest.raises(InputError, match="nested more than"):
        expressions.check(DEEP_SUM)
    with pytest.raises(InputError, match="malformed expression|nested more than"):  # (Python's parser: 200)
        expressions.check("(" * 5000 + "x" + ")" * 5000)


def test_messages_quote_values_briefly():
    assert len(brief("a" * 10_000)) < 100 and "10002 characters" in brief("a" * 10_000)
    assert brief(10 ** 5000) == "<a int too large to show>"
    assert brief_text("x\0y") == "x\\x00y" and brief_text("x + y") == "x + y"


# --- the leftovers of issue 48's fuzz and messages ----------------------------------------------------------

@pytest.mark.parametrize("name, contents, expected", [
    ("empty", "", "is empty: a problem needs at least [mesh]"),
    ("blank", "  \n\t\n", "is empty: a problem needs at least [mesh]"),
    ("deep", "a = " + "[" * 12 + "1" + "]" * 12 + "\n", "deeper than any key of a problem"),
])
def test_a_problem_file_with_nothing_or_too_much_in_it_is_named(tmp_path, name, contents, expected):
    path = tmp_path / f"{name}.toml"
    path.write_text(contents)
    result = cli([path, "--quiet"], cwd=tmp_path)
    assert_bad_input(result, expected, tmp_path / "results")
    assert f"{name}.toml" in result.stdout + result.stderr  # the file, named


def test_a_subnormal_young_s_modulus_is_refused(tmp_path):
    result = cli(["block", *FAST, "--set", "material.E=5e-324", "--out", tmp_path / "out"])
    assert_bad_input(result, "material.E must be at least", tmp_path / "out")


def test_a_tab_in_an_expression_is_whitespace(tmp_path):
    result = cli(["block", *FAST, "--set", 'contact.c_n=" 1e3\\t"', "--out", tmp_path / "out"])
    assert result.returncode == 0, result.stdout + result.stderr
    rows = json.loads((tmp_path / "out" / "history.json").read_text())
    assert rows[-1]["contact_resultant"] > 0  # c_n = 1e3 was read: the foundation carries load


def test_a_negative_friction_coefficient_is_refused_with_its_value(tmp_path):
    result = cli(["cattaneo", "--quiet", "--set", "parameters.mu=-0.3", "--out", tmp_path / "out"])
    assert_bad_input(result, "contact.friction must be >= 0, got 'mu' = -0.3", tmp_path / "out")


def test_command_line_options_given_as_overrides_say_what_an_override_is():
    import nc_dolfinx as nc
    with pytest.raises(InputError, match="'--refine' is a command-line option; an override is 'section.key=value'"):
        nc.load_problem("block", ["--refine", "none"])


def test_adapt_takes_the_settings_of_adapt_settings_by_name():
    import nc_dolfinx as nc
    problem = nc.load_problem("block", ["mesh.cells=[4,2]"])
    assert len(nc.adapt(problem, levels=2, refine="uniform").history) == 2
    with pytest.raises(TypeError, match="unknown adapt setting"):
        nc.adapt(problem, levles=2)
    with pytest.raises(TypeError, match="not both"):
        nc.adapt(problem, nc.AdaptSettings.from_problem(problem), levels=2)


def test_a_load_just_beyond_friction_shows_the_digits_that_exceed_one():
    from nc_dolfinx.solver.settling import _beyond_one
    assert [_beyond_one(r) for r in (1.001, 1.0000004, 1.02, 2.5)] == ["1.001", "1.0000004", "1.02", "2.5"]
