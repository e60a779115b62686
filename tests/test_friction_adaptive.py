"""The manufactured frictional solution with a narrow interior bump (nc_dolfinx/cases/
manufactured_friction_layer.toml): the exact u satisfies the normal compliance law and the regularised
Coulomb law on Γ_C exactly (the bump vanishes with its gradient there), and Dörfler-adaptive refinement
reaches the error of uniform refinement with clearly fewer dofs, with a bounded effectivity on both.
See docs/src/manufactured_friction_layer.md for the measurements behind the margins."""
import math

import pytest
import sympy as sp

import test_friction_manufactured as tfm
from conftest import ROOT
from test_friction_manufactured import slope

LAYER = ROOT / "nc_dolfinx" / "cases" / "manufactured_friction_layer.toml"


@pytest.fixture
def layer_case(monkeypatch):
    """test_friction_manufactured's helpers, pointed at this case (2D)."""
    monkeypatch.setitem(tfm.CASES, 2, LAYER)
    return tfm


def test_bump_is_there_and_leaves_gamma_c_alone(layer_case):
    """u − u_0 (u_0: manufactured_friction's exact u) is the bump b(1, 1); b, ∇b vanish on Γ_C (y = 0)
    symbolically, b vanishes on Γ_D (y = 1), and b reaches B inside: the feature is real and localized
    (b < 1e-6 B at distance 0.2 from its centre)."""
    layer = layer_case.sympy_case(2)
    x, y = layer["X"]
    assert tfm.CASES[2] == LAYER
    base_text = tfm.read_toml(ROOT / "nc_dolfinx" / "cases" / "manufactured_friction.toml")["exact"]["u"]
    names = {**layer["params"], "x": x, "y": y}
    base = [sp.sympify(t, locals=names) for t in base_text]
    bumps = [sp.simplify(a - b) for a, b in zip(layer["u"], base)]
    assert sp.simplify(bumps[0] - bumps[1]) == 0
    b = bumps[0]
    assert b != 0
    for e in (b, sp.diff(b, x), sp.diff(b, y)):
        assert sp.simplify(e.subs(y, 0)) == 0
    assert sp.simplify(b.subs(y, 1)) == 0
    p = layer["params"]
    B, xb, yb, r = (float(p[k]) for k in ("B", "xb", "yb", "r"))
    f = sp.lambdify((x, y), b, "math")
    assert f(xb, yb) == pytest.approx(B, rel=1e-12)
    assert abs(f(xb + 0.2, yb)) < 1e-6 * B and abs(f(xb, yb - 0.2)) < 1e-6 * B
    assert r < 0.1  # narrow against the unit square


def test_exact_solution_satisfies_both_laws(layer_case):
    """At 401 points of Γ_C, this case's own expressions: both laws' residuals below 1e-12 relative to the
    tractions; both zones exist; all of Γ_C is in contact; |σ_t| = bound in slip, below it in stick;
    u = 0 on Γ_D (test_friction_manufactured.assert_both_laws_hold)."""
    tfm.assert_both_laws_hold(layer_case.contact_residuals(2), 2)


def test_exact_solution_satisfies_both_laws_symbolically(layer_case):
    """σ_t = −G Δu_t on Γ_C symbolically (so both branches of c_t give the law's traction), and
    σ_n = −c_n δ^{m_n} for δ = u_n − g_0."""
    r = layer_case.contact_residuals(2)
    case, sym = r["case"], r["symbolic"]
    assert case["m_t"] == 1
    assert sp.simplify(sym["sigma_t"] + case["G"] * sym["slip"]) == sp.zeros(2, 1)
    X = case["X"]
    u_n = -case["u"][-1].subs(X[-1], 0)
    assert sp.simplify(sym["sigma_n"] + case["c_n"] * (u_n - case["gap"]) ** case["m_n"]) == 0


def refinement(kind, **options):
    import nc_dolfinx as nc
    overrides = ["mesh.cells=[4,4]", f'adapt.refine="{kind}"'] + [f"adapt.{k}={v}" for k, v in options.items()]
    return nc.adapt(nc.load_problem("manufactured_friction_layer", overrides)).history


@pytest.fixture(scope="module")
def both():
    uniform = refinement("uniform", levels=6)                          # 4×4 → 128×128
    adaptive = refinement("adaptive", theta=0.5, levels=30, max_dofs=uniform[-1]["dofs"])
    return uniform, adaptive


def dofs_for(error, rows):
    """The dofs at which ``rows`` reach ``error`` (log-log interpolation; None if they never do)."""
    for a, b in zip(rows, rows[1:]):
        if b["h1_error"] <= error < a["h1_error"]:
            t = math.log(a["h1_error"] / error) / math.log(a["h1_error"] / b["h1_error"])
            return math.exp(math.log(a["dofs"]) + t * math.log(b["dofs"] / a["dofs"]))
    return None


def test_adaptive_needs_fewer_dofs_than_uniform(both):
    """4×4 → 128×128 uniform (33282 dofs) against Dörfler θ = 0.5 up to as many dofs: adaptive reaches the
    finest uniform error with fewer than a third of its dofs (measured 6.9× fewer: a uniform mesh needs h ≪ r
    everywhere for the bump), its error on its last level is below half the uniform one at ≥ the same
    dofs (measured 0.29), and its last three levels converge at the optimal rate dofs^(−1/2) (measured
    −0.52)."""
    uniform, adaptive = both
    assert adaptive[-1]["dofs"] >= uniform[-1]["dofs"]
    target = uniform[-1]["h1_error"]
    need = dofs_for(target, adaptive)
    assert need is not None
    assert uniform[-1]["dofs"] / need > 3.0
    assert adaptive[-1]["h1_error"] < 0.5 * target
    assert slope(adaptive, "h1_error") == pytest.approx(-0.5, abs=0.08)


def test_uniform_rate_is_optimal_only_once_the_bump_is_resolved(both):
    """Uniform refinement: ‖u − u_h‖_1 = O(dofs^(−1/2)) over the last step, 64×64 → 128×128 (h = 1/128 ≈
    r/5; measured −0.498), while halving h from 1/8 to 1/16 (h > r = 0.04: the bump falls between the
    vertices) divides the error by less than 1.5 (measured 1.09; O(h) would give 2): the bump is what
    uniform refinement resolves late."""
    uniform, _ = both
    assert [r["cells"] for r in uniform] == [32 * 4 ** k for k in range(6)]
    assert slope(uniform, "h1_error", last=2) == pytest.approx(-0.5, abs=0.04)
    assert uniform[1]["h1_error"] / uniform[2]["h1_error"] < 1.5


def test_effectivity_is_bounded_on_both(both):
    """η/‖u − u_h‖_1 above 1 (reliability) and below 20 on every level of both runs (measured 4.7–6.9
    uniform, 5.9–7.6 adaptive), the same on both within a factor 2."""
    uniform, adaptive = both
    eff = [r["eta"] / r["h1_error"] for r in uniform + adaptive]
    assert 1.0 < min(eff) and max(eff) < 20.0 and max(eff) / min(eff) < 2.0
