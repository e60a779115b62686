"""The manufactured case: its exact solution satisfies the law, and P1 converges at optimal rates.

The exact solution of nc_dolfinx/cases/manufactured.toml is checked symbolically (sympy) against the
compliance law (4) and σ_t = 0 on Γ_C and u = 0 on Γ_D; then uniform refinement must give ‖u − u_h‖_1 = O(h)
and ‖u − u_h‖_0 = O(h²) for m_n ∈ {1, 1.5, 2, 3}, and a steady effectivity index η/‖u − u_h‖_1.
"""
import math

import numpy as np
import pytest
import sympy as sp

from conftest import ROOT, history, run_cli
from nc_dolfinx.physics.elasticity import lame
from nc_dolfinx.problem.reading import read_toml

CASE = ROOT / "nc_dolfinx" / "cases" / "manufactured.toml"


def sympy_exact(m):
    data = read_toml(CASE)
    x, y = sp.symbols("x y", real=True)
    params = {}
    for name, value in data["parameters"].items():
        params[name] = sp.sympify(value, locals=params) if isinstance(value, str) else sp.nsimplify(value)
    params["m"] = sp.nsimplify(m)
    L = params["L"]
    names = {**params, "x": x, "y": y, "pos": lambda a: sp.Max(a, 0)}
    u = [sp.sympify(text, locals=names) for text in data["exact"]["u"]]
    return x, y, u, params, L


@pytest.mark.parametrize("m", [1, 1.5, 2, 3])
def test_exact_solution_satisfies_the_law_symbolically(m):
    x, y, (ux, uy), params, L = sympy_exact(m)
    E, nu, c = params["E"], params["nu"], params["c"]
    lmbda, mu = (sp.nsimplify(v) for v in lame(float(E), float(nu)))
    assert sp.simplify(L - (lmbda + 2 * mu)) == 0
    exx, eyy, exy = sp.diff(ux, x), sp.diff(uy, y), (sp.diff(ux, y) + sp.diff(uy, x)) / 2
    s_yy = lmbda * (exx + eyy) + 2 * mu * eyy
    s_xy = 2 * mu * exy
    # Γ_C: y = 0, ν = (0, −1): u_n = −u_y, σ_n = σ_yy, σ_t = σν·t = −σ_xy with t = (−ν_2, ν_1) = (1, 0).
    u_n = -uy.subs(y, 0)
    assert sp.simplify(s_xy.subs(y, 0)) == 0
    law = s_yy.subs(y, 0) + c * sp.Max(u_n, 0) ** params["m"]
    # Max(A (x − x0)^3, 0)^m equals A^m Max(x − x0, 0)^{3m} for A > 0: compare on both sides of x0.
    for side in (params["x0"] - sp.Rational(1, 3), params["x0"] + sp.Rational(1, 3)):
        assert abs(float(law.subs(x, side))) < 1e-13
    xs = np.linspace(0, 1, 41)
    assert max(abs(float(law.subs(x, sp.nsimplify(v)))) for v in xs) < 1e-12
    # Γ_D: y = 1 is clamped.
    assert sp.simplify(ux.subs(y, 1)) == 0 and sp.simplify(uy.subs(y, 1)) == 0
    # a free boundary: contact (u_n > 0) on part of Γ_C, a gap (u_n < 0) on the rest
    values = [float(u_n.subs(x, sp.nsimplify(v))) for v in xs]
    assert min(values) < 0 < max(values)


def fitted_rate(rows, key, last=4):
    h = np.array([1.0 / math.sqrt(r["cells"]) for r in rows[-last:]])
    err = np.array([r[key] for r in rows[-last:]])
    return np.polyfit(np.log(h), np.log(err), 1)[0]


@pytest.fixture(scope="module")
def uniform_runs(tmp_path_factory):
    out = {}
    for m in (1, 1.5, 2, 3):
        target = tmp_path_factory.mktemp(f"m{m}")
        proc = run_cli(["manufactured", "--out", target, "--refine", "uniform", "--levels", "5",
                        "--set", f"parameters.m={m}", "--set", "mesh.cells=[4,4]", "--quiet"])
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[m] = history(target)
    return out


@pytest.mark.parametrize("m", [1, 1.5, 2, 3])
def test_optimal_rates(uniform_runs, m):
    rows = uniform_runs[m]
    assert len(rows) == 5
    assert fitted_rate(rows, "h1_error") == pytest.approx(1.0, abs=0.1)
    assert fitted_rate(rows, "l2_error") == pytest.approx(2.0, abs=0.15)
    assert fitted_rate(rows, "eta") == pytest.approx(1.0, abs=0.1)  # Corollary 8: η = O(h)


@pytest.mark.parametrize("m", [1, 2])
def test_effectivity_index_is_steady(uniform_runs, m):
    eff = [r["eta"] / r["h1_error"] for r in uniform_runs[m][-4:]]
    assert max(eff) / min(eff) <= 1.5
    # Theorem 6 (reliability) with a constant of moderate size: η bounds the error from above.
    assert min(eff) > 1.0
