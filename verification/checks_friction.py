"""The expectations of the friction studies (issue 32), evaluated on worker_friction.py's measurements."""
from checks import Section
from common import fitted_slope, spread
from manufactured_friction import EXACT_FORCE

TITLES = {
    "friction_exact": "14. Friction: exact sheared layers (stick and slip, 2D and 3D) and μ = 0",
    "friction_manufactured": "15. Friction: manufactured solutions with stick and slip zones",
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


def friction_exact(data):
    s = Section("friction_exact", TITLES["friction_exact"])
    rows = []
    for layer in data["layers"]:
        force = layer["friction_force"][0] / layer["exact_friction_force"] - 1
        rows.append([f"{layer['dim']}D", layer["mode"], f"{layer['m_n']:g}", f"{layer['nodal_error']:.2e}",
                     f"{force:+.2e}", f"{layer['eta']:.2e}", f"{layer[layer['mode']]:.4f}", layer["friction_passes"],
                     f"{layer['force_balance']:.1e}"])
        name = f"{layer['dim']}D {layer['mode']}, m_n = {layer['m_n']:g}"
        tolerance = NODAL_RTOL[layer["mode"]]
        s.check(f"{name}: nodal error / d", f"{layer['nodal_error']:.2e}", f"< {tolerance:g}",
                layer["nodal_error"] < tolerance)
        s.check(f"{name}: η / |friction force|", f"{layer['eta'] / abs(layer['exact_friction_force']):.1e}",
                f"< {ETA_EXACT:g}", layer["eta"] < ETA_EXACT * abs(layer["exact_friction_force"]))
    s.tables.append((f"exact linear states of the regularised law (ε_r = {data['eps_r']:g}); nodal error relative to "
                     "the penetration d",
                     ["dim", "mode", "m_n", "nodal error", "force − exact", "η", "stick/slip measure", "passes",
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
                      f"{r[measure]:.4f}", r["friction_passes"]])
    return table


def friction_manufactured(data):
    s = Section("friction_manufactured", TITLES["friction_manufactured"])
    headers = ["level", "dofs", "‖u − u_h‖_1", "η", "η/‖e‖_1", "η_3²/η²", "|F_t/F_t,exact − 1|", "stick", "passes"]
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
    return s


BUILDERS = {"friction_exact": friction_exact, "friction_manufactured": friction_manufactured}
