"""A manufactured solution for two deformable bodies in contact ([[pairs]], issue 47): the stacked blocks of
meshes/two_bodies.py (lower body B = [0,1] x [0,0.5], upper body A = [0,1] x [0.5,1], non-matching faces on
y = 0.5), 2D plane strain, and its convergence study (uniform and Dörfler-adaptive refinement).

The exact solution (s = y − 1/2, a(x) = A (x − x0)³, p(x) = c_n (a)_+^{m_n} = c_n A^{m_n} (x − x0)_+^{3 m_n},
L = λ + 2μ, w_A = 1 + s², w_B = 1 + 2 s²):

    u_A = ( s w_A a'/2,   w_A (−a/2 − s p/L) )          on the upper body (s ≥ 0)
    u_B = (−s w_B a'/2,   w_B ( a/2 − s p/L) )          on the lower body (s ≤ 0)

On the interface (s = 0, ν_A = −e_y, ν_B = +e_y, Πx = x, g_0 = 0): the normal jump is
u_n = (u_A − u_B)·ν_A = u_B,y − u_A,y = a; ∂_y u_x = ∓a'/2 = −∂_x u_y, so σ_xy = 0 on both faces
(frictionless); ∂_x u_x = 0 and L ∂_y u_y = −p, so σ_yy = −p on both faces: σ_A ν_A = −p ν_A and
σ_B ν_B = −p ν_B with p = c_n (u_n − g_0)_+^{m_n}, the pair's law exactly. Contact on x > x0 only (the jump
a < 0 is a gap on x < x0): the law's kink is inside the face. (x − x0)_+^{3 m} is C² for m >= 1: u ∈ H² per body.
Γ_D: top (u = u_A) and bottom (u = u_B), each body held by its own; Γ_N: the four sides, g = σ(u)ν; f = −div σ(u).

How it is given to the library (no change to nc_dolfinx needed to *run* it): [exact] u is one expression on
the whole mesh, u = H u_A + (1 − H) u_B with the switch H = min(1, pos(y − 1/2)·1e12). H is exactly 1 at
every point of the upper body farther than 1e-12 from the interface and exactly 0 on the lower body, so at
every cell and side-facet quadrature point (none lies on y = 1/2) the library's f = −div σ(u), g = σ(u)ν (UFL
derivatives of H vanish there) and the errors ‖u − u_h‖ are those of the body's own u. It is not a per-body
value on the interface's nodes themselves (both bodies have nodes there at the same positions, a point
function cannot tell them apart), so nothing is ever interpolated from it there: u_D is given per group.
A per-body [exact] (or a step function in the expression language) would say so directly:
/tmp/lead/patch_manufactured.diff.

    PYTHONPATH=. /usr/bin/python3 verification/manufactured_two_bodies.py [--quick] [--m 1 1.5]
    PYTHONPATH=. /usr/bin/python3 verification/manufactured_two_bodies.py --symbolic   # the conditions only
    mpirun -n 2 ... verification/manufactured_two_bodies.py --rows M LEVELS OUT.json    # (the tests' rank check)

--quick: m_n = 1.5 only, 3 uniform levels, the adaptive run to the same dofs. --3d: also the same solution
extruded in y on stacked_blocks_3d (vertical axis z, u_y = 0; 4 uniform levels from h = 1/4, 1/6);
--3d-only: that alone.
"""
import json
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "verification"))

PARAMETERS = {"A": 1.0, "x0": 0.4, "c": 10.0, "E": 1.0, "nu": 0.3}
L_TEXT = "E*(1 - nu)/((1 + nu)*(1 - 2*nu))"  # λ + 2μ in plane strain
JUMP_POSITIVE = "c*A**m*pos(x - x0)**(3*m)"  # p(x) = c (a)_+^m, written so that UFL differentiates exponents >= 1


def texts(dim=2):
    """(u_A, u_B, H) as expression strings: the vertical axis is y in 2D, z in 3D (u_y = 0 there: the same
    solution, extruded); H = 1 on the upper body, 0 on the lower (off the interface itself)."""
    v = "yz"[dim - 2]
    s = f"({v} - 0.5)"
    upper = [f"{s}*(1 + {s}**2)*1.5*A*(x - x0)**2", f"(1 + {s}**2)*(-0.5*A*(x - x0)**3 - {s}*{JUMP_POSITIVE}/L)"]
    lower = [f"-{s}*(1 + 2*{s}**2)*1.5*A*(x - x0)**2", f"(1 + 2*{s}**2)*(0.5*A*(x - x0)**3 - {s}*{JUMP_POSITIVE}/L)"]
    if dim == 3:
        upper.insert(1, "0")
        lower.insert(1, "0")
    return upper, lower, f"min(1, pos({v} - 0.5)*1e12)"


U_UPPER, U_LOWER, STEP = texts(2)


def parameters(m):
    values = dict(PARAMETERS, m=float(m))
    E, nu = values["E"], values["nu"]
    values["L"] = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    return values


def exact_texts(dim=2):
    """[exact] u on the whole mesh (the switch H between the bodies' expressions)."""
    upper, lower, step = texts(dim)
    return [f"{step}*({a}) + (1 - {step})*({b})" for a, b in zip(upper, lower)]


# --- the symbolic check: every condition's residual ---------------------------------------------------



def pointwise(variables, expr):
    """expr as a function of numpy arrays (lambdify with the math module, point by point: Max stays max)."""
    import sympy
    f = sympy.lambdify(variables, expr, "math")
    return np.vectorize(lambda *a: float(f(*a)))


def symbolic_residuals(m, dim=2):
    """{condition: max |residual|} of the interface conditions, the contact zone and the loads, computed by sympy
    from the very strings given to the library (sympy's parser with the library's functions: pos, min, max):
    exact zeros where the algebra closes,
    and the largest value on a grid of 2001 points of the face (both sides of x0) as a float."""
    import sympy

    def to_sympy(text, coordinates, values):  # the problem-file syntax (Python's) with the library's functions
        names = {"pos": lambda a: sympy.Max(a, 0), "min": sympy.Min, "max": sympy.Max, "abs": sympy.Abs,
                 "sqrt": sympy.sqrt, "exp": sympy.exp, "log": sympy.log, "sin": sympy.sin, "cos": sympy.cos,
                 "pi": sympy.pi, **{k: sympy.Float(v) for k, v in values.items()}, **coordinates}
        return sympy.sympify(text, locals=names)
    par = parameters(m)
    X = sympy.symbols("x y z"[:2 * dim - 1], real=True)
    x, v = X[0], X[-1]  # v: the vertical coordinate (y in 2D, z in 3D)
    exact_params = {k: sympy.nsimplify(v, rational=True) for k, v in par.items()}  # 0.3 -> 3/10, L -> 35/26
    E, nu = exact_params["E"], exact_params["nu"]
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    assert sympy.simplify(exact_params["L"] - (lam + 2 * mu)) == 0

    def field(texts):  # the library's parser; its Floats (parameters, 0.5, 1.5, 1e12) made exact rationals
        return sympy.Matrix([sympy.nsimplify(to_sympy(t, {str(c): c for c in X}, par), rational=True) for t in texts])

    def stress(u):
        grad = u.jacobian(X)
        eps = (grad + grad.T) / 2
        return lam * eps.trace() * sympy.eye(dim) + 2 * mu * eps

    upper_texts, lower_texts, _ = texts(dim)
    uA, uB = field(upper_texts), field(lower_texts)
    sA, sB = stress(uA), stress(uB)
    half = sympy.Rational(1, 2)
    c, mm, x0 = exact_params["c"], exact_params["m"], exact_params["x0"]
    jump = (uB[-1] - uA[-1]).subs(v, half)                    # u_n = (u_A − u_B)·ν_A, ν_A = −e_v, g_0 = 0
    p = c * sympy.Max(jump, 0) ** mm                           # the pair's law
    nB = sympy.Matrix([0] * (dim - 1) + [1])
    nA = -nB
    tA, tB = (sA * nA).subs(v, half), (sB * nB).subs(v, half)
    conditions = {
        "normal jump u_n − A (x − x0)^3": jump - exact_params["A"] * (x - x0) ** 3,
        "upper face σ_n + p (σ_n = ν_A·σ_A ν_A)": nA.dot(tA) + p,
        "lower face σ_n + p (σ_n = ν_B·σ_B ν_B)": nB.dot(tB) + p,
        "upper face ‖σ_t‖ (frictionless)": sympy.sqrt(sum(c ** 2 for c in tA[:-1])),
        "lower face ‖σ_t‖ (frictionless)": sympy.sqrt(sum(c ** 2 for c in tB[:-1])),
        "action = reaction: σ_A ν_A + σ_B ν_B": (tA + tB).norm(),
    }
    t = sympy.symbols("t", positive=True)
    out = {}
    grid = np.linspace(0.0, 1.0, 2001)
    for name, expr in conditions.items():
        exact_zero = all(sympy.simplify(expr.subs(x, x0 + sign * t)) == 0 for sign in (1, -1))
        value = float(np.max(np.abs(pointwise(x, expr)(grid))))
        out[name] = (exact_zero, value)
    # the contact zone: p > 0 exactly on x > x0 (part of the face, 0 < x0 < 1)
    pf = pointwise(x, p)
    zone = grid[pf(grid) > 0]
    out["contact zone = (x0, 1] (value: first grid point in contact − x0)"] = (bool(zone.min() > float(x0) and abs(zone.min() - float(x0)) < 1e-3),
                                     abs(zone.min() - float(x0)))
    # the one expression [exact] u (the switch H) equals u_A on the upper body, u_B on the lower one
    whole = field(exact_texts(dim))
    ff = [pointwise(X, e) for e in list(whole - uA) + list(whole - uB)]
    XX, VV = np.meshgrid(grid[::20], np.linspace(0, 1, 101))
    upper, lower = VV > 0.5 + 1e-9, VV < 0.5
    points = (XX, VV) if dim == 2 else (XX, np.full_like(XX, 0.3), VV)
    diff = [f(*points) for f in ff]
    out["[exact] u = u_A on the upper body, u_B on the lower"] = (
        True, float(max(max(np.abs(d[upper]).max() for d in diff[:dim]), max(np.abs(d[lower]).max() for d in diff[dim:]))))
    # f and g per body (what loads.from_exact computes with UFL): printed for the record
    fA, fB = (-sympy.Matrix([sum(sig[i, j].diff(X[j]) for j in range(dim)) for i in range(dim)]) for sig in (sA, sB))
    return out, {"f_A": fA, "f_B": fB, "u_A": uA, "u_B": uB, "p": p}


def print_symbolic(m, dim=2):
    residuals, formulas = symbolic_residuals(m, dim)
    print(f"### Symbolic check, {dim}D, m_n = {m:g} (sympy, from the strings given to the library)\n")
    print("| condition | sympy simplifies to 0 (x = x0 ± t) | max abs(residual) on 2001 points of the face |")
    print("|---|---|---|")
    for name, (zero, value) in residuals.items():
        print(f"| {name} | {zero} | {value:.2e} |")
    print()
    return residuals, formulas


# --- the problem and the runs -------------------------------------------------------------------------

def _mesh_module():
    """meshes/two_bodies.py by its path (verification/ may hold a module of the same name)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("meshes_two_bodies", ROOT / "meshes" / "two_bodies.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


MESH_SIZES = {2: (1 / 6, 1 / 9), 3: (1 / 4, 1 / 6)}  # (h_lower, h_upper) at level 0


def mesh_file(folder, dim=2):
    two_bodies = _mesh_module()
    path = Path(folder) / f"stacked_blocks_{dim}d.msh"
    if not path.exists():
        getattr(two_bodies, f"stacked_blocks_{dim}d")(str(path), *MESH_SIZES[dim])
    return path


def problem_dict(mesh, m, refine="uniform", levels=4, theta=0.5, max_dofs=None, dim=2):
    adapt = {"refine": refine} if refine == "none" else {"refine": refine, "levels": levels}
    if refine == "adaptive":
        adapt["theta"] = theta
    if max_dofs:
        adapt["max_dofs"] = int(max_dofs)
    return {"title": f"manufactured two bodies, m_n = {m:g}",
            "parameters": {**PARAMETERS, "m": float(m), "L": L_TEXT},
            "mesh": {"file": str(mesh), "dirichlet": ["top", "bottom"],
                     "neumann": [f"{body}_{side}" for body in ("lower", "upper")
                                 for side in (("left", "right") if dim == 2 else ("x0", "x1", "y0", "y1"))]},
            "material": {"E": "E", "nu": "nu"},
            "loads": {"from_exact": True, "u_D": {"top": texts(dim)[0], "bottom": texts(dim)[1]}},
            "pairs": [{"faces": ["upper_face", "lower_face"], "c_n": "c", "m_n": float(m)}],
            "exact": {"u": exact_texts(dim)},
            "adapt": adapt}


def body_errors(u, fields):
    """H¹ seminorm errors |u − u_h|_1 on the upper and the lower body (split by the vertical coordinate)."""
    import ufl
    import nc_dolfinx as nc
    msh = fields.domain.mesh
    y = ufl.SpatialCoordinate(msh)[msh.geometry.dim - 1]
    e = fields.u_exact - u
    dx = ufl.dx(metadata={"quadrature_degree": nc.QUADRATURE_DEGREES["error"]})
    upper = ufl.conditional(ufl.gt(y, 0.5), 1.0, 0.0)
    comm = msh.comm
    g2 = ufl.inner(ufl.grad(e), ufl.grad(e))
    return (math.sqrt(nc.integrate(upper * g2 * dx, comm)), math.sqrt(nc.integrate((1 - upper) * g2 * dx, comm)))


def run(mesh, m, refine="uniform", levels=4, **kw):
    """nc.adapt on the problem; rows (dicts) with the library's columns and the per-body errors."""
    import nc_dolfinx as nc
    problem = nc.Problem.from_dict(problem_dict(mesh, m, refine, levels, **kw), "manufactured_two_bodies")
    rows = []

    def on_level(level):
        row = dict(level.row)
        row["h1_upper"], row["h1_lower"] = body_errors(level.solution.u, level.solution.fields)
        rows.append(row)

    start = time.perf_counter()
    nc.adapt(problem, on_level=on_level)
    return rows, time.perf_counter() - start


def slope(xs, ys):
    from common import fitted_slope
    return fitted_slope(xs, ys)


def exact_force(m):
    """∫_{y=1/2} p dx = c A^m (1 − x0)^{3m+1}/(3m + 1), the y-component of the lower body's push on the upper."""
    P = parameters(m)
    return P["c"] * P["A"] ** m * (1 - P["x0"]) ** (3 * m + 1) / (3 * m + 1)


def rates(rows, key, dim=2):
    """Rates in h (h ∝ cells^(−1/dim) under uniform refinement) between consecutive levels."""
    return [math.log(b[key] / a[key]) / (-math.log(b["cells"] / a["cells"]) / dim) for a, b in zip(rows, rows[1:])]


def uniform_table(rows, seconds, m, dim=2):
    force = exact_force(m)
    h1_rates, eta_rates = (["–"] + [f"{r:.3f}" for r in rates(rows, key, dim)] for key in ("h1_error", "eta"))
    print("| level | dofs | ‖u−u_h‖_1 | rate (h) | \\|u−u_h\\|_1 upper | lower | η | rate η (h) | η/‖u−u_h‖_1 | η_3²/η² (σ_t) | η_4²/η² | pair force rel. error | contact length (0.6) or area | Newton |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for i, r in enumerate(rows):
        print(f"| {r['level']} | {r['dofs']} | {r['h1_error']:.4e} | {h1_rates[i]} | {r['h1_upper']:.3e} | {r['h1_lower']:.3e} | "
              f"{r['eta']:.4e} | {eta_rates[i]} | {r['eta'] / r['h1_error']:.3f} | {(r['eta_3'] / r['eta']) ** 2:.2e} | "
              f"{(r['eta_4'] / r['eta']) ** 2:.2e} | {abs(r['pair1_force'][-1] - force) / force:.2e} | "
              f"{r.get('pair1_contact_length', r.get('pair1_contact_area', float('nan'))):.4f} | {r['newton_iterations']} |")
    fit = rows[-3:]
    print(f"\nfitted over the last {len(fit)} levels: ‖u−u_h‖_1 ∝ h^{-dim * slope([r['cells'] for r in fit], [r['h1_error'] for r in fit]):.3f}, "
          f"η ∝ h^{-dim * slope([r['cells'] for r in fit], [r['eta'] for r in fit]):.3f}; exact pair force {force:.6f}, "
          f"exact peak pressure {parameters(m)['c'] * (1 - PARAMETERS['x0']) ** (3 * m):.4f} "
          f"(last level: {rows[-1]['pair1_max_pressure']:.4f}); {seconds:.1f} s\n")


def adaptive_table(adaptive, uniform, seconds, dim=2):
    """manufactured_friction's table (η_3: here the pair faces' σ_t term), then the adaptive run's slope."""
    from manufactured_friction import adaptive_table as table
    table(adaptive, uniform, seconds)
    fit = adaptive[-4:]
    print(f"adaptive, last {len(fit)} levels: ‖u−u_h‖_1 ∝ dofs^{slope([r['dofs'] for r in fit], [r['h1_error'] for r in fit]):.3f} "
          f"(the optimum: −1/{dim} = {-1 / dim:.3f})\n")


def rows_for_ranks(m, levels, out):
    """(Under mpirun) the uniform run's errors and η per level, written by rank 0 as JSON."""
    import shutil
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    folder = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None)  # one folder for all ranks
    try:
        if comm.rank == 0:
            mesh_file(folder)
        comm.barrier()
        rows, _ = run(mesh_file(folder), m, "uniform", levels)
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(folder, ignore_errors=True)
    if MPI.COMM_WORLD.rank == 0:
        keep = ("dofs", "h1_error", "l2_error", "eta", "h1_upper", "h1_lower", "pair1_force", "elastic_energy")
        Path(out).write_text(json.dumps([{k: r[k] for k in keep if k in r} for r in rows]))


def main(argv):
    if "--rows" in argv:
        i = argv.index("--rows")
        rows_for_ranks(float(argv[i + 1]), int(argv[i + 2]), argv[i + 3])
        return
    quick = "--quick" in argv
    ms = [1.5] if quick else [1.0, 1.5]
    if "--m" in argv:
        ms = [float(v) for v in argv[argv.index("--m") + 1:] if not v.startswith("--")]
    dims = [3] if "--3d-only" in argv else [2, 3] if "--3d" in argv else [2]
    from common import provenance
    print("# Manufactured two-body contact (stacked blocks, [[pairs]]): convergence\n")
    print("\n".join(provenance("manufactured_two_bodies.py", argv)))
    print()
    for dim in dims:
        for m in ms:
            print_symbolic(m, dim)
    if "--symbolic" in argv:
        return
    with tempfile.TemporaryDirectory() as folder:
        for dim in dims:
            mesh = mesh_file(folder, dim)
            levels = (3 if quick else 5) if dim == 2 else 4
            sizes = " and ".join(f"1/{round(1 / h)}" for h in MESH_SIZES[dim])
            for m in ms:
                print(f"## {dim}D, m_n = {m:g}: uniform refinement, {levels} levels (h_lower, h_upper = {sizes} at level 0)\n")
                uniform, seconds = run(mesh, m, "uniform", levels, dim=dim)
                uniform_table(uniform, seconds, m, dim)
                print(f"## {dim}D, m_n = {m:g}: Dörfler θ = 0.5 against uniform\n")
                adaptive, seconds = run(mesh, m, "adaptive", 20, theta=0.5, max_dofs=uniform[-1]["dofs"], dim=dim)
                adaptive_table(adaptive, uniform, seconds, dim)


if __name__ == "__main__":
    main(sys.argv[1:])
