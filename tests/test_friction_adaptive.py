"""The manufactured frictional solutions with a narrow interior bump (nc_dolfinx/cases/
manufactured_friction_layer.toml, 2D, and manufactured_friction_layer3d.toml): the exact u satisfies the
normal compliance law and the regularised Coulomb law on Γ_C exactly (the bump vanishes with its gradient
there), and Dörfler-adaptive refinement reaches the error of uniform refinement with clearly fewer dofs,
with a bounded effectivity on both. See docs/src/manufactured_friction_layer.md for the measurements
behind the margins."""
import importlib.util

import pytest
import sympy as sp

import test_friction_manufactured as tfm
from conftest import ROOT
from test_friction_manufactured import slope

# verification/common.py's interpolation, loaded under a name of its own (benchmarks/ has a `common` too)
_spec = importlib.util.spec_from_file_location("verification_common", ROOT / "verification" / "common.py")
verification_common = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(verification_common)
loglog_interpolate = verification_common.loglog_interpolate

CASES = ROOT / "nc_dolfinx" / "cases"
LAYER = {2: CASES / "manufactured_friction_layer.toml", 3: CASES / "manufactured_friction_layer3d.toml"}
BASE = {2: CASES / "manufactured_friction.toml", 3: CASES / "manufactured_friction3d.toml"}


@pytest.fixture(params=[2, 3], ids=["2d", "3d"])
def layer_case(request, monkeypatch):
    """test_friction_manufactured's helpers, pointed at this dimension's bump case; yields the dimension."""
    monkeypatch.setitem(tfm.CASES, request.param, LAYER[request.param])
    return request.param


def test_bump_is_there_and_leaves_gamma_c_alone(layer_case):
    """u − u_0 (u_0: the exact u of manufactured_friction, or ...3d) is the bump b(1, …, 1); b and ∇b vanish
    on Γ_C (the last coordinate 0) symbolically, b vanishes on Γ_D (the last coordinate 1), and b reaches B
    inside: the feature is real and localized (b < 1e-6 B at distance 0.3 from its centre, r < 0.1)."""
    dim = layer_case
    layer = tfm.sympy_case(dim)
    X = layer["X"]
    assert tfm.CASES[dim] == LAYER[dim]
    base_text = tfm.read_toml(BASE[dim])["exact"]["u"]
    names = {**layer["params"], **dict(zip("xyz", X))}
    base = [sp.sympify(t, locals=names) for t in base_text]
    bumps = [sp.simplify(a - b) for a, b in zip(layer["u"], base)]
    assert all(sp.simplify(b - bumps[0]) == 0 for b in bumps[1:])
    b = bumps[0]
    assert b != 0
    for e in (b, *(sp.diff(b, xi) for xi in X)):
        assert sp.simplify(e.subs(X[-1], 0)) == 0
    assert sp.simplify(b.subs(X[-1], 1)) == 0
    p = layer["params"]
    centre = [float(p[k]) for k in ("xb", "yb", "zb")[:dim]]
    B, r = float(p["B"]), float(p["r"])
    f = sp.lambdify(X, b, "math")
    assert f(*centre) == pytest.approx(B, rel=1e-12)
    for axis in range(dim):
        away = list(centre)
        away[axis] += 0.3 if axis < dim - 1 else -0.3
        assert abs(f(*away)) < 1e-6 * B
    assert r < 0.1  # narrow against the unit square or cube


def test_exact_solution_satisfies_both_laws(layer_case):
    """On a grid of Γ_C, this case's own expressions: both laws' residuals below 1e-12 relative to the
    tractions; both zones exist; all of Γ_C is in contact; |σ_t| = bound in slip, below it in stick;
    u = 0 on Γ_D (test_friction_manufactured.assert_both_laws_hold)."""
    tfm.assert_both_laws_hold(tfm.contact_residuals(layer_case), layer_case)


def test_exact_solution_satisfies_both_laws_symbolically(layer_case):
    """σ_t = −G Δu_t on Γ_C symbolically (so both branches of c_t give the law's traction), and
    σ_n = −c_n δ^{m_n} for δ = u_n − g_0."""
    dim = layer_case
    r = tfm.contact_residuals(dim)
    case, sym = r["case"], r["symbolic"]
    assert case["m_t"] == 1
    assert sp.simplify(sym["sigma_t"] + case["G"] * sym["slip"]) == sp.zeros(dim, 1)
    X = case["X"]
    u_n = -case["u"][-1].subs(X[-1], 0)
    assert sp.simplify(sym["sigma_n"] + case["c_n"] * (u_n - case["gap"]) ** case["m_n"]) == 0


def refinement(dim, kind, **options):
    import nc_dolfinx as nc
    overrides = [f"mesh.cells={[4] * dim}", f'adapt.refine="{kind}"'] + [f"adapt.{k}={v}" for k, v in options.items()]
    return nc.adapt(nc.load_problem(LAYER[dim].stem, overrides)).history


# From 4×4 (4³): uniform to 128×128 (16³), Dörfler θ = 0.5 to as many dofs (3D: 5 levels, 12384 dofs).
RUNS = {2: ({"levels": 6}, {"levels": 30}), 3: ({"levels": 3}, {"levels": 5})}


@pytest.fixture(scope="module", params=[2, 3], ids=["2d", "3d"])
def both(request):
    dim = request.param
    uniform_options, adaptive_options = RUNS[dim]
    uniform = refinement(dim, "uniform", **uniform_options)
    adaptive = refinement(dim, "adaptive", theta=0.5, max_dofs=uniform[-1]["dofs"], **adaptive_options)
    return dim, uniform, adaptive


def test_adaptive_needs_fewer_dofs_than_uniform(both):
    """Uniform from 4×4 to 128×128 (33282 dofs; 3D from 4³ to 16³, 14739 dofs) against Dörfler θ = 0.5:
    adaptive reaches the finest uniform error with fewer than a third of its dofs (measured 6.9× fewer in
    2D, 8.2× in 3D: a uniform mesh needs h ≪ r everywhere for the bump), its error on its last level is
    below half the uniform one (measured 0.29) in 2D, below 0.6 of it in 3D (measured 0.47, at 12384 dofs
    against 14739; with B = 0 it is 0.91, at 43773 dofs), and its last three levels converge at the
    optimal rate dofs^(−1/d) ± 0.08 (measured −0.52 in 2D), in 3D at least at that rate and up to 0.15
    faster while the bump is being resolved (measured −0.40; −0.31 over the last step alone)."""
    dim, uniform, adaptive = both
    target = uniform[-1]["h1_error"]
    # the dofs where the adaptive error first falls to the target (an adaptive error need not fall at
    # every level: only the two levels around the crossing are interpolated)
    i = next(i for i, r in enumerate(adaptive) if r["h1_error"] <= target)
    assert i > 0
    need = loglog_interpolate(target, [r["h1_error"] for r in adaptive[i - 1:i + 1]],
                              [r["dofs"] for r in adaptive[i - 1:i + 1]])
    assert uniform[-1]["dofs"] / need > 3.0
    assert adaptive[-1]["h1_error"] < (0.5 if dim == 2 else 0.6) * target
    assert adaptive[-1]["dofs"] >= (uniform[-1]["dofs"] if dim == 2 else 0.8 * uniform[-1]["dofs"])
    # the optimal rate, or faster while the bump is being resolved (3D, which ends sooner)
    assert -1 / dim - (0.08 if dim == 2 else 0.15) < slope(adaptive, "h1_error") < -1 / dim + 0.08


def test_uniform_rate_is_optimal_only_once_the_bump_is_resolved(both):
    """2D: ‖u − u_h‖_1 = O(dofs^(−1/2)) over the last step, 64×64 → 128×128 (h = 1/128 ≈ r/5; measured
    −0.498), while halving h from 1/8 to 1/16 (h > r = 0.04: the bump falls between the vertices) divides
    the error by less than 1.5 (measured 1.09; O(h) would give 2). 3D: halving h from 1/4 to 1/8 (h > r =
    0.08) divides it by less than 1.5 (measured 1.25). The bump is what uniform refinement resolves late."""
    dim, uniform, _ = both
    if dim == 2:
        assert [r["cells"] for r in uniform] == [32 * 4 ** k for k in range(6)]
        assert slope(uniform, "h1_error", last=2) == pytest.approx(-0.5, abs=0.04)
        assert uniform[1]["h1_error"] / uniform[2]["h1_error"] < 1.5
    else:
        assert [r["cells"] for r in uniform] == [384 * 8 ** k for k in range(3)]
        assert uniform[0]["h1_error"] / uniform[1]["h1_error"] < 1.5


def test_effectivity_is_bounded_on_both(both):
    """η/‖u − u_h‖_1 above 1 (reliability) and below 20 on every level of both runs (measured 4.7–6.9
    uniform, 5.9–7.6 adaptive in 2D; 4.9–5.6 and 4.9–6.5 in 3D), the same on both within a factor 2."""
    _, uniform, adaptive = both
    eff = [r["eta"] / r["h1_error"] for r in uniform + adaptive]
    assert 1.0 < min(eff) and max(eff) < 20.0 and max(eff) / min(eff) < 2.0
