#!/usr/bin/env python3
"""Cattaneo–Mindlin between two identical elastic cylinders (the built-in case ``cattaneo_cylinders``, issue 47).

Two half-discs of radius 1 and one material (Dundurs' β = 0), pressed together without friction (step 1),
μ = 0.3 switched on (step 2), then the upper one's top moved sideways at fixed normal displacement (step 3):
Coulomb friction between the bodies ([[pairs]] friction). The half-plane theory's answer is then exact:
the Hertz half-width a = 2 sqrt(P R/(π E*)) (R = 1/2, E* = E/(2(1 − ν²))) is kept, and a central stick zone
|x| < c with c/a = (1 − Q/(μP))^{1/2} appears. A client of the public API; prints markdown tables
(docs/src/guide/two_bodies.md holds a run of them) and writes them, with two figures, to ``--out``::

    PYTHONPATH=. /usr/bin/python3 verification/cattaneo_two_bodies.py [--quick] [--out DIR]

(1) ``closed form``: sympy (and mpmath for two principal-value integrals) checks the formulas compared with:
    ∫ p = P for p = p0 (1 − x²/a²)^{1/2}, p0 = 2P/(π a); the two-cylinder Hertz half-width from the
    half-plane compatibility (2/(π E*)) PV∫ p(s)/(x − s) ds = x/R on |x| < a; ∫ q = Q for Cattaneo–Mindlin's
    q(x) = μ p0 (1 − x²/a²)^{1/2} − μ p0 (c/a)(1 − x²/c²)^{1/2} (the last term on |x| < c), which gives
    c/a = (1 − Q/(μP))^{1/2}; 0 ≤ q ≤ μ p; and no relative tangential strain in the stick zone
    (PV∫ q(s)/(x − s) ds = 0 on |x| < c: with β = 0 the derivative of the tangential jump across the two
    half-planes is −2/(π E*) times that integral, so the jump is constant there: no slip).
(2) ``the case``: the shipped mesh, the shear of step 3 in ``increments`` equal parts (default 3): each
    increment's Q/(μP) and c/a_H against (1 − Q/(μP))^{1/2}, the difference also in chords of the upper face.
(3) ``refinement``: the same three loads on the shipped mesh refined once and twice in the contact zone
    (cells with midpoints |x| < 0.1, |y| < 0.025: both bodies) and once uniformly.
(4) ``path``: the last load reached in 1 increment and in ``increments``: for a monotone shear the
    Cattaneo–Mindlin state does not depend on the path.
(5) ``half-width``: the computed contact's half-width under the shear against step 1's, a/a1 − 1 (Cattaneo–Mindlin
    keeps it: β = 0), and c/a_H, at dn, dn/4 and dn/16 (dt scaled alike: a/R from 0.1 to 0.02).
(6) ``frictionless slide``: the path with μ = 0 throughout: the upper body slides by about dt, a small slide
    that should leave the contact's width and pressure as they were; where each face's pressure lies, the
    contact's width, its peak and the force's x-component (with ``--quick`` one dt). With each half-pass
    measuring the normal jump along its own face's normal (before 26e3871), the two faces' pressures moved
    apart by 24 dt and the contact narrowed (by 6.8 % at dt = 5e-4, 0.65 chords; by up to 5.9 % in the case's
    shear): docs, guide/two_bodies.md.

Quantities (history rows of nc.adapt, per pair 1): P = pair1_force[1] (the normal force per unit length on
the upper body), Q = |pair1_friction_force[0]| (the tangential force between the bodies), Q_n = |pair1_force[0]|
(all of the force's x-component, with the x-part of the pressure on the curved faces), c =
pair1_stick_length/2 (the stuck vertices of the upper face, each with its lumped measure: the stick zone's
edge at each end within half a chord h of the last stuck vertex), a_H = 2 (P R/(π E*))^{1/2} (Hertz's
half-width at the computed P: Cattaneo–Mindlin's a), a = pair1_contact_length/2 (the computed {p > 0} on the
upper face; a1 in step 1, which exceeds a_H by the penalty's tail, 0.6–0.9 %). c/a_H is compared with the
theory; the difference is also given in chords, |c/a_H − theory| a_H/h.
"""
import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "verification"))

import nc_dolfinx as nc  # noqa: E402
from common import refined_around  # noqa: E402  (verification/common.py)

CASE = "cattaneo_cylinders"
COMM = MPI.COMM_WORLD
RADIUS = 0.5  # R1 R2/(R1 + R2), R1 = R2 = 1
BOX = 0.1     # the local refinement's box: |x| < BOX, |y| < BOX/4 (the contact zone is |x| < a ≈ 0.052)


def say(*args):
    if COMM.rank == 0:
        print(*args, flush=True)


# --- (1) the closed form -------------------------------------------------------------------------------

def _hilbert(f, x, half_width, kinks=()):
    """PV∫_{-h}^{h} f(s)/(x − s) ds for |x| < h (mpmath; f smooth but at ``kinks``, where the rule is split):
    the regular part plus f(x) times PV∫ ds/(x − s) = ln((h + x)/(h − x))."""
    import mpmath
    fx = f(x)
    points = sorted({-half_width, half_width, x, *kinks})
    regular = mpmath.quad(lambda s: (f(s) - fx) / (x - s) if s != x else 0, points)
    return float(regular + fx * mpmath.log((half_width + x) / (half_width - x)))


def closed_form():
    """The formulas the study compares with, checked with sympy (symbolically) and mpmath (two principal
    values, at a few points): a list of (check, residual) with residuals that must vanish (to round-off for
    the numerical ones)."""
    import sympy as sp
    x = sp.symbols("x", real=True)
    a, c, P, mu, E, nu, R1, R2, rho = sp.symbols("a c P mu E nu R_1 R_2 rho", positive=True)
    p0 = 2 * P / (sp.pi * a)
    p = p0 * sp.sqrt(1 - x ** 2 / a ** 2)
    q_outer, q_inner = mu * p, mu * p0 * (c / a) * sp.sqrt(1 - x ** 2 / c ** 2)
    Q = sp.integrate(q_outer, (x, -a, a)) - sp.integrate(q_inner, (x, -c, c))
    out = [("∫ p dx − P (Hertz's p0 = 2P/(π a))", sp.simplify(sp.integrate(p, (x, -a, a)) - P)),
           ("∫ q dx − μP (1 − c²/a²) (Cattaneo–Mindlin's q)", sp.simplify(Q - mu * P * (1 - c ** 2 / a ** 2)))]
    roots = sp.solve(sp.Eq(Q, rho * mu * P), c)
    out.append(("c − a (1 − Q/(μP))^{1/2} (the root of ∫ q = Q)",
                sp.simplify(roots[0] - a * sp.sqrt(1 - rho)) if len(roots) == 1 else sp.nan))
    # q ≥ 0 in the stick zone: (q_outer² − q_inner²)/(μ p0)² = 1 − c²/a², a constant ≥ 0 (c ≤ a);
    # q ≤ μ p: q_inner ≥ 0
    gap = sp.simplify((q_outer ** 2 - q_inner ** 2) / (mu * p0) ** 2)
    out.append(("(q_outer² − q_inner²)/(μ p0)² − (1 − c²/a²) (so 0 ≤ q ≤ μp on −c < x < c)",
                sp.simplify(gap - (1 - c ** 2 / a ** 2))))
    e_star = 1 / ((1 - nu ** 2) / E + (1 - nu ** 2) / E)
    out.append(("E* − E/(2(1 − ν²)) (one material on both sides)",
                sp.simplify(e_star - E / (2 * (1 - nu ** 2)))))
    out.append(("R1 R2/(R1 + R2) − 1/2 at R1 = R2 = 1",
                (R1 * R2 / (R1 + R2)).subs({R1: 1, R2: 1}) - sp.Rational(1, 2)))
    # the half-plane compatibility of Hertz and of the stick zone, numerically (a = 1 in units of a; c = 0.6):
    # PV∫ (1 − s²)^{1/2}/(x − s) ds = π x, so (2/(π E*)) p0 π x = x/R gives p0 = a E*/(2R), a² = 4 P R/(π E*);
    # and the stick-zone term cancels the outer one: PV∫ q(s)/(x − s) ds = 0 on |x| < c.
    points = (-0.83, -0.41, 0.07, 0.36, 0.92)
    hertz = max(abs(_hilbert(lambda s: math.sqrt(max(1 - s * s, 0.0)), t, 1.0) - math.pi * t) for t in points)
    out.append(("PV∫ (1 − s²)^{1/2}/(x − s) ds − π x, largest over −1 < x < 1 (Hertz's compatibility)", hertz))
    ca = 0.6

    def q_unit(s):  # q/(μ p0) with a = 1, c = 0.6
        inner = ca * math.sqrt(max(1 - (s / ca) ** 2, 0.0)) if abs(s) < ca else 0.0
        return math.sqrt(max(1 - s * s, 0.0)) - inner
    stick = max(abs(_hilbert(q_unit, ca * t, 1.0, (-ca, ca))) for t in (-0.9, -0.5, 0.1, 0.45, 0.8))
    out.append(("PV∫ q(s)/(x − s) ds/(μ p0), largest over −c < x < c (no tangential strain jump where stuck)",
                stick))
    R = R1 * R2 / (R1 + R2)
    half_width = sp.solve(sp.Eq(p0, a * e_star / (2 * R)), a)
    out.append(("a − 2 (P R/(π E*))^{1/2} (the half-width from p0 = a E*/(2R))",
                sp.simplify(half_width[0] - 2 * sp.sqrt(P * R / (sp.pi * e_star))) if len(half_width) == 1 else sp.nan))
    return [(text, float(value)) for text, value in out]


# --- the case, its loads and meshes --------------------------------------------------------------------

def hertz_half_width(P, E, nu):
    return 2 * math.sqrt(P * RADIUS / (math.pi * E / (2 * (1 - nu ** 2))))


def case_problem(increments=None, dt=None, mu=None, eps_r=None, dn=None):
    """The built-in case, its load path modified: the increments of step 3 (the shear), its final dt,
    step 2's μ, the slip regularisation ε_r, step 1's dn."""
    raw = dict(nc.load_problem(CASE).raw)
    steps = [dict(step, set=dict(step["set"])) for step in raw["steps"]]
    if dn is not None:
        steps[0]["set"]["dn"] = dn
    if increments is not None:
        steps[2]["increments"] = increments
    if dt is not None:
        steps[2]["set"]["dt"] = dt
    if mu is not None:
        steps[1]["set"]["mu"] = mu
    raw["steps"] = steps
    if eps_r is not None:
        raw["contact"] = dict(raw.get("contact", {}), slip_regularisation=eps_r)
    return nc.Problem.from_dict(raw, CASE, source=nc.case_path(CASE))


def refined_domain(problem, uniform=0, local=0, comm=COMM):
    """The case's mesh refined ``uniform`` times everywhere, then ``local`` times in the cells whose midpoints
    lie in |x| < BOX, |y| < BOX/4 (both bodies around the contact zone)."""
    return refined_around(problem, lambda mids: (np.abs(mids[:, 0]) < BOX) & (np.abs(mids[:, 1]) < BOX / 4),
                          uniform, local, comm)


def chord(domain, group="upper_contact", half_width=0.06):
    """The longest edge of a face (boundary group) with its midpoint at |x| < half_width, over all ranks: the
    spacing of the vertices at which the friction law classifies stick and slip."""
    msh = domain.mesh
    fdim = msh.topology.dim - 1
    tags = domain.facet_tags
    facets = tags.indices[tags.values == domain.facet_groups[group]]
    nodes = nc.dolfinx_versions.entities_to_geometry(msh, fdim, facets)
    x = msh.geometry.x[nodes] if len(facets) else np.zeros((0, 2, 3))
    length = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    near = np.abs(x.mean(axis=1)[:, 0]) < half_width
    return domain.comm.allreduce(float(length[near].max(initial=0.0)), op=MPI.MAX)


def quantities(row, mu, E, nu, a1=None):
    """One history row's P, Q, c, the contact's half-width a, Hertz's a_H at that P, c/a_H against
    (1 − Q/(μP))^{1/2} (module docstring); with ``a1`` (step 1's computed half-width) also a/a1 − 1."""
    P = row["pair1_force"][1]
    friction = row.get("pair1_friction_force", [0.0, 0.0])
    Q = abs(friction[0])
    a = row["pair1_contact_length"] / 2
    stick, slip = row.get("pair1_stick_length", 0.0), row.get("pair1_slip_length", 0.0)
    ratio = Q / (mu * P) if mu > 0 and P > 0 else math.inf
    theory = math.sqrt(max(1 - ratio, 0.0)) if math.isfinite(ratio) else 0.0
    a_h = hertz_half_width(P, E, nu)
    c = stick / 2
    a1 = a if a1 is None else a1
    return {"P": P, "Q": Q, "Q_n": abs(row["pair1_force"][0]), "a": a, "a_hertz": a_h, "a_error": a / a_h - 1,
            "c": c, "c_over_a": c / a_h, "Q_over_muP": ratio, "c_over_a_cm": theory, "difference": c / a_h - theory,
            "a1": a1, "narrowing": a / a1 - 1, "stick": stick, "slip": slip, "friction_force": list(friction),
            "dofs": row["dofs"], "max_pressure": row["pair1_max_pressure"], "dt": row.get("param_dt"),
            "step": row.get("step"), "increment": row.get("increment")}


def measure(problem, domain=None):
    """Run the case's load path: the step-1 numbers (frictionless Hertz), and one entry per increment of the
    shear (step 3), each :func:`quantities` (c/a1: against step 1's half-width); ``chord`` the upper face's
    longest edge near the contact, ``seconds`` the run's."""
    t0 = time.perf_counter()
    result = nc.adapt(problem, domain=domain)
    seconds = time.perf_counter() - t0
    values = problem.values
    E, nu = values["material"]["E"], values["material"]["nu"]
    mu = [step["set"]["mu"] for step in values["steps"] if "mu" in step["set"]][-1]
    rows = result.history
    press = quantities([r for r in rows if r.get("step") == 1][-1], mu, E, nu)
    shear = [quantities(r, mu, E, nu, press["a"]) for r in rows if r.get("step") == 3]
    return {"press": press, "shear": shear, "mu": mu, "E": E, "nu": nu, "seconds": seconds,
            "dofs": rows[-1]["dofs"], "chord": chord(result.final.solution.domain), "history": rows}


def frictionless_slide(dt):
    """The case's path with μ = 0 throughout and the shear dt in one increment: the upper body slides by about
    dt on the lower one. Returns a/a1 − 1, the peak pressure over step 1's, |pair1_force_x|/P and, per face
    (side 0 the upper, 1 the lower), the pressure-weighted mean x of the pair's integration points."""
    result = nc.adapt(case_problem(increments=1, dt=dt, mu=0.0))
    first, last = result.history[0], result.history[-1]
    u, fields = result.final.solution.u, result.final.solution.fields
    centres = []
    for side in (0, 1):
        x, p = nc.pair_pressure(u, fields, 1, side)
        sums = COMM.allreduce(np.array([float(x[:, 0] @ p), float(p.sum())]), op=MPI.SUM)
        centres.append(sums[0] / sums[1])
    return {"dt": dt, "narrowing": last["pair1_contact_length"] / first["pair1_contact_length"] - 1,
            "peak": last["pair1_max_pressure"] / first["pair1_max_pressure"],
            "force_x": abs(last["pair1_force"][0]) / last["pair1_force"][1], "centres": centres,
            "a1": first["pair1_contact_length"] / 2}


# --- output --------------------------------------------------------------------------------------------

def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def shear_rows(run):
    h = run["chord"]
    return [[f"{q['Q_over_muP']:.4f}", f"{q['Q']:.4f}", f"{q['Q_n']:.4f}", f"{q['c']:.5f}", f"{q['a_hertz']:.5f}",
             f"{q['c_over_a']:.4f}", f"{q['c_over_a_cm']:.4f}", f"{q['difference']:+.4f}",
             f"{abs(q['difference']) * q['a_hertz'] / h:.2f}", f"{q['a']:.5f}", f"{q['narrowing']:+.2%}"]
            for q in run["shear"]]


SHEAR_HEADER = ["Q/(μP)", "Q", "abs(force_x)", "c", "a_H", "c/a_H", "(1 − Q/μP)^½", "c/a_H − theory", "in chords",
                "a", "a/a1 − 1"]


def slope(x, y):
    x, y = np.asarray(x, float), np.abs(np.asarray(y, float))
    ok = y > 0
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0]) if ok.sum() > 1 else float("nan")


def figures(out, case, levels):
    """c/a_H against Q/(μP) (every mesh, and the theory's curve); max |c/a_H − theory|, one chord h/a_H and
    |a1/a_H − 1| against dofs."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(5.5, 4))
    r = np.linspace(0, 1, 201)
    ax.plot(r, np.sqrt(1 - r), "k-", label="Cattaneo–Mindlin (1 − Q/μP)^½")
    for (label, run), marker in zip(levels, "os^vDx"):
        ax.plot([q["Q_over_muP"] for q in run["shear"]], [q["c_over_a"] for q in run["shear"]], marker,
                mfc="none", label=f"{label} ({run['dofs']} dofs)")
    ax.set_ylabel("c/a_H (a_H: Hertz's half-width at the computed P)")
    _finish(plt, fig, ax, "Q/(μP)", "the stick zone", out / "stick_zone.png")
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for kind, style in (("local", "-"), ("uniform", "none")):  # the shipped mesh starts the local line
        runs = [run for label, run in levels if (label.startswith("uniform")) == (kind == "uniform")]
        if not runs:
            continue
        dofs = [run["dofs"] for run in runs]
        local = kind == "local"
        ax.loglog(dofs, [max(abs(q["difference"]) for q in run["shear"]) for run in runs], marker="o", ls=style,
                  color="C0", label="max |c/a_H − (1 − Q/μP)^½|" if local else "uniform x1 (markers alone)")
        ax.loglog(dofs, [run["chord"] / run["press"]["a_hertz"] for run in runs], marker=".", ls=style, color="C1",
                  label="h/a_H (one chord)" if local else None)
        ax.loglog(dofs, [abs(run["press"]["a_error"]) for run in runs], marker="s", ls=style, color="C2",
                  label="|a1/a_Hertz − 1| (step 1)" if local else None)
    _finish(plt, fig, ax, "dofs", "refinement", out / "convergence.png")


def _finish(plt, fig, ax, xlabel, title, path):
    ax.set_xlabel(xlabel)
    ax.set_title(f"{CASE}: {title}")
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer refinements (a minute)")
    parser.add_argument("--increments", type=int, default=3, help="increments of the shear (step 3)")
    parser.add_argument("--out", default="results/cattaneo_two_bodies", help="where table.md and the PNGs go")
    args = parser.parse_args(argv)
    from common import provenance
    lines = [f"# Cattaneo–Mindlin between two identical cylinders (case {CASE}), verification/cattaneo_two_bodies.py",
             *provenance("cattaneo_two_bodies.py", sys.argv[1:] if argv is None else argv, COMM.size)]
    say("\n".join(lines))

    def emit(text):
        lines.append(text)
        say(text)

    checks = closed_form()
    emit("\n**(1) The closed form** (sympy; the principal values by mpmath at five points)\n")
    emit(table(["check", "residual"], [[text, f"{value:.1e}"] for text, value in checks]))

    problem = case_problem(increments=args.increments)
    case = measure(problem)
    press = case["press"]
    emit(f"\n**(2) The case** (shipped mesh, {case['dofs']} dofs, upper chord h = {case['chord']:.2e} at the "
         f"contact; step 1 frictionless: P = {press['P']:.4f}, a1 = {press['a']:.5f}, Hertz a_H = "
         f"{press['a_hertz']:.5f} ({press['a_error']:+.2%}), h/a_H = {case['chord'] / press['a_hertz']:.4f}; "
         f"μ = {case['mu']}, the shear in {args.increments} increments; {case['seconds']:.0f} s)\n")
    emit(table(["dt", *SHEAR_HEADER], [[f"{q['dt']:.5f}" if q["dt"] is not None else "-", *row]
                                       for q, row in zip(case["shear"], shear_rows(case))]))

    levels = [("shipped", case)]
    for local in ((1,) if args.quick else (1, 2)):
        levels.append((f"local x{local}", measure(problem, refined_domain(problem, local=local))))
    if not args.quick:
        levels.append(("uniform x1", measure(problem, refined_domain(problem, uniform=1))))
    rows = []
    for label, run in levels:
        rows += [[label, run["dofs"], f"{run['chord'] / run['press']['a_hertz']:.4f}",
                  f"{run['press']['a_error']:+.2%}", *row[:1], *row[5:]] for row in shear_rows(run)]
    emit("\n**(3) Refinement** (the same loads; local: the cells in |x| < 0.1, |y| < 0.025 refined, both bodies; "
         "h the upper face's chord at the contact)\n")
    emit(table(["mesh", "dofs", "h/a_H", "a1/a_H − 1", "Q/(μP)", "c/a_H", "(1 − Q/μP)^½", "c/a_H − theory",
                "in chords", "a", "a/a1 − 1"], rows))
    local = [run for label, run in levels if not label.startswith("uniform")]
    emit(f"\nfitted slope of max |c/a_H − theory| against dofs (local refinement): "
         f"{slope([r['dofs'] for r in local], [max(abs(q['difference']) for q in r['shear']) for r in local]):.2f}")

    one = measure(case_problem(increments=1))
    last, single = case["shear"][-1], one["shear"][-1]
    emit(f"\n**(4) The path** (the last load in 1 increment against {args.increments})\n")
    emit(table(["increments", "Q/(μP)", "a", "c/a_H", "(1 − Q/μP)^½"],
               [[n, f"{q['Q_over_muP']:.5f}", f"{q['a']:.5f}", f"{q['c_over_a']:.4f}", f"{q['c_over_a_cm']:.4f}"]
                for n, q in ((1, single), (args.increments, last))]))

    rows = []
    for scale in ((1.0, 0.25) if args.quick else (1.0, 0.25, 0.0625)):
        run = case if scale == 1.0 else measure(case_problem(dn=0.01 * scale, dt=0.004 * scale))
        a1 = run["press"]["a"]
        rows += [[f"{0.01 * scale:g}", f"{a1:.5f}", f"{a1 / 0.5:.4f}", f"{run['chord'] / a1:.4f}",
                  f"{q['Q_over_muP']:.4f}", f"{q['narrowing']:+.2%}", f"{q['difference']:+.4f}"] for q in run["shear"]]
    emit("\n**(5) The contact's half-width under the shear against a/R** (dn and dt scaled together; R = 1/2)\n")
    emit(table(["dn", "a1", "a1/R", "h/a1", "Q/(μP)", "a/a1 − 1", "c/a_H − theory"], rows))

    slides = [frictionless_slide(dt) for dt in ((5e-4,) if args.quick else (1e-4, 5e-4, 2.5e-3))]
    emit("\n**(6) A frictionless slide** (μ = 0 throughout, the upper top moved by dt at fixed dn; h the upper "
         "face's chord; centre: the pressure-weighted mean x of each face's integration points)\n")
    emit(table(["dt", "dt/h", "a/a1 − 1", "peak p / step 1's", "abs(force_x)/P", "centre, upper face / a1",
                "centre, lower face / a1"],
               [[f"{r['dt']:g}", f"{r['dt'] / case['chord']:.2f}", f"{r['narrowing']:+.2%}", f"{r['peak']:.3f}",
                 f"{r['force_x']:.4f}", f"{r['centres'][0] / r['a1']:+.4f}", f"{r['centres'][1] / r['a1']:+.4f}"]
                for r in slides]))

    if COMM.rank == 0:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        (out / "table.md").write_text("\n".join(lines) + "\n")
        figures(out, case, levels)
        say(f"\nwrote {out / 'table.md'}, {out / 'stick_zone.png'}, {out / 'convergence.png'}")
    return {"checks": checks, "case": case, "levels": levels, "one_increment": one}


if __name__ == "__main__":
    main()
