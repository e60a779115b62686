"""Cattaneo–Mindlin partial slip of a sphere: the ``cattaneo3d`` case (a half ball on a nearly rigid
foundation, pressed, then pushed sideways with Coulomb friction), verification/cattaneo3d.py's measures.

Tolerances, from the measurements of docs/src/cattaneo3d.md (shipped mesh, size h = R/100 ≈ a/10 at the
contact): the contact radius a = sqrt(2A/π) is 2.5 % below Hertz's (−1.0 % on a mesh of size a/16: the
edge of {p > 0} is located within a cell, and the penalty c_n = 1e3 E widens it slightly), so 5 % is
asserted; the friction law's own contact measure (its vertices in contact, weighted by ∫ φ_i) is 3.7 %
above the normal law's A (the edge counted by whole vertex patches), so 6 % is asserted; the stick radius
c over a, sqrt(A_stick/(A_stick + A_slip)) in the law's classification at the vertices, is within 2.1 % of
Cattaneo–Mindlin's (1 − Q/(μP))^(1/3) for Q/(μP) = 0.18–0.50 (+1.8, +2.1, +0.1 %; 4.5–6.2 % below it
before issue 50, when a lumped projection classified the vertices), so 4 % is asserted, with the trend
(the stick zone shrinks as Q grows). The case runs in about 25 s serially.
"""
import json

import numpy as np
import pytest

import nc_dolfinx as nc
from conftest import ROOT, run

SCRIPT = ROOT / "tests" / "mpi" / "cattaneo3d_quantities.py"


@pytest.fixture(scope="module")
def tangential_loading():
    import sys
    sys.path.insert(0, str(ROOT / "verification"))
    from cattaneo3d import run as run_case
    return run_case()


def test_contact_radius_against_hertz(tangential_loading):
    rows, _, _ = tangential_loading
    for row in rows:
        assert abs(row["a_error"]) < 0.05, row
        assert row["stick_area"] + row["slip_area"] == pytest.approx(row["contact_area"], rel=0.06)


def test_stick_radius_against_cattaneo_mindlin(tangential_loading):
    rows, _, _ = tangential_loading
    assert len(rows) == 3
    ratios = [row["Q/muP"] for row in rows]
    assert 0.1 < ratios[0] < ratios[1] < ratios[2] < 0.7  # partial slip, growing Q at constant P
    for row in rows:
        assert abs(row["c/a_error"]) < 0.04, row
    sticks = [row["stick_area"] for row in rows]
    assert sticks[0] > sticks[1] > sticks[2] > 0


def test_friction_switched_on_without_motion_sticks_everywhere():
    """The case's step 2 sets μ without moving anything: its initial guess (the pressed state) already
    solves it, the whole contact zone sticks and carries no tangential force. (Before a one-line fix in
    nc_dolfinx/solver/newton.py such a step raised AttributeError: the fixed point on the friction bound
    read a target that the early return of an already converged solve had not set.)"""
    problem = nc.load_problem("cattaneo3d")
    raw = dict(problem.raw)
    raw["steps"] = raw["steps"][:2]
    result = nc.adapt(nc.Problem.from_dict(raw, "cattaneo3d-steps12", source=problem.source))
    pressed, switched = result.history
    assert pressed["stick_area"] == 0.0 and switched["slip_area"] == 0.0
    # (the same vertices in contact: the law's measure of them)
    assert switched["stick_area"] == pytest.approx(pressed["slip_area"], rel=1e-9)
    assert np.abs(switched["friction_force"]).max() < 1e-9 * switched["contact_resultant"]


def test_two_ranks_give_the_same_forces_and_stick_zone(tangential_loading):
    """The case on 2 ranks (tests/mpi/cattaneo3d_quantities.py) against the serial run of the fixture: the
    same P, Q and contact area to the solver's tolerance, the same stick and slip areas."""
    out = run([SCRIPT], 2)
    assert out.returncode == 0, out.stderr[-3000:]
    parallel, serial = json.loads(out.stdout.strip().splitlines()[-1]), tangential_loading[0][-1]
    for key in ("P", "Q", "contact_area"):
        assert parallel[key] == pytest.approx(serial[key], rel=1e-7), key
    for key in ("stick_area", "slip_area"):
        assert parallel[key] == pytest.approx(serial[key], rel=1e-6), key
