"""Cattaneo–Mindlin partial slip of a cylinder on a stiff flat (the built-in case ``cattaneo``), measured.

Prints, with a header (date, commit, machine, command):
  1. the case against Hertz and Cattaneo–Mindlin: P, Q, a, c, and the tangential traction q(x) on Γ_C;
  2. the stick half-width c and Q against the slip regularisation ε_r (1e-1 … 1e-4);
  3. friction during the normal load (μ > 0 in step 1) with 1, 2, 4, 8 increments of step 1, and under
     uniform and local (contact-zone) refinement.
Run: PYTHONPATH=. /usr/bin/python3 verification/cattaneo.py [--quick]   (serial; ~3.5 min, --quick ~40 s)

Quantities (history rows of nc.adapt): P = -reaction_top[1] (normal force per unit length), Q =
|friction_force[0]| (the foundation's tangential force; reaction_top[0] also carries the x-component of the
pressure on the curved Γ_C and is shown as Q_top), a = contact_length/2 (the normal law's {p > 0}),
c = a · stick_length/(stick_length + slip_length) (the friction law's classification at the vertices of Γ_C,
each weighted by ∫ φ_i: the ratio taken within that one measure). Theory: Hertz
a_H = sqrt(4PR/(π E*)), E* = E/(1-ν²); Cattaneo–Mindlin c/a = (1 - Q/(μP))^{1/2}.
"""
import math
import sys
import time
from pathlib import Path

import numpy as np
import ufl
from mpi4py import MPI

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import nc_dolfinx as nc  # noqa: E402
from common import refined_around  # noqa: E402  (verification/common.py)

CASE = "cattaneo"


def case_problem(mu1=0.0, increments1=1, increments2=None, eps_r=None, mu2=None, dt=None, dn=None):
    """The built-in case, its load path modified: μ during step 1's normal load (``mu1``: the parameter's
    initial value, so it does not ramp; 0 is Cattaneo–Mindlin's frictionless normal load), the increments
    of step 1 (dn ramps from 0) and of step 3 (the shear), ε_r, step 2's μ, step 3's dt, step 1's dn."""
    source = nc.case_path(CASE)
    raw = dict(nc.load_problem(CASE).raw)
    steps = [dict(step, set=dict(step["set"])) for step in raw["steps"]]
    raw["parameters"] = dict(raw["parameters"], mu=mu1)
    steps[0]["increments"] = increments1
    if dn is not None:
        steps[0]["set"]["dn"] = dn
    if mu2 is not None:
        steps[1]["set"]["mu"] = mu2
    if increments2 is not None:
        steps[2]["increments"] = increments2
    if dt is not None:
        steps[2]["set"]["dt"] = dt
    raw["steps"] = steps
    if eps_r is not None:
        raw["contact"] = dict(raw["contact"], slip_regularisation=eps_r)
    return nc.Problem.from_dict(raw, CASE, source=source)


def refined_domain(problem, uniform=0, local=0, comm=MPI.COMM_WORLD, box=0.12):
    """The case's mesh refined ``uniform`` times everywhere, then ``local`` times in the cells whose
    midpoints lie in |x| < box, y < box/4 (around the contact zone |x| < 0.083)."""
    return refined_around(problem, lambda mids: (np.abs(mids[:, 0]) < box) & (mids[:, 1] < box / 4),
                          uniform, local, comm)


def measure(problem, domain=None):
    """Run the case; returns the final numbers and the traction profile (rank 0: sorted by x)."""
    t0 = time.perf_counter()
    result = nc.adapt(problem, domain=domain)
    seconds = time.perf_counter() - t0
    row = result.history[-1]
    first = [r for r in result.history if r.get("step") == 1][-1]
    values = problem.values
    E, nu = values["material"]["E"], values["material"]["nu"]
    mu = [step["set"]["mu"] for step in problem.values["steps"] if "mu" in step["set"]][-1]  # step 2's μ
    P = -row["reaction_top"][1]
    Q = abs(row["friction_force"][0])
    a = row["contact_length"] / 2
    c = a * _stick_fraction(row)
    hertz = nc.hertz_line_contact(P, 1.0, E, nu)
    ratio = Q / (mu * P)
    out = {"P": P, "Q": Q, "Q_top": abs(row["reaction_top"][0]), "a": a, "a_hertz": hertz["half_width"],
           "c": c, "c_over_a": c / a, "c_over_a_cm": math.sqrt(max(1 - ratio, 0.0)), "Q_over_muP": ratio,
           "mu": mu, "E": E, "nu": nu, "seconds": seconds, "dofs": row["dofs"],
           "passes": row.get("friction_passes"), "newton": row.get("friction_newton"), "P1": -first["reaction_top"][1],
           "c1": first["contact_length"] / 2 * _stick_fraction(first), "a1": first["contact_length"] / 2,
           "Q1": abs(first["friction_force"][0]), "max_slip": row["max_slip"]}
    out["profile"] = traction_profile(result.final.solution)
    return out


def _stick_fraction(row):
    """The stuck part of the friction law's contact zone (its vertices, weighted by ∫ φ_i), 0 without one."""
    zone = row["stick_length"] + row["slip_length"]
    return row["stick_length"] / zone if zone > 0 else 0.0


def traction_profile(solution):
    """The pressure p (lumped L² projection on Γ_C) and the x-component of the law's tangential traction
    at the vertices of Γ_C in contact, where the law is evaluated (the tangential_traction written for
    ParaView): rows (x, p, s_x), gathered on rank 0."""
    u, fields = solution.u, solution.fields
    n = ufl.FacetNormal(fields.domain.mesh)
    pressure = nc.contact_projection(nc.contact_pressure(u, fields, n), fields, "p")
    shear = nc.SlipState.after(u, fields).traction  # (the return map: the law's σ_t at the vertices)
    V, W = pressure.function_space, shear.function_space
    owned = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:owned, 0]
    assert np.array_equal(x, W.tabulate_dof_coordinates()[:owned, 0])  # (the same vertex numbering)
    rows = np.column_stack([x, pressure.x.array[:owned], shear.x.array[:2 * owned:2]])
    rows = rows[rows[:, 1] > 0]
    gathered = fields.domain.comm.gather(rows, root=0)
    if fields.domain.comm.rank != 0:
        return None
    rows = np.concatenate(gathered)
    rows = rows[np.argsort(rows[:, 0])]
    _, keep = np.unique(np.round(rows[:, 0], 12), return_index=True)
    return rows[keep]


def cm_traction(x, mu, p0, a, c):
    """Cattaneo–Mindlin's tangential traction magnitude q(x) (0 outside |x| < a)."""
    q = mu * p0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))
    inner = np.abs(x) < c
    q[inner] -= mu * p0 * (c / a) * np.sqrt(1 - (x[inner] / c) ** 2)
    return q


def profile_comparison(m):
    """The computed |s_x| against q(x) of Cattaneo–Mindlin with the computed P, a and Q: p0 = 2P/(π a),
    c = a (1 - Q/(μP))^{1/2}; and p against Hertz's p0 (1 - x²/a²)^{1/2}. Max and RMS differences at the
    nodes, relative to μ p0 (p0)."""
    x, p, s = m["profile"].T
    p0 = 2 * m["P"] / (math.pi * m["a"])
    a, mu = m["a"], m["mu"]
    q = cm_traction(x, mu, p0, a, a * m["c_over_a_cm"])
    hertz_p = p0 * np.sqrt(np.clip(1 - (x / a) ** 2, 0, None))
    return {"x": x, "p": p, "s": np.abs(s), "q": q, "hertz_p": hertz_p, "p0": p0,
            "q_max": np.abs(np.abs(s) - q).max() / (mu * p0), "q_rms": np.sqrt(np.mean((np.abs(s) - q) ** 2)) / (mu * p0),
            "p_max": np.abs(p - hertz_p).max() / p0, "p_rms": np.sqrt(np.mean((p - hertz_p) ** 2)) / p0}


def header(argv):
    from common import provenance
    return "\n".join([f"# Cattaneo–Mindlin partial slip (case {CASE}), verification/cattaneo.py",
                      *provenance("cattaneo.py", argv[1:], MPI.COMM_WORLD.size)])


def table(title, columns, rows):
    print(f"\n## {title}\n")
    print("| " + " | ".join(columns) + " |")
    print("|" + "|".join("---" for _ in columns) + "|")
    for row in rows:
        print("| " + " | ".join(row) + " |")


def main(argv):
    quick = "--quick" in argv
    rank0 = MPI.COMM_WORLD.rank == 0
    say = print if rank0 else (lambda *a, **k: None)
    say(header(argv))

    # 1. the case against Hertz and Cattaneo–Mindlin
    m = measure(case_problem())
    if rank0:
        cmp = profile_comparison(m)
        table("1. The case (step 1 frictionless, μ = 0.3 from step 2, step 3 the shear, ε_r = 1e-3) against Hertz "
              "and Cattaneo–Mindlin",
              ["quantity", "computed", "theory", "difference"], [
                  ["P (normal force / length)", f"{m['P']:.4f}", "", ""],
                  ["Q = abs(friction_force_x)", f"{m['Q']:.4f}", "", ""],
                  ["Q_top = abs(reaction_top_x)", f"{m['Q_top']:.4f}", f"Q = {m['Q']:.4f}",
                   f"{m['Q_top'] / m['Q'] - 1:+.2%}"],
                  ["Q/(μP)", f"{m['Q_over_muP']:.4f}", "", ""],
                  ["a (step 3)", f"{m['a']:.5f}", f"Hertz {m['a_hertz']:.5f}", f"{m['a'] / m['a_hertz'] - 1:+.2%}"],
                  ["a (step 1, frictionless)", f"{m['a1']:.5f}",
                   f"Hertz {nc.hertz_line_contact(m['P1'], 1.0, m['E'], m['nu'])['half_width']:.5f}",
                   f"{m['a1'] / nc.hertz_line_contact(m['P1'], 1.0, m['E'], m['nu'])['half_width'] - 1:+.2%}"],
                  ["c (stick half-width)", f"{m['c']:.5f}", f"{m['a'] * m['c_over_a_cm']:.5f}",
                   f"{m['c_over_a'] / m['c_over_a_cm'] - 1:+.2%}"],
                  ["c/a", f"{m['c_over_a']:.4f}", f"(1-Q/μP)^½ = {m['c_over_a_cm']:.4f}",
                   f"{m['c_over_a'] - m['c_over_a_cm']:+.4f}"],
                  ["p(x) vs Hertz p0 (1-x²/a²)^½, max / rms", "", "", f"{cmp['p_max']:.3f} / {cmp['p_rms']:.3f} p0"],
                  ["q(x) vs Cattaneo–Mindlin, max / rms", "", "", f"{cmp['q_max']:.3f} / {cmp['q_rms']:.3f} μp0"],
                  ["dofs / friction passes / time", f"{m['dofs']} / {m['passes']} / {m['seconds']:.1f} s", "", ""]])
        picks = np.linspace(0, m["a"] * 1.05, 12)
        x = cmp["x"]
        rows = []
        for target in picks:
            i = int(np.argmin(np.abs(x - target)))
            rows.append([f"{x[i]:.4f}", f"{x[i] / m['a']:.3f}", f"{cmp['p'][i] / cmp['p0']:.4f}",
                         f"{cmp['hertz_p'][i] / cmp['p0']:.4f}", f"{cmp['s'][i] / (m['mu'] * cmp['p0']):.4f}",
                         f"{cmp['q'][i] / (m['mu'] * cmp['p0']):.4f}"])
        table("1b. Traction on Γ_C at the vertices (p: lumped projection; s_x: the law's), x ≥ 0, "
              "in units of p0 = 2P/(π a) and μ p0",
              ["x", "x/a", "p/p0", "Hertz", "abs(s_x)/(μ p0)", "Cattaneo–Mindlin q/(μ p0)"], rows)

    # 2. the regularisation
    rows = []
    for eps_r in ((1e-1, 1e-2, 1e-3) if quick else (1e-1, 1e-2, 1e-3, 1e-4)):
        r = measure(case_problem(eps_r=eps_r))
        rows.append([f"{eps_r:.0e}", f"{r['Q']:.4f}", f"{r['Q_over_muP']:.4f}", f"{r['a']:.5f}", f"{r['c']:.5f}",
                     f"{r['c_over_a']:.4f}", f"{r['c_over_a_cm']:.4f}", f"{r['max_slip']:.2e}", str(r['passes']),
                     f"{r['seconds']:.1f}"])
    table("2. Step 3 (the shear) against the slip regularisation ε_r (step 1 frictionless)",
          ["ε_r", "Q", "Q/(μP)", "a", "c", "c/a", "CM (1-Q/μP)^½", "max slip (last incr.)", "passes", "time s"], rows)

    # 3. friction during the normal load
    def row3(label, uniform, local, r):
        return [label, str(uniform), str(local), f"{r['a1']:.5f}", f"{r['c1']:.5f}", f"{r['c1'] / r['a1']:.4f}",
                f"{r['Q']:.4f}", f"{r['a'] / r['a_hertz'] - 1:+.2%}", f"{r['c']:.5f}", f"{r['c_over_a']:.4f}",
                f"{r['c_over_a_cm']:.4f}", f"{r['c_over_a'] - r['c_over_a_cm']:+.4f}", str(r['dofs']),
                f"{r['seconds']:.1f}"]
    rows = []
    for n1 in ((1, 2, 4) if quick else (1, 2, 4, 8, 16)):
        rows.append(row3(str(n1), 0, 0, measure(case_problem(mu1=0.3, increments1=n1))))
    for uniform, local in (((1, 0), (0, 1)) if quick else ((1, 0), (2, 0), (0, 1), (0, 2))):
        for mu1 in (0.0, 0.3):
            problem = case_problem(mu1=mu1, increments1=4 if mu1 else 1)
            r = measure(problem, refined_domain(problem, uniform, local))
            rows.append(row3("4" if mu1 else "1, μ = 0", uniform, local, r))
    table("3. μ = 0.3 already during the normal load (step 1): increments of step 1, uniform and local "
          "refinement (rows 'μ = 0': Cattaneo–Mindlin's path on the same mesh)",
          ["step-1 incr.", "uniform", "local", "a (step 1)", "c (step 1, last incr.)", "c/a (step 1)", "Q",
           "a/a_H - 1", "c", "c/a", "CM (1-Q/μP)^½", "c/a - CM", "dofs", "time s"], rows)


if __name__ == "__main__":
    main(sys.argv)
