"""Load paths ([[steps]]): each step solved from the previous state in its increments.

Without friction the solution of (7) is unique and depends only on the data, so a path's every state must
equal a direct solve of the problem at that state's parameters; the applied load's resultant is known in
closed form along the path; the history and solution.pvd carry one time step per state; and 1, 2 and 3
ranks give the same path (the adaptive meshes included).
"""
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import nc_dolfinx as nc
from conftest import history, run_cli

# block with its top traction scaled by a parameter p: ∫_Ω f = (0, −10·2) and ∫_top g = (0, −p ∫_0^2 x dx)
PATH = ["--set", "parameters.p=0", "--set", 'loads.g.top=["0", "-p*x"]',
        "--set", 'steps=[{set = {p = 10}}, {set = {p = "2*p"}, increments = 3}]']
P_OF_STATE = [10.0, 40.0 / 3, 50.0 / 3, 20.0]


def applied_y(p):
    return -10.0 * 2.0 - p * 2.0


def block_on_path(**changes):
    problem = nc.load_problem("block", ["mesh.cells=[8,4]", "parameters.p=0", 'loads.g.top=["0", "-p*x"]'])
    raw = dict(problem.raw, steps=[{"set": {"p": 10}}, {"set": {"p": "2*p"}, "increments": 3}], **changes)
    return nc.Problem.from_dict(raw, "block-path")


def test_states_move_the_parameters_linearly():
    states = list(block_on_path().load_path())
    assert [(s.step, s.increment, s.increments) for s in states] == [(1, 1, 1), (2, 1, 3), (2, 2, 3), (2, 3, 3)]
    assert [s.problem.parameters["p"] for s in states] == pytest.approx(P_OF_STATE, rel=1e-15)
    assert [s.time for s in states] == pytest.approx([1, 4 / 3, 5 / 3, 2], rel=1e-15)
    assert states[-1].problem.parameters["p"] == 20.0  # a step's end exactly, not by interpolation
    assert all(not s.problem.values["steps"] for s in states)


def test_a_parameter_defined_by_another_follows_it():
    problem = nc.load_problem("block", ["parameters.a=1", 'parameters.b="3*a"'])
    raw = dict(problem.raw, steps=[{"set": {"a": 2}, "increments": 2}])
    states = list(nc.Problem.from_dict(raw).load_path())
    assert [s.problem.parameters["b"] for s in states] == pytest.approx([4.5, 6.0], rel=1e-15)


def test_every_state_equals_a_direct_solve():
    """Frictionless normal compliance has one solution per data: a path state solved from the previous
    one equals the problem solved from zero at the same parameters (to the solver's tolerance)."""
    problem = block_on_path()
    result = nc.adapt(problem, nc.AdaptSettings(refine="none"))
    assert [row["step"] for row in result.history] == [1, 2, 2, 2]
    for row, p in zip(result.history, P_OF_STATE):
        assert row["applied_load"] == pytest.approx([0.0, applied_y(p)], rel=1e-12, abs=1e-12)
        assert row["force_balance"] < 1e-8
    direct = nc.solve(problem.at_parameters({"p": 20.0}), result.final.solution.domain)
    u_path, u_direct = result.final.u.x.array, direct.u.x.array
    assert np.max(np.abs(u_path - u_direct)) <= 1e-8 * np.max(np.abs(u_direct))


def test_a_problem_without_steps_has_no_path_columns():
    result = nc.adapt(nc.load_problem("block", ["mesh.cells=[8,4]"]), nc.AdaptSettings(refine="none"))
    assert not {"step", "increment", "load_time"} & set(result.history[0])


@pytest.fixture(scope="module")
def path_runs(tmp_path_factory):
    out = {}
    for nprocs in (1, 2, 3):
        target = tmp_path_factory.mktemp(f"path-{nprocs}")
        proc = run_cli(["block", "--refine", "adaptive", "--levels", "2", *PATH, "--out", target], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = target
    return out


def test_history_and_pvd_carry_the_states(path_runs):
    rows = history(path_runs[1])
    assert [(r["step"], r["increment"]) for r in rows] == [(1, 1), (1, 1), (2, 1), (2, 2), (2, 3), (2, 3)]
    assert [r["dofs"] for r in rows[1:5]] == [rows[1]["dofs"]] * 4  # increments solve on the step's mesh
    assert rows[5]["dofs"] > rows[4]["dofs"] > rows[0]["dofs"]  # refinement after each step's last increment
    for row in rows:  # p = 10 at the end of step 1 (time 1), then linear to 20 at time 2
        assert row["applied_load"][1] == pytest.approx(applied_y(10.0 * row["load_time"]), rel=1e-12)
    pvd = ET.parse(path_runs[1] / "solution.pvd").getroot()
    steps = [(float(d.get("timestep")), d.get("file")) for d in pvd.iter("DataSet")]
    assert [t for t, _ in steps] == pytest.approx([1, 4 / 3, 5 / 3, 2])
    assert [f for _, f in steps] == ["levels/level_01.pvtu", "levels/level_02.pvtu", "levels/level_03.pvtu",
                                     "levels/level_05.pvtu"]  # each state's finest mesh
    assert all((path_runs[1] / f).exists() for _, f in steps)
    summary = json.loads((path_runs[1] / "summary.json").read_text())
    assert summary["status"] == "completed"


@pytest.mark.parametrize("nprocs", [2, 3])
def test_path_is_the_same_on_1_2_3_ranks(path_runs, nprocs):
    serial, parallel = history(path_runs[1]), history(path_runs[nprocs])
    assert [(r["dofs"], r["marked"] if "marked" in r else None) for r in serial] == \
        [(r["dofs"], r["marked"] if "marked" in r else None) for r in parallel]
    for s, p in zip(serial, parallel):
        for key in ("eta", "eta_2", "eta_4", "elastic_energy", "load_time"):
            assert p[key] == pytest.approx(s[key], rel=1e-8), key
        assert p["contact_force"] == pytest.approx(s["contact_force"], rel=1e-8, abs=1e-12)


STIFFENING = ["block", "--refine", "none", "--set", "mesh.cells=[8,4]", "--set", "parameters.cn=2000",
              "--set", 'contact.c_n="cn*(1 + x)"', "--set", "steps=[{set = {cn = 2000}}, {set = {cn = 2e8}}]"]


def test_a_failing_step_keeps_the_finished_ones_and_is_named(tmp_path):
    unlimited = tmp_path / "unlimited"
    assert run_cli([*STIFFENING, "--out", unlimited]).returncode == 0
    counts = [row["newton_iterations"] for row in history(unlimited)]
    assert counts[1] > counts[0], counts  # the stiff step needs more Newton steps than the first
    out = tmp_path / "out"
    proc = run_cli([*STIFFENING, "--out", out, "-snes_max_it", str(counts[0]), "-fallbacks", "false"])
    errors = [line for line in (proc.stdout + proc.stderr).splitlines() if line.startswith("nc_dolfinx: error:")]
    assert proc.returncode == 1 and len(errors) == 1, proc.stdout + proc.stderr
    assert "level 1, after step 1 increment 1: SNES diverged" in errors[0]
    summary = json.loads((out / "summary.json").read_text())
    assert (summary["status"], summary["levels"]) == ("failed", 1)
    assert [(r["step"], r["increment"]) for r in history(out)] == [(1, 1)]
    pvd = ET.parse(out / "solution.pvd").getroot()
    assert [d.get("file") for d in pvd.iter("DataSet")] == ["levels/level_00.pvtu"]


BAR = {"parameters": {"delta": 0.0},
       "mesh": {"rectangle": [[0.0, 0.0], [2.0, 1.0]], "cells": [8, 4], "dirichlet": ["left", "right"],
                "symmetry": ["bottom"], "contact": ["top"]},
       "material": {"E": 1.0e3, "nu": 0.3},
       "loads": {"u_D": {"left": ["0", "free"], "right": ["delta", "free"]}},
       "contact": {"c_n": 1.0e3, "m_n": 1.0, "gap": 1.0},
       "steps": [{"set": {"delta": 0.01}}, {"set": {"delta": 0.03}, "increments": 2}]}


def test_a_force_displacement_curve_along_the_path():
    """A bar in uniaxial plane-strain stress pulled by its right end u_x = δ: the reaction there is
    E/(1 − ν²) δ/L · H at every state (the bar of tests/test_prescribed.py), the left one its opposite. The
    path starts from δ = 0, an unloaded problem, which is not solved: its steps are."""
    result = nc.adapt(nc.Problem.from_dict(BAR), nc.AdaptSettings(refine="none"))
    stiffness = 1.0e3 / (1 - 0.3**2) / 2.0 * 1.0
    for row, delta in zip(result.history, [0.01, 0.02, 0.03]):
        assert row["reaction_right"][0] == pytest.approx(stiffness * delta, rel=1e-10)
        assert row["reaction_left"][0] == pytest.approx(-stiffness * delta, rel=1e-10)


def test_a_step_that_leaves_the_problem_unloaded_is_refused():
    raw = dict(BAR, steps=[{"set": {"delta": 0.01}}, {"set": {"delta": 0.0}}])
    with pytest.raises(nc.InputError, match=r"steps\[2\] leads to a bad problem: the problem has no load"):
        nc.Problem.from_dict(raw)
