"""The manufactured two-body contact solution (verification/manufactured_two_bodies.py): the stacked blocks,
[[pairs]] with p = c_n (u_n − g_0)_+^{m_n}, contact on part of the interface only.

- the conditions (the pair's law on both faces, σ_t = 0 on both, action = reaction, [exact] u = u_A / u_B on
  its body) hold symbolically (sympy simplifies each residual to 0 on both sides of the kink) and to 1e-12 on
  the face, for m_n = 1 and 1.5 (and the 3D extrusion, m_n = 1.5);
- uniform refinement, 3 levels (m_n = 1.5): the H¹ error's rate in h in [0.9, 1.1] (P1, u ∈ H² per body), on
  each body; the effectivity η/‖u − u_h‖_1 within a bounded band, settling (measured 3.64, 3.99, 4.17); the
  pair's force converges to its exact value;
- 1 and 2 ranks give the same errors, η and force to 1e-8 (two levels: the refinement's body-safe transfer
  in parallel too).
"""
import json
import math

import pytest

from conftest import ROOT, import_script, run

mtb = import_script("verification", "manufactured_two_bodies")
M = 1.5


@pytest.fixture(scope="module")
def uniform(tmp_path_factory):
    mesh = mtb.mesh_file(tmp_path_factory.mktemp("mtb"))
    rows, _ = mtb.run(mesh, M, "uniform", 3)
    return rows


@pytest.mark.parametrize("m, dim", [(1.0, 2), (1.5, 2), (1.5, 3)])
def test_the_conditions_hold_symbolically(m, dim):
    residuals, _ = mtb.symbolic_residuals(m, dim)
    for name, (exact_zero, value) in residuals.items():
        assert exact_zero, name
        if not name.startswith("contact zone"):
            assert value < 1e-12, (name, value)
    zone = next(v for k, v in residuals.items() if k.startswith("contact zone"))[1]
    assert zone < 1e-3  # contact starts at x0 = 0.4 (to the grid's spacing): the kink is inside the face


def test_h1_rate_and_effectivity(uniform):
    assert [r["level"] for r in uniform] == [0, 1, 2]
    for key in ("h1_error", "h1_upper", "h1_lower"):
        for rate in mtb.rates(uniform, key):
            assert 0.9 <= rate <= 1.1, (key, rate)
    eta_rates = mtb.rates(uniform, "eta")
    assert 0.8 <= eta_rates[-1] <= 1.1, eta_rates  # (0.88, 0.95: η approaches its rate 1 from below)
    effectivity = [r["eta"] / r["h1_error"] for r in uniform]
    assert all(2.0 <= e <= 8.0 for e in effectivity), effectivity
    assert max(effectivity) / min(effectivity) < 1.3, effectivity
    assert abs(effectivity[-1] - effectivity[-2]) < abs(effectivity[-2] - effectivity[-3]) + 0.05  # settling
    force = mtb.exact_force(M)
    errors = [abs(r["pair1_force"][1] - force) / force for r in uniform]
    assert errors[-1] < 0.02 and errors[-1] < errors[0], errors
    assert all(r["force_balance"] < 1e-10 for r in uniform)


def test_one_and_two_ranks_give_the_same_errors(uniform, tmp_path):
    out = tmp_path / "np2.json"
    result = run([ROOT / "verification" / "manufactured_two_bodies.py", "--rows", M, 2, out], nprocs=2)
    assert result.returncode == 0, result.stderr
    two = json.loads(out.read_text())
    assert [r["dofs"] for r in two] == [r["dofs"] for r in uniform[:2]]
    for r2, r1 in zip(two, uniform):
        for key in ("h1_error", "l2_error", "eta", "h1_upper", "h1_lower", "elastic_energy"):
            assert r2[key] == pytest.approx(r1[key], rel=1e-8), key
        assert r2["pair1_force"] == pytest.approx(r1["pair1_force"], rel=1e-8)
        assert math.isfinite(r2["eta"])
