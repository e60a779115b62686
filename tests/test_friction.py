"""Coulomb friction with normal compliance (nc_dolfinx.physics.friction): the exact sheared layer of
tests/mpi/sheared_layer.py in stick and slip, 2D and 3D, on 1, 2 and 3 ranks; μ = 0 against the
frictionless problem; the slip measured from the previous state of a load path; the estimator's η_3 as the
residual of the law; and the bad inputs of friction."""
import json

import numpy as np
import pytest
from mpi4py import MPI

import nc_dolfinx as nc
from conftest import ROOT, run
from mpi.sheared_layer import EPS_R, exact_state, held_problem, layer_problem, outcome
from nc_dolfinx.errors import InputError

SCRIPT = ROOT / "tests" / "mpi" / "sheared_layer.py"


@pytest.mark.parametrize("dim, mode, m_n", [(2, "stick", 1.0), (2, "slip", 1.0), (2, "slip", 1.5),
                                            (3, "stick", 1.0), (3, "slip", 1.5)])
def test_the_sheared_layer_is_exact(dim, mode, m_n):
    """Nodal values, the friction force (μP per unit base in slip, its stick fraction below), the pressure's
    resultant, the stick/slip measures and the slip against the exact solution; the estimator vanishes on
    the exact u (η_3 measures the law's residual, not σ_t, which is not zero here); forces balance. In slip
    the bound holds with equality (Gγ = μP), which leaves the slip s determined only through the normal
    law's d: it is met to 1e-6 relative, stick to round-off."""
    result = outcome(nc.adapt(layer_problem(dim, mode, m_n)), dim, mode, m_n)
    tolerance = 1e-10 if mode == "stick" else 1e-6
    assert result["nodal_error"] < tolerance
    assert result["friction_force"][0] == pytest.approx(result["exact_friction_force"], rel=tolerance)
    # (the off-slip components: zero in the exact state, met to the same accuracy as the slip's: the solve's
    # target, 1e-13 ‖L‖, bounds both; its last steps are GMRES solves of the consistent Newton finish, which
    # left 3.8e-11 of the force in 3D stick, 2.7e-11 in 3D slip)
    assert np.abs(result["friction_force"][1:]).max() < tolerance * abs(result["exact_friction_force"])
    assert result["contact_resultant"] == pytest.approx(result["exact_resultant"], rel=tolerance)
    assert result[mode] == pytest.approx(result["base"], rel=1e-12)
    assert result["stick" if mode == "slip" else "slip"] == 0.0
    assert result["max_slip"] == pytest.approx(result["exact_slip"], rel=1e-5)
    assert result["eta"] < 1e-8 * abs(result["exact_friction_force"])
    assert result["force_balance"] < 1e-9
    assert result["reaction_top"][0] == pytest.approx(-result["friction_force"][0], rel=1e-9)


@pytest.mark.parametrize("nprocs", [2, 3])
@pytest.mark.parametrize("dim, mode, path", [(2, "slip", ""), (3, "stick", ""), (2, "stick", "held")])
def test_ranks_give_the_same_layer(nprocs, dim, mode, path):
    """1, 2 and 3 ranks: the same nodal values (sorted by coordinates) and numbers; also at the end of the
    held load path (test_a_held_load_does_not_creep), whose state the return map moved on 4 times."""
    outputs = [run([SCRIPT, dim, mode, 1.0, *([path] if path else [])], n) for n in (1, nprocs)]
    for out in outputs:
        assert out.returncode == 0, out.stderr[-3000:]
    serial, parallel = (json.loads(out.stdout.strip().splitlines()[-1]) for out in outputs)
    scale = np.abs(serial["nodal_values"]).max()
    np.testing.assert_allclose(parallel["nodal_values"], serial["nodal_values"], atol=1e-9 * scale, rtol=0)
    for key in ("friction_force", "contact_resultant", "stick", "slip", "reaction_top"):
        np.testing.assert_allclose(parallel[key], serial[key], rtol=1e-8, atol=1e-12)
    if path:  # (and the held state is the exact one on every rank count)
        assert parallel["nodal_error"] < 1e-10 and parallel["max_slip"] < 1e-8 * parallel["exact_slip"]


def test_zero_friction_is_the_frictionless_problem():
    """friction = 0 solves exactly the problem without friction: u_h, η and the reactions agree to
    round-off (the friction term is zero, so only the solver's summation order can differ)."""
    frictional = layer_problem(2, "slip", 1.0, friction=0.0)
    raw = dict(frictional.raw)
    raw["contact"] = {k: v for k, v in raw["contact"].items() if k not in ("friction", "slip_regularisation")}
    frictionless = nc.Problem.from_dict(raw, "frictionless")
    results = [nc.adapt(p) for p in (frictional, frictionless)]
    u, v = (r.final.u.x.array for r in results)
    assert np.abs(u - v).max() <= 1e-12 * np.abs(v).max()
    rows = [r.history[-1] for r in results]
    assert rows[0]["eta"] == pytest.approx(rows[1]["eta"], rel=1e-10)
    np.testing.assert_allclose(rows[0]["reaction_top"], rows[1]["reaction_top"], rtol=1e-10)
    assert rows[0]["friction_force"] == [0.0, 0.0]


@pytest.mark.parametrize("cells, preset", [((8, 4), "direct"), ((100, 50), "iterative")])
def test_the_slip_is_measured_from_the_previous_state(cells, preset):
    """A load path: step 1 presses the layer without shear, step 2 shears it (in stick). The slip increment
    of step 2 is measured from step 1's state, whose base did not move tangentially, so step 2 ends at the
    exact layer; step 1's state is the pressed layer (no friction force). Step 2 is a warm start: above
    1e4 dofs ``auto`` solves it with BoomerAMG when there is friction (solver.linear.choose_preset)."""
    problem = layer_problem(2, "stick", 1.0)
    gamma, slip, *_ = exact_state(2, "stick", 1.0)
    raw = dict(problem.raw)
    raw["parameters"] = {"gamma": 0.0, "s": 0.0}
    e, depth = exact_state(2, "stick", 1.0)[2:4]
    u = ["gamma*y + s", f"-{e!r}*y - {depth!r}"]
    raw["loads"] = dict(raw["loads"], u_D=u)
    raw["exact"] = {"u": u}
    raw["steps"] = [{"set": {"gamma": 0.0}}, {"set": {"gamma": gamma, "s": slip}}]
    raw["mesh"] = dict(raw["mesh"], cells=list(cells))
    raw["solver"] = dict(raw["solver"], preset="auto")
    result = nc.adapt(nc.Problem.from_dict(raw, "layer-path"))
    first, second = result.history
    assert result.final.solution.stats.preset == preset
    loose = {"direct": 1.0, "iterative": 100.0}[preset]  # (exact steps; Krylov's tolerance: measured 1.3e-10)
    assert abs(first["friction_force"][0]) < 1e-12 * loose
    assert second["h1_error"] < 1e-10 * loose * first["elastic_energy"] ** 0.5
    assert second["max_slip"] == pytest.approx(slip, rel=1e-8 * loose)


def test_a_held_load_does_not_creep():
    """A load path: step 1 shears the layer in stick to its exact state, step 2 holds the same load over 4
    increments. The law keeps the tangential traction from one state to the next (physics/slip_state.py):
    every increment of step 2 ends at the same exact state, with no slip increment and the same friction
    force. A spring stretched anew each increment (the law without its memory) slid the base by the
    pre-slip s again in every increment of step 2 (H¹ error 1.8e-7 against the bound 1.6e-12)."""
    slip = exact_state(2, "stick", 1.0)[1]
    first, *held = nc.adapt(held_problem(2)).history
    assert len(held) == 4 and first["stick_length"] == pytest.approx(2.0, rel=1e-12)
    for row in held:
        assert row["h1_error"] < 1e-10 * first["elastic_energy"] ** 0.5
        assert row["max_slip"] < 1e-8 * slip
        assert row["friction_force"][0] == pytest.approx(first["friction_force"][0], rel=1e-10)
        assert row["stick_length"] == pytest.approx(2.0, rel=1e-12)


def test_eta_3_is_the_residual_of_the_law():
    """On the exact sheared layer σ_t(u_h) ≠ 0 (the friction force), so the frictionless η_3 (‖σ_t‖ on Γ_C)
    would not vanish; the law's residual does."""
    result = nc.adapt(layer_problem(2, "stick", 1.0))
    row = result.history[-1]
    sigma_t = abs(row["friction_force"][0]) / 2.0  # the uniform traction on a base of length 2
    assert sigma_t > 1e-3
    assert row["eta_3"] < 1e-8 * sigma_t  # (round-off of the solve: the frictionless η_3 would be ~ 1.4 σ_t)


@pytest.mark.parametrize("contact, message", [
    ({"friction": -0.1}, "contact.friction must be >= 0"),
    ({"friction": "-x"}, "contact.friction must be >= 0 on Γ_C"),
    ({"c_t": 1.0}, "contact.m_t is missing"),
    ({"m_t": 1.0}, "contact.c_t is missing"),
    ({"friction": 0.3, "c_t": 1.0, "m_t": 1.0}, "not both"),
    ({"slip_regularisation": 1e-3}, "has no effect without friction"),
    ({"friction": 0.3, "slip_regularisation": 0.0}, "contact.slip_regularisation"),
    ({"c_t": -1.0, "m_t": 1.0}, "contact.c_t must be >= 0"),
    ({"c_t": 1.0, "m_t": 0.5}, "contact.m_t"),
])
def test_bad_friction_input(contact, message):
    """Each bad friction input is one InputError naming the key."""
    raw = dict(layer_problem(2, "stick", 1.0).raw)
    base = {k: v for k, v in raw["contact"].items() if k not in ("friction", "slip_regularisation")}
    raw["contact"] = {**base, **contact}
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        problem = nc.Problem.from_dict(raw, "bad")
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))


def test_regularisation_default_and_limit():
    """ε_r defaults to 1e-3; in stick the computed slip is the pre-slip ε_r d Gγ/(μP) = 0.8 ε_r d: it scales
    with ε_r (→ 0: Coulomb's stick) while the friction force, which equilibrium fixes, hardly moves."""
    raw = dict(layer_problem(2, "stick", 1.0).raw)
    raw["contact"] = {k: v for k, v in raw["contact"].items() if k != "slip_regularisation"}
    assert nc.Problem.from_dict(raw, "default").values["contact"]["slip_regularisation"] == 1e-3
    depth = exact_state(2, "stick", 1.0)[3]
    rows = {}
    for eps_r in (EPS_R, EPS_R / 10):
        raw["contact"]["slip_regularisation"] = eps_r
        rows[eps_r] = nc.adapt(nc.Problem.from_dict(raw, f"eps{eps_r}")).history[-1]
        assert rows[eps_r]["max_slip"] == pytest.approx(0.8 * eps_r * depth, rel=1e-6)
    # (the clamp's displacement holds the first pre-slip, so the second's shear differs by ~ s/(γH) ≈ 1e-5)
    assert rows[EPS_R / 10]["friction_force"][0] == pytest.approx(rows[EPS_R]["friction_force"][0], rel=1e-4)


def test_the_consistent_jacobian_is_the_derivative_of_the_residual():
    """The Jacobian of the solver's Newton finish (solver/fixed_point.py), K + j_n' + (d/du) j_t with the bound
    of u itself, against central differences of the residual along a smooth direction, at a solved state with
    stick and slip zones (the square pressed by its weight, clamped on top): equal to 1e-8 (measured 9e-13:
    the law is piecewise polynomial away from its kinks). The frozen-bound Jacobian of the passes misses the
    bound's dependence on u_n (measured 2.5e-3 off): so the test can tell them apart."""
    import ufl
    from petsc4py import PETSc
    from dolfinx import fem
    import dolfinx.fem.petsc as fem_petsc
    from nc_dolfinx import dolfinx_versions as versions
    from nc_dolfinx.physics.forms import normal_compliance_forms
    data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [8, 8], "dirichlet": ["top"],
                     "neumann": ["left", "right"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "-0.5"]},
            "contact": {"c_n": 100.0, "m_n": 2.0, "friction": 0.3}}
    problem = nc.Problem.from_dict(data, "pressed-square")
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    u, fields = solution.u, solution.fields
    zones = nc.solution_quantities(u, fields)
    assert zones["stick_length"] > 0.1 and zones["slip_length"] > 0.1
    forms = normal_compliance_forms(u, fields)

    def own_bound(form):
        return fem.form(ufl.replace(form, {forms.frozen: u}))

    def matrix(form):
        A = fem_petsc.assemble_matrix(form)
        A.assemble()
        return A

    residual = own_bound(forms.contact_residual)

    def residual_at(w):
        u.x.array[:] = w
        vec = fem_petsc.assemble_vector(residual)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return vec

    consistent, frozen = matrix(fem.form(forms.consistent_jacobian)), matrix(own_bound(forms.contact_jacobian))
    direction = fem.Function(u.function_space)
    direction.interpolate(lambda x: np.vstack([np.sin(7 * x[0] + 1), np.cos(5 * x[1]) + x[0]]))
    state, v = u.x.array.copy(), direction.x.array
    h = 1e-6 * np.abs(state).max() / np.abs(v).max()
    difference = (residual_at(state + h * v) - residual_at(state - h * v)) / (2 * h)
    u.x.array[:] = state

    def misfit(A):
        product = A.createVecLeft()
        A.mult(versions.petsc_vec(direction), product)
        return (product - difference).norm() / difference.norm()

    assert misfit(consistent) < 1e-8
    assert misfit(frozen) > 1e-4


def test_the_newton_finish_replaces_the_passes_tail():
    """The pressed square on two adaptive levels with and without the consistent Newton finish
    (-friction_newton false): the same u_h (η to 1e-9), fewer passes of the fixed point with it, and on the
    nested level it is used (its warm start goes to Newton at once)."""
    data = {"mesh": {"rectangle": [[0, 0], [1, 1]], "cells": [8, 8], "dirichlet": ["top"],
                     "neumann": ["left", "right"], "contact": ["bottom"]},
            "material": {"E": 1.0, "nu": 0.3}, "loads": {"f": ["0", "-0.5"]},
            "contact": {"c_n": 100.0, "m_n": 2.0, "friction": 0.3}, "adapt": {"levels": 2, "refine": "adaptive"}}
    runs = {flag: nc.adapt(nc.Problem.from_dict(dict(data, solver={"petsc_options": {"friction_newton": flag}}),
                                                  f"newton-{flag}")).history for flag in ("true", "false")}
    for on, off in zip(runs["true"], runs["false"]):
        assert on["eta"] == pytest.approx(off["eta"], rel=1e-9)
        assert off["friction_newton"] == 0
    assert sum(r["friction_passes"] for r in runs["true"]) < sum(r["friction_passes"] for r in runs["false"])
    assert runs["true"][-1]["friction_newton"] >= 1


@pytest.fixture(scope="module")
def creeping_increments(tmp_path_factory):
    """tests/mpi/creeping_increment.py on 1, 2 and 3 ranks: {ranks: its npz}."""
    folder = tmp_path_factory.mktemp("creeping")
    results = {}
    for nprocs in (1, 2, 3):
        out = folder / f"np{nprocs}.npz"
        proc = run([ROOT / "tests" / "mpi" / "creeping_increment.py", out], nprocs)
        assert proc.returncode == 0, proc.stderr[-3000:]
        results[nprocs] = dict(np.load(out))
    return results


@pytest.mark.parametrize("nprocs", [1, 2, 3])
def test_a_creeping_warm_increment_goes_to_the_continuation(creeping_increments, nprocs):
    """The last increment of a load path that extends the slip zone under a stiff foundation (the family's
    1e4-1-mu0.1, 64 cells): the passes at ε_r creep (their line search cuts step after step), and after
    friction_creeping_steps cut steps in a row the ε-continuation of the cold start takes over from there.
    It ends at the same u_h as the passes alone (to 1e-9 of the largest displacement), the same on 1, 2
    and 3 ranks (nodal values to 1e-9). The path is asserted on one rank: the continuation's stages run
    (≥ 7 passes, against 2), and since the law is evaluated at the vertices (issue 50) the passes alone
    creep less (measured 19 Newton steps) and the continuation that takes over costs 27, so the takeover is
    asserted not to cost more than half again as much. On 2 and 3 ranks the warm start's consistent Newton
    steps sometimes converge at once (1 pass, 11–14 Newton steps, in 1 run of 3 or 4 here: the round-off
    of the parallel sums decides it), and then nothing creeps."""
    result = creeping_increments[nprocs]
    scale = np.abs(result["passes_values"]).max()
    assert str(result["default_reason"]).startswith("CONVERGED") and str(result["passes_reason"]).startswith("CONVERGED")
    np.testing.assert_allclose(result["default_values"], result["passes_values"], atol=1e-9 * scale, rtol=0)
    np.testing.assert_allclose(result["default_values"], creeping_increments[1]["default_values"],
                               atol=1e-9 * scale, rtol=0)
    if nprocs == 1:
        assert result["default_passes"] >= 7 > result["passes_passes"]
        assert result["default_newton"] < 1.5 * result["passes_newton"]
