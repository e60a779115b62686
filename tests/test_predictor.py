"""The predictors of a load path's increments (``solver.predictor``, issue 48): none, secant, tangent and auto.

The tangent predictor (nc_dolfinx/solver/predictor.py) moves the Dirichlet values and loads to the
increment's end and makes one linear solve with the last converged state's preconditioner; like the secant
one it changes only Newton's initial guess, so a frictional path (the layer of tests/mpi/load_increments.py,
pressed, sheared and sheared back in fixed increments) reaches the same states with it as without a
predictor, to the solver's tolerance, on 1 and 2 ranks (tests/mpi/predictor.py). Without friction, on a
press in a nonlinear law, the tangent prediction saves Newton steps. ``auto`` resolves per law and dimension (adaptive.AUTO_PREDICTOR).
"""
import json

import numpy as np
import pytest

import nc_dolfinx as nc
from nc_dolfinx.adaptive import AUTO_PREDICTOR, predictor_of
from conftest import ROOT, import_script, run

SCRIPT = ROOT / "tests" / "mpi" / "predictor.py"
layer_script = import_script("tests/mpi", "load_increments")
TOL = 1e-8  # the solver stops at ‖F‖ <= 1e-10 ‖L‖: states agree to well within this (relative)


@pytest.mark.parametrize("nprocs", [1, 2])
def test_the_tangent_predictor_reaches_the_states_of_none_on_a_frictional_path(nprocs):
    proc = run([SCRIPT], nprocs, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    runs = json.loads(proc.stdout.strip().splitlines()[-1])
    assert runs["none"]["max_slip"] > 1e-3  # (the path slips: the law's memory matters)
    assert runs["tangent"]["predicted"] > 0, runs  # (the tangent prediction was kept on some increments)
    assert runs["tangent"]["rows"] == runs["none"]["rows"]
    assert runs["tangent"]["states"] <= TOL, runs
    assert runs["tangent"]["u"] <= TOL, runs


def pressed_layer(predictor):
    """The layer without friction on a quadratic foundation (m_n = 2), pressed in 4 increments and released
    in 2."""
    data = json.loads(json.dumps(layer_script.LAYER))
    del data["contact"]["friction"]
    data["contact"].update(m_n=2, c_n=100.0)
    data["steps"] = [{"set": {"w": 0.02}, "increments": 4}, {"set": {"w": 0.01}, "increments": 2}]
    data["solver"]["predictor"] = predictor
    return nc.Problem.from_dict(data, "layer-pressed")


def test_the_tangent_predictor_saves_newton_steps_without_friction():
    results = {name: nc.adapt(pressed_layer(name), nc.AdaptSettings(refine="none")) for name in ("none", "tangent")}
    newton = {name: sum(r["newton_iterations"] for r in result.history) for name, result in results.items()}
    assert newton["tangent"] < newton["none"], newton
    u, u_none = (results[name].final.u.x.array for name in ("tangent", "none"))
    assert np.max(np.abs(u - u_none)) <= TOL * np.max(np.abs(u_none))
    for r, o in zip(results["tangent"].history, results["none"].history):
        assert r["elastic_energy"] == pytest.approx(o["elastic_energy"], rel=TOL)


def test_auto_chooses_per_law_and_dimension():
    frictional, frictionless = layer_script.layer(predictor="auto"), pressed_layer("auto")
    for dim in (2, 3):
        assert predictor_of(frictional, dim) == AUTO_PREDICTOR[(True, dim)]
        assert predictor_of(frictionless, dim) == AUTO_PREDICTOR[(False, dim)]
    assert predictor_of(pressed_layer("none"), 2) == "none"
    assert set(AUTO_PREDICTOR.values()) <= {"secant", "tangent", "none"}
