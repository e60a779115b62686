"""What a load path shows its user (issue 48, item 4): forces that balance on a curved Γ_C that sticks, the
path's parameters as columns, load_path.png, progress lines per increment, every n-th state written,
--load-steps refused beside [[steps]], and the CSV's column names through the API.

The case: a coarse half-disc (meshes/halfdisc.py, h = R/4, its circle given) pressed with friction on, slid
to dt = 0.002, back to −0.002 and back to 0, refined adaptively after every step. The friction force used to
be ∫_Γ_C s_t, while the residual carries j_t(u_h, v) = −∫_Γ_C s_t·v_t (the tangential part of v, normal to
the vertex normal N): on a mesh refined onto the circle, the law's memory carried over has a part along the
new N, and force_balance was 2.3e-5 to 2.0e-4 on every state after the first refinement (1e-14 before it).
The reported forces are now the residual's own vectors' resultants: 1e-10 or less on every row.
"""
import csv
import json
from pathlib import Path

import numpy as np
import pytest

import nc_dolfinx as nc
from nc_dolfinx.adaptive import progress_line
from nc_dolfinx.output import columns, plots

from conftest import PYTHON, ROOT, history, run_cli, summary

H = 0.25
DT = [0.0, 0.001, 0.002, 0.001, 0.0, -0.001, -0.002, -0.001, 0.0]  # dt at the path's states (after the press)
PROBLEM = """title = "half-disc pressed, slid to and fro with friction"
[parameters]
E = 1.0e3
dn = 0.0
dt = 0.0
[mesh]
file = "{mesh}"
dirichlet = ["top"]
neumann = ["free"]
contact = ["contact"]
[mesh.shapes.contact.circle]
centre = [0, 1]
radius = 1
[mesh.shapes.free.circle]
centre = [0, 1]
radius = 1
[material]
E = "E"
nu = 0.3
[loads]
u_D = ["dt", "-dn"]
[contact]
c_n = "1.0e3*E"
m_n = 1
gap = "y"
friction = 0.3
[adapt]
refine = "adaptive"
levels = 2
[[steps]]
set = {{ dn = 0.01 }}
[[steps]]
set = {{ dt = 0.002 }}
increments = 2
[[steps]]
set = {{ dt = -0.002 }}
increments = 4
[[steps]]
set = {{ dt = 0.0 }}
increments = 2
"""
OPTIONS = ["--set", 'output.load_path_x="dt"', "--write-every", "2"]


@pytest.fixture(scope="module")
def problem_file(tmp_path_factory):
    import subprocess
    folder = tmp_path_factory.mktemp("half_disc_path")
    mesh = folder / "halfdisc.msh"
    subprocess.run([PYTHON, str(ROOT / "meshes" / "halfdisc.py"), repr(H), str(mesh)], check=True,
                   capture_output=True, timeout=300)
    path = folder / "path.toml"
    path.write_text(PROBLEM.format(mesh=mesh))
    return path


@pytest.fixture(scope="module")
def runs(problem_file, tmp_path_factory):
    """The CLI on 1 and 3 ranks: {ranks: (CompletedProcess, out folder)}."""
    done = {}
    for n in (1, 3):
        out = tmp_path_factory.mktemp(f"out{n}") / "run"
        done[n] = (run_cli([problem_file, "--out", out, *OPTIONS], n), out)
        assert done[n][0].returncode == 0, done[n][0].stdout[-3000:] + done[n][0].stderr[-3000:]
    return done


def states(rows):
    return plots.path_states(rows)


@pytest.mark.parametrize("n", [1, 3])
def test_forces_balance_where_a_curved_contact_sticks(runs, n):
    """Every row, before and after each refinement onto the circle: applied + contact + friction +
    reaction = 0 to the solver's tolerance (was 2.8e-6 after the first refinement); the contact sticks in
    part and the friction force has its vertical part on the curved Γ_C."""
    rows = history(runs[n][1])
    assert len(rows) == 13
    for row in rows:
        assert row["force_balance"] < 1e-9, (row["level"], row["force_balance"])
        total = np.add(row["reaction_top"], row["contact_force"]) + row["friction_force"]
        assert np.abs(total).max() < 1e-8 * abs(row["reaction_top"][1]), row["level"]
    assert any(row["stick_length"] > 0 for row in rows)
    refined = [row for row in rows if "time_refine" in row and row["step"] >= 2]
    assert refined and all(abs(row["friction_force"][1]) > 1e-3 for row in refined)


def test_the_ranks_give_the_same_path(runs):
    """1 and 3 ranks: the same rows (forces, zones, parameters) to the solver's tolerance."""
    serial, parallel = (history(runs[n][1]) for n in (1, 3))
    assert [(r["step"], r["increment"], r["dofs"]) for r in serial] == \
           [(r["step"], r["increment"], r["dofs"]) for r in parallel]
    for a, b in zip(serial, parallel):
        for key in ("reaction_top", "friction_force", "contact_force"):
            np.testing.assert_allclose(b[key], a[key], rtol=1e-6, atol=1e-8 * abs(a["reaction_top"][1]))
        for key in ("stick_length", "slip_length", "param_dt", "param_dn"):
            assert b[key] == pytest.approx(a[key], rel=1e-6, abs=1e-10), key


def test_the_parameters_are_columns(runs):
    """param_dn and param_dt at every state, exactly where the path puts them; described in summary.json."""
    out = runs[1][1]
    rows = history(out)
    assert [row["param_dn"] for row in states(rows)] == [0.01] * 9
    assert [row["param_dt"] for row in states(rows)] == pytest.approx(DT, abs=1e-15)
    with open(out / "history.csv") as fh:
        header = next(csv.reader(fh))
    assert {"param_dn", "param_dt", "friction_force_x", "friction_force_y"} <= set(header)
    assert "'dt'" in summary(out)["columns"]["param_dt"]


def test_load_path_plot_shows_the_hysteresis(runs):
    """load_path.png is drawn beside convergence.png; its curves against dt are the path's states, and the
    friction force at dt = 0 differs between the ways there (a cycle's hysteresis, not one line)."""
    out = runs[1][1]
    assert (out / "load_path.png").stat().st_size > 10_000 and (out / "convergence.png").exists()
    xs, curves = plots.load_path_curves(history(out), "param_dt")
    assert xs == pytest.approx(DT, abs=1e-15)
    assert set(curves) == {"reaction_top", "friction_force"}
    assert set(curves["friction_force"]) == {"friction_force_x", "friction_force_y"}
    q = curves["friction_force"]["friction_force_x"]
    at_zero = q[[i for i, x in enumerate(xs) if x == 0.0]]
    assert len(at_zero) == 3 and np.ptp(at_zero) > 0.02 * np.abs(q).max()
    assert q[2] < 0 < q[6]  # the friction force opposes the slide


def test_progress_lines_count_increments(runs):
    """One line per row: "step s, increment k of N", ", refined" on a refined mesh, the largest slip;
    no path row is called a level."""
    lines = [line for line in runs[1][0].stdout.splitlines() if line.startswith("step ")]
    assert len(lines) == 13
    assert lines[0].startswith("step 1, increment 1 of 1 (row 0):")
    assert lines[1].startswith("step 1, increment 1 of 1, refined (row 1):")
    assert lines[7].startswith("step 3, increment 3 of 4 (row 7):")
    assert all("max slip = " in line for line in lines)
    assert not any(line.startswith("level") for line in runs[1][0].stdout.splitlines())
    assert "at step 4, increment 2 (row 12)" in runs[1][0].stdout


def test_every_second_state_is_written(runs):
    """--write-every 2: the even increments and every step's last state (each of its levels); all rows are
    in the history; solution.pvd lists the written states only."""
    out = runs[1][1]
    written = sorted(int(p.stem.split("_")[1]) for p in (out / "levels").glob("level_*.pvtu"))
    assert written == [0, 1, 3, 4, 6, 8, 9, 11, 12]
    pvd = (out / "solution.pvd").read_text()
    assert pvd.count("<DataSet") == 5 and "level_06.pvtu" in pvd and "level_05" not in pvd
    assert summary(out)["status"] == "completed" and (out / "solution.xdmf").exists()


def test_load_steps_beside_steps_is_refused(problem_file, tmp_path):
    """--load-steps splits level 0's solve: on a path it is one clear error naming [[steps]].increments."""
    result = run_cli([problem_file, "--load-steps", "3", "--out", tmp_path / "out"])
    assert result.returncode == 1
    line = result.stdout.strip().splitlines()[-1] + result.stderr
    assert "--load-steps = 3" in line and "[[steps]].increments" in line, line
    assert not (tmp_path / "out").exists()


def test_an_abscissa_that_is_no_parameter_of_the_path_is_refused(problem_file, tmp_path):
    result = run_cli([problem_file, "--set", 'output.load_path_x="E"', "--out", tmp_path / "out"])
    assert result.returncode == 1
    assert "output.load_path_x = 'E'" in result.stdout + result.stderr and "dn, dt" in result.stdout + result.stderr


def test_api_rows_answer_to_the_csv_names():
    """A row of nc.adapt's history: row["friction_force_x"] is row["friction_force"][0] (the CSV's column),
    in and get too; the stored keys (and JSON) keep the vectors as lists."""
    problem = nc.load_problem("cattaneo", ["steps=[{set = {dn = 0.01, mu = 0.3}}]"])
    row = nc.adapt(problem).history[-1]
    assert row["friction_force_x"] == row["friction_force"][0] != 0
    assert row["reaction_top_y"] == row["reaction_top"][1] < 0
    assert "contact_force_y" in row and "contact_force_z" not in row and row.get("friction_force_z") is None
    assert "friction_force_x" not in list(row) and json.loads(json.dumps(row))["friction_force"] == row["friction_force"]
    with pytest.raises(KeyError):
        row["friction_force_q"]
    assert row["force_balance"] < 1e-9


def test_the_parameter_columns_follow_expressions():
    """path_parameters: a parameter defined by an expression of a moved one follows it (b = 3a) until a
    step sets it; each step moves its parameters from where the previous one left them."""
    problem = nc.load_problem("block", ["parameters.a=1", 'parameters.b="3*a"', "parameters.p=0",
                                        'steps=[{set = {a = 2}, increments = 2}, {set = {p = 10, b = 0}, increments = 4}]'])
    assert columns.path_parameters(problem, {"step": 1, "increment": 1, "load_time": 0.5}) == \
        {"param_a": 1.5, "param_p": 0.0, "param_b": 4.5}
    assert columns.path_parameters(problem, {"step": 2, "increment": 1, "load_time": 1.25}) == \
        {"param_a": 2.0, "param_p": 2.5, "param_b": 4.5}
    assert columns.path_parameters(problem, {"level": 0}) == {}


def test_progress_line_without_a_path_and_on_an_auto_step():
    base = {"level": 3, "dofs": 100, "newton_iterations": 2, "linear_iterations": 4, "time_solve": 0.1, "eta": 1.0}
    assert progress_line(base).startswith("level  3:   ")
    auto = dict(base, step=2, increment=3, load_time=1.375, increment_cuts=1)
    assert progress_line(auto).startswith("step 2, increment 3 (row 3):")  # N not known in advance
    fixed = dict(base, step=2, increment=3, load_time=1 + 3 / 7, max_slip=2e-3)
    assert progress_line(fixed).startswith("step 2, increment 3 of 7 (row 3):")
    assert progress_line(fixed).endswith(", max slip = 2.000e-03")


def test_write_every_without_a_path_writes_every_nth_level_and_the_last(tmp_path):
    out = tmp_path / "out"
    result = run_cli(["block", "--set", "mesh.cells=[4,2]", "--quiet", "--refine", "uniform", "--levels", "4",
                      "--write-every", "2", "--out", out])
    assert result.returncode == 0, result.stdout + result.stderr
    assert sorted(p.name for p in (out / "levels").glob("*.pvtu")) == ["level_00.pvtu", "level_02.pvtu",
                                                                        "level_03.pvtu"]
    assert len(history(out)) == 4 and not (out / "load_path.png").exists()
    assert "level 3" in result.stdout  # (a refinement level is still a level)


def test_the_api_rows_carry_the_path_parameters_and_refuse_load_steps():
    """Through nc.adapt too (not only the command line): a row of a path has param_NAME at its state, and
    solver.load_steps on a path is refused, as --load-steps is."""
    overrides = ["mesh.cells=[8,4]", "parameters.p=0", 'loads.g.top=["0", "-p*x"]',
                 'steps=[{set = {p = 10}}, {set = {p = "2*p"}, increments = 3}]']
    rows = nc.adapt(nc.load_problem("block", overrides), refine="none").history
    assert [row["param_p"] for row in rows] == pytest.approx([10.0, 40.0 / 3, 50.0 / 3, 20.0], rel=1e-15)
    with pytest.raises(nc.InputError, match="solver.load_steps = 3 splits the loads of a single solve"):
        nc.adapt(nc.load_problem("block", overrides + ["solver.load_steps=3"]), refine="none")
