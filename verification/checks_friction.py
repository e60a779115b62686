"""The expectations of the friction studies (issue 32), evaluated on worker_friction.py's measurements."""
from checks import Section, dofs_to_reach
from common import fitted_slope, spread
from manufactured_friction import EXACT_FORCE

TITLES = {
    "friction_exact": "14. Friction: exact sheared layers (stick and slip, 2D and 3D) and μ = 0",
    "friction_manufactured": "15. Friction: manufactured solutions with stick and slip zones",
    "cattaneo": "16. Friction: Cattaneo–Mindlin partial slip of a cylinder and a sphere",
}
ORDER = list(TITLES)

NODAL_RTOL = {"stick": 1e-10, "slip": 1e-6}  # relative to the penetration d; slip: the bound's equality leaves
                                              # the slip s determined only through d (tests/test_friction.py)
ETA_EXACT = 1e-8          # η relative to the friction force on an exact state
ZERO_FRICTION = 1e-12     # max |u(μ=0) − u(frictionless)| / max |u|
H1_SLOPE = {2: (-0.55, -0.45), 3: (-0.40, -0.28)}  # against dofs: −1/2 in 2D, −1/3 in 3D
EFF_BOUNDS = (1.0, 20.0)
EFF_SETTLE = 0.10         # max/min − 1 of η/‖e‖_1 over the last three uniform levels (2D)
FORCE_ORDER = 1.5         # the friction force's error falls at least like h^1.5 in 2D (measured h²)
# Cattaneo–Mindlin (tests/test_cattaneo.py and test_cattaneo3d.py say where the tolerances come from): the
# contact size against Hertz, the stick zone against c/a = (1 − Q/(μP))^(1/2) (cylinder) or ^(1/3) (sphere)
CYLINDER_A, CYLINDER_C = 0.02, 0.03   # |a/a_Hertz − 1|, |c/a − CM|
SPHERE_A, SPHERE_C = 0.05, (-0.04, 0.04)  # |a/a_Hertz − 1|, (c/a)/CM − 1 (the shipped mesh: a/10 cells)
LAYER_DOF_RATIO = 3.0     # manufactured_friction_layer(3d): uniform needs this many times adaptive's dofs (measured ~7, ~12)


PASSES = "passes + Newton"  # the solver's cost: passes of the fixed point, steps of its consistent Newton finish


def cost(passes, newton):
    """A table cell: the fixed point's passes and the Newton finish's steps (runs from before the finish:
    passes only)."""
    return str(passes) if newton is None else f"{passes} + {newton}"


def friction_exact(data):
    s = Section("friction_exact", TITLES["friction_exact"])
    rows = []
    for layer in data["layers"]:
        force = layer["friction_force"][0] / layer["exact_friction_force"] - 1
        rows.append([f"{layer['dim']}D", layer["mode"], f"{layer['m_n']:g}", f"{layer['nodal_error']:.2e}",
                     f"{force:+.2e}", f"{layer['eta']:.2e}", f"{layer[layer['mode']]:.4f}", cost(layer["friction_passes"], layer.get("friction_newton")),
                     f"{layer['force_balance']:.1e}"])
        name = f"{layer['dim']}D {layer['mode']}, m_n = {layer['m_n']:g}"
        tolerance = NODAL_RTOL[layer["mode"]]
        s.check(f"{name}: nodal error / d", f"{layer['nodal_error']:.2e}", f"< {tolerance:g}",
                layer["nodal_error"] < tolerance)
        s.check(f"{name}: η / |friction force|", f"{layer['eta'] / abs(layer['exact_friction_force']):.1e}",
                f"< {ETA_EXACT:g}", layer["eta"] < ETA_EXACT * abs(layer["exact_friction_force"]))
    s.tables.append((f"exact linear states of the regularised law (ε_r = {data['eps_r']:g}); nodal error relative to "
                     "the penetration d",
                     ["dim", "mode", "m_n", "nodal error", "force − exact", "η", "stick/slip measure", PASSES,
                      "balance"], rows))
    s.check("μ = 0 against the frictionless problem", f"max |Δu|/max |u| = {data['zero_friction']:.1e}",
            f"<= {ZERO_FRICTION:g}", data["zero_friction"] <= ZERO_FRICTION)
    return s


def _uniform_table(rows, dim):
    measure = "stick_length" if dim == 2 else "stick_area"
    table = []
    for r in rows:
        force = abs(r["friction_force"][0] / EXACT_FORCE[dim] - 1)
        table.append([r["level"], r["dofs"], f"{r['h1_error']:.4e}", f"{r['eta']:.4e}",
                      f"{r['eta'] / r['h1_error']:.3f}", f"{(r['eta_3'] / r['eta']) ** 2:.1e}", f"{force:.2e}",
                      f"{r[measure]:.4f}", cost(r["friction_passes"], r.get("friction_newton"))])
    return table


def friction_manufactured(data):
    s = Section("friction_manufactured", TITLES["friction_manufactured"])
    headers = ["level", "dofs", "‖u − u_h‖_1", "η", "η/‖e‖_1", "η_3²/η²", "|F_t/F_t,exact − 1|", "stick", PASSES]
    for dim in (2, 3):
        rows = data[f"uniform{dim}"]
        s.tables.append((f"{dim}D uniform refinement", headers, _uniform_table(rows, dim)))
        fit = rows[-3:] if dim == 2 else rows[-2:]  # 3D: the first step from 6³ is preasymptotic
        slope = fitted_slope([r["dofs"] for r in fit], [r["h1_error"] for r in fit])
        low, high = H1_SLOPE[dim]
        s.check(f"{dim}D H¹ error against dofs", f"slope {slope:.3f}", f"in [{low}, {high}]", low <= slope <= high)
        effectivity = [r["eta"] / r["h1_error"] for r in rows]
        s.check(f"{dim}D effectivity η/‖e‖_1 on every level", f"{min(effectivity):.2f} … {max(effectivity):.2f}",
                f"in [{EFF_BOUNDS[0]:g}, {EFF_BOUNDS[1]:g}]",
                EFF_BOUNDS[0] <= min(effectivity) and max(effectivity) <= EFF_BOUNDS[1])
    effectivity = [r["eta"] / r["h1_error"] for r in data["uniform2"][-3:]]
    s.check("2D effectivity settles (last three levels)", f"max/min − 1 = {spread(effectivity):.3f}",
            f"< {EFF_SETTLE:g}", spread(effectivity) < EFF_SETTLE)
    rows = data["uniform2"][-3:]
    errors = [abs(r["friction_force"][0] / EXACT_FORCE[2] - 1) for r in rows]
    order = -2 * fitted_slope([r["dofs"] for r in rows], errors)  # h ∝ dofs^(−1/2)
    s.check("2D friction force converges", f"error ∝ h^{order:.2f}", f">= h^{FORCE_ORDER:g}", order >= FORCE_ORDER)
    adaptive = data["adaptive2"]
    s.tables.append(("2D Dörfler θ = 0.5 (the exact u is a polynomial: uniform refinement is already optimal, so "
                     "adaptivity is not expected to gain)",
                     ["level", "dofs", "‖u − u_h‖_1", "η/‖e‖_1", "stick"],
                     [[r["level"], r["dofs"], f"{r['h1_error']:.4e}", f"{r['eta'] / r['h1_error']:.3f}",
                       f"{r['stick_length']:.4f}"] for r in adaptive]))
    ratio = [r["eta"] / r["h1_error"] for r in adaptive]
    s.check("2D adaptive effectivity", f"{min(ratio):.2f} … {max(ratio):.2f}",
            f"in [{EFF_BOUNDS[0]:g}, {EFF_BOUNDS[1]:g}]", EFF_BOUNDS[0] <= min(ratio) and max(ratio) <= EFF_BOUNDS[1])
    for dim, key in ((2, "layer"), (3, "layer3d")):
        _layer_against_uniform(s, dim, data[f"{key}_uniform"], data[f"{key}_adaptive"])
    return s


def _layer_against_uniform(s, dim, uniform, adaptive):
    """The table and the check of a bump case: the dofs uniform refinement spends for its finest error,
    against adaptive refinement's."""
    name = "manufactured_friction_layer" + ("3d" if dim == 3 else "")
    ratio = uniform[-1]["dofs"] / dofs_to_reach(adaptive, uniform[-1]["h1_error"])
    s.tables.append((f"{dim}D {name}: a narrow bump inside the body; uniform, then Dörfler θ = 0.5",
                     ["refinement", "level", "dofs", "‖u − u_h‖_1", "η/‖e‖_1"],
                     [[kind, r["level"], r["dofs"], f"{r['h1_error']:.4e}", f"{r['eta'] / r['h1_error']:.3f}"]
                      for kind, rows in (("uniform", uniform), ("adaptive", adaptive)) for r in rows]))
    label = "adaptive beats uniform (layer)" if dim == 2 else "3D adaptive beats uniform (layer3d)"
    s.check(label, f"uniform needs {ratio:.1f}× the dofs for its finest error", f">= {LAYER_DOF_RATIO:g}×",
            ratio >= LAYER_DOF_RATIO)
    if dim == 3:
        effectivity = [r["eta"] / r["h1_error"] for r in uniform + adaptive]
        s.check("3D effectivity η/‖e‖_1 on the bump case (both runs)",
                f"{min(effectivity):.2f} … {max(effectivity):.2f}", f"in [{EFF_BOUNDS[0]:g}, {EFF_BOUNDS[1]:g}]",
                EFF_BOUNDS[0] <= min(effectivity) and max(effectivity) <= EFF_BOUNDS[1])


def cattaneo(data):
    s = Section("cattaneo", TITLES["cattaneo"])
    c = data["cylinder"]
    s.tables.append(("cylinder (2D, plane strain): pressed without friction, then moved sideways with μ = "
                     f"{c['mu']:g}", ["P", "Q", "Q/(μP)", "a", "a Hertz", "c/a", "CM (1 − Q/μP)^½", PASSES],
                     [[f"{c['P']:.4f}", f"{c['Q']:.4f}", f"{c['Q_over_muP']:.3f}", f"{c['a']:.5f}",
                       f"{c['a_hertz']:.5f}", f"{c['c_over_a']:.3f}", f"{c['c_over_a_cm']:.3f}", cost(c["passes"], c.get("newton"))]]))
    error = c["a"] / c["a_hertz"] - 1
    s.check("cylinder: contact half-width against Hertz", f"{100 * error:+.2f} %", f"within ±{100 * CYLINDER_A:g} %",
            abs(error) <= CYLINDER_A)
    gap = c["c_over_a"] - c["c_over_a_cm"]
    s.check("cylinder: stick zone against Cattaneo–Mindlin", f"c/a − CM = {gap:+.4f}", f"within ±{CYLINDER_C:g}",
            abs(gap) <= CYLINDER_C)
    rows = data["sphere"]
    s.tables.append(("sphere (3D, half ball): the sideways increments after the frictionless pressing",
                     ["increment", "P", "Q/(μP)", "a", "a Hertz", "c/a", "CM (1 − Q/μP)^⅓", PASSES],
                     [[r["increment"], f"{r['P']:.4f}", f"{r['Q/muP']:.3f}", f"{r['a']:.5f}", f"{r['a_hertz']:.5f}",
                       f"{r['c/a']:.3f}", f"{r['c/a_mindlin']:.3f}", cost(r["friction_passes"], r.get("friction_newton"))] for r in rows]))
    worst_a = max(abs(r["a_error"]) for r in rows)
    s.check("sphere: contact radius against Hertz", f"max |a/a_H − 1| = {100 * worst_a:.2f} %",
            f"<= {100 * SPHERE_A:g} %", worst_a <= SPHERE_A)
    errors = [r["c/a_error"] for r in rows]
    low, high = SPHERE_C
    s.check("sphere: stick radius against Mindlin", f"(c/a)/CM − 1 = {min(errors):+.3f} … {max(errors):+.3f}",
            f"in [{low:g}, {high:g}]", all(low <= e <= high for e in errors))
    return s


BUILDERS = {"friction_exact": friction_exact, "friction_manufactured": friction_manufactured, "cattaneo": cattaneo}
