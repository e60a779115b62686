#!/usr/bin/env python3
"""Two deformable bodies ([[pairs]], issue 47): the contact patch test, the symmetry identity, two-body Hertz.

A client of the public API (``nc.Problem``, ``nc.build_domain``, ``nc.solve``, ``nc.adapt``,
``nc.solution_quantities``); prints markdown tables (docs/src/guide/two_bodies.md holds a run of them)::

    /usr/bin/python3 verification/two_bodies.py [--quick] [--parts patch symmetry hertz2d hertz3d eta]

(a) ``patch``: the stacked blocks of meshes/two_bodies.py (non-matching at y = 1/2, z = 1/2 in 3D) pressed by
    a prescribed displacement d: the exact interface pressure is uniform, p = d / (c + 1/c_n) with c the
    compliance (1 − ν²)/E (2D plane strain) or 1/E (3D). The maximum relative error of the pressure at the
    integration points, with the pair's ``integration`` key: ``cut`` (the shipped default: 2D edges cut where
    the other face's vertices project, 3D triangles clipped by the other face's), ``gauss`` (the rule on whole
    facets: no cut), ``nodes`` (node-to-segment: the facets' vertices, lumped weights), two half-passes and
    one pass.
(b) ``symmetry``: a square and its mirror image pressed together (``meshes/two_bodies.py mirrored``) against the
    square alone on a foundation at the mirror plane with c_n' = 2^m c_n, g_0' = g_0/2 (m_n = 1.5): equal to
    round-off on mirrored meshes. On a non-matching pair (the stacked blocks, h 1/6 below and 1/9 above, the
    pair's offset the gap) against the upper block alone on the foundation (the lower block clamped and
    unloaded beside it, so the upper block's mesh is the same): equal up to the discretisation error, which
    goes to zero under uniform refinement.
(c) ``hertz2d``: the built-in case two_cylinders, adaptive levels: a = pair1_contact_length/2 and
    pair1_max_pressure against a = 2 sqrt(F R/(π E*)), p0 = 2F/(π a), R = 1/2, E* = E/(2(1 − ν²)).
(d) ``hertz3d``: the built-in case sphere_on_block (a quarter model; a finite block of size R, not a
    half-space): F = 4 |pair1_force_z|, a = sqrt(4 A/π), against a = (3FR/(4E*))^(1/3), p0 = 3F/(2πa²).
(e) ``eta``: η against dofs on two_cylinders, adaptive and uniform refinement, and the fitted slopes.
"""
import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import nc_dolfinx as nc  # noqa: E402
from mpi4py import MPI  # noqa: E402



def _meshes():
    """meshes/two_bodies.py, loaded by its path (this script has the same file name)."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("meshes_two_bodies", ROOT / "meshes" / "two_bodies.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


meshes = _meshes()

E, NU, D, C_N = 100.0, 0.3, 0.01, 1.0e3
COMM = MPI.COMM_WORLD


def say(*args):
    if COMM.rank == 0:
        print(*args, flush=True)


def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def fmt(x, spec=".2e"):
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def slope(x, y):
    x, y = np.log(np.asarray(x, float)), np.log(np.asarray(y, float))
    return float(np.polyfit(x, y, 1)[0]) if len(x) > 1 else float("nan")


# --- (a) the contact patch test -----------------------------------------------------------------------

def stacked_problem(mesh, dim, passes="two", integration="cut"):
    held = {2: ["lower_left", "upper_left"], 3: ["lower_x0", "upper_x0", "lower_y0", "upper_y0"]}[dim]
    raw = {"title": "stacked blocks", "mesh": {"file": str(mesh), "dirichlet": ["bottom", "top"], "symmetry": held},
           "parameters": {"d": D},
           "loads": {"u_D": {"bottom": [*["free"] * (dim - 1), "0"], "top": [*["free"] * (dim - 1), "-d"]}},
           "material": {"E": E, "nu": NU},
           "pairs": [{"faces": ["upper_face", "lower_face"], "c_n": C_N, "passes": passes,
                      "integration": integration}],
           "adapt": {"refine": "none"}}
    return nc.Problem.from_dict(raw, "stacked")


def exact_pressure(dim):
    return D / (((1 - NU ** 2) / E if dim == 2 else 1 / E) + 1 / C_N)


def patch_error(mesh, dim, passes="two", integration="cut"):
    """(max relative pressure error at the points taking part, number of points, |pair force| rel. error)."""
    problem = stacked_problem(mesh, dim, passes, integration)
    domain = nc.build_domain(problem, COMM)
    solution = nc.solve(problem, domain)
    coupling = solution.fields.pair_coupling(solution.u)
    p = coupling.pressure()[coupling.w > 0]
    exact = exact_pressure(dim)
    local = float(np.abs(p - exact).max(initial=0.0))
    error = COMM.allreduce(local, op=MPI.MAX) / exact
    points = COMM.allreduce(len(p), op=MPI.SUM)
    q = nc.solution_quantities(solution.u, solution.fields)
    force = abs(abs(q["pair1_force"][dim - 1]) - exact) / exact  # the face's measure is 1
    return error, points, force


VARIANTS_2D = [  # (label, passes, integration, None)
    ("cut where the other face's vertices project (shipped default)", "two", "cut", None),
    ("cut", "one", "cut", None),
    ("whole edges (integration = \"gauss\")", "two", "gauss", None),
    ("whole edges", "one", "gauss", None),
    ("node-to-segment (integration = \"nodes\": vertices, lumped weights)", "one", "nodes", None),
    ("node-to-segment", "two", "nodes", None),
]
VARIANTS_3D = [
    ("cut by the other face's triangles, clipped (shipped default)", "two", "cut", None),
    ("cut, clipped", "one", "cut", None),
    ("whole facets (integration = \"gauss\")", "two", "gauss", None),
    ("node-to-segment (integration = \"nodes\")", "one", "nodes", None),
]


def part_patch(tmp, quick):
    m2, m3 = tmp / "b2.msh", tmp / "b3.msh"
    if COMM.rank == 0:
        meshes.stacked_blocks_2d(str(m2))
        meshes.stacked_blocks_3d(str(m3))
    COMM.barrier()
    out = {}
    for dim, mesh, variants in ((2, m2, VARIANTS_2D), (3, m3, VARIANTS_3D)):
        if quick:
            variants = [v for v in variants if "shipped" in v[0] or "gauss" in v[0] and v[1] == "two"]
        rows = []
        for label, passes, integration, levels in variants:
            t = time.perf_counter()
            error, points, force = patch_error(mesh, dim, passes, integration)
            rows.append([label, passes, points, fmt(error), fmt(force), f"{time.perf_counter() - t:.1f}"])
            out[(dim, label, passes)] = error
        say(f"\n**(a) Patch test, {dim}D** (stacked blocks, h 1/6 below, 1/9 above, jittered; exact p = "
            f"{exact_pressure(dim):.6g})\n")
        say(table(["integration", "passes", "points", "max rel. error of p", "rel. error of the pair force", "s"],
                  rows))
    return out


# --- (b) the symmetry identity ---------------------------------------------------------------------

def square_mesh(path, h):
    """The unit square (groups bottom, top, left, right; cells "body"), triangles of size h."""
    import gmsh
    import gmsh_common as common  # meshes/gmsh_common.py (meshes/two_bodies.py put its folder on sys.path)
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        square = gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        side = {}
        for _, curve in gmsh.model.getEntities(1):
            x, y, _ = gmsh.model.occ.getCenterOfMass(1, curve)
            side[{(0.5, 0.0): "bottom", (0.5, 1.0): "top", (0.0, 0.5): "left"}.get((round(x, 6), round(y, 6)),
                                                                                  "right")] = [curve]
        common.name_groups(side, square)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", h)
        common.generate_and_write(path)
    finally:
        gmsh.finalize()


M_N, GAP = 1.5, 0.01
PRESS = {"parameters": {"d": 0.02}, "material": {"E": E, "nu": NU}}
UPPER_LOAD, LOWER_LOAD = ["0.2*d*x", "-d*(x - 0.3)"], ["0.2*d*x", "d*(x - 0.3)"]


def rel(a, b):
    return abs(a - b) / max(abs(b), 1e-300)


def symmetry_mirrored(tmp, h):
    single, pair = tmp / f"square_{h}.msh", tmp / f"pair_{h}.msh"
    if COMM.rank == 0:
        square_mesh(single, h)
        meshes.mirrored(str(single), str(pair), axis_value=-GAP / 2)
    COMM.barrier()
    adapt = {"adapt": {"refine": "none"}}
    one = nc.Problem.from_dict({**PRESS, **adapt, "title": "one", "mesh": {
        "file": str(single), "dirichlet": ["top"], "contact": ["bottom"], "neumann": ["left", "right"]},
        "loads": {"u_D": {"top": UPPER_LOAD}}, "contact": {"c_n": 2 ** M_N * C_N, "m_n": M_N, "gap": GAP / 2}}, "one")
    two = nc.Problem.from_dict({**PRESS, **adapt, "title": "two", "mesh": {
        "file": str(pair), "dirichlet": ["upper_top", "lower_top"],
        "neumann": ["upper_left", "upper_right", "lower_left", "lower_right"]},
        "loads": {"u_D": {"upper_top": UPPER_LOAD, "lower_top": LOWER_LOAD}},
        "pairs": [{"faces": ["upper_bottom", "lower_bottom"], "c_n": C_N, "m_n": M_N}]}, "two")
    r1, r2 = (nc.adapt(p, comm=COMM).history[0] for p in (one, two))
    return {"dofs": r2["dofs"], "reaction": rel(r2["reaction_upper_top"][1], r1["reaction_top"][1]),
            "energy": rel(r2["elastic_energy"], 2 * r1["elastic_energy"]),
            "force": rel(r2["pair1_force"][1], r1["contact_force"][1]),
            "contact": r1["contact_length"]}


def symmetry_nonmatching(tmp, levels):
    """The stacked blocks (1/6 below, 1/9 above, jittered) as a pair with offset GAP, against the upper block
    alone on the foundation at GAP/2 (the lower block clamped beside it, unloaded: the same upper mesh)."""
    mesh = tmp / "b2_sym.msh"
    if COMM.rank == 0:
        meshes.stacked_blocks_2d(str(mesh))
    COMM.barrier()
    sides = ["upper_left", "upper_right", "lower_left", "lower_right"]
    loads_one = {"top": ["0.2*d*x", "-d*(x - 0.3)"], "bottom": ["0", "0"]}
    loads_two = {"top": ["0.2*d*x", "-d*(x - 0.3)"], "bottom": ["0.2*d*x", "d*(x - 0.3)"]}
    refine = {"adapt": {"refine": "uniform", "levels": levels}}
    one = nc.Problem.from_dict({**PRESS, **refine, "title": "one", "mesh": {
        "file": str(mesh), "dirichlet": ["top", "bottom"], "contact": ["upper_face"],
        "neumann": sides + ["lower_face"]},
        "loads": {"u_D": loads_one}, "contact": {"c_n": 2 ** M_N * C_N, "m_n": M_N, "gap": GAP / 2}}, "one")
    two = nc.Problem.from_dict({**PRESS, **refine, "title": "two", "mesh": {
        "file": str(mesh), "dirichlet": ["top", "bottom"], "neumann": sides},
        "loads": {"u_D": loads_two},
        "pairs": [{"faces": ["upper_face", "lower_face"], "c_n": C_N, "m_n": M_N, "offset": GAP}]}, "two")
    h1, h2 = (nc.adapt(p, comm=COMM).history for p in (one, two))
    rows = []
    for level, (r1, r2) in enumerate(zip(h1, h2)):
        rows.append({"level": level, "dofs": r2["dofs"],
                     "reaction": rel(r2["reaction_top"][1], r1["reaction_top"][1]),
                     "force": rel(r2["pair1_force"][1], r1["contact_force"][1]),
                     "contact": r1["contact_length"], "contact_pair": r2["pair1_contact_length"]})
    return rows


def part_symmetry(tmp, quick):
    rows = [symmetry_mirrored(tmp, h) for h in ((0.15,) if quick else (0.15, 0.075))]
    say("\n**(b) Symmetry identity, mirrored meshes** (a square and its mirror image, m_n = 1.5, gap 0.01, "
        "against the square on a foundation with c_n' = 2^1.5 c_n, g_0' = g_0/2)\n")
    say(table(["dofs (pair)", "reaction rel. diff.", "2 x energy rel. diff.", "force rel. diff.",
               "contact length (one body)"],
              [[r["dofs"], fmt(r["reaction"]), fmt(r["energy"]), fmt(r["force"]), f"{r['contact']:.4f}"]
               for r in rows]))
    nm = symmetry_nonmatching(tmp, 2 if quick else 5)
    say("\n**(b) Symmetry identity, non-matching pair** (stacked blocks, h 1/6 below, 1/9 above, jittered; the "
        "upper block alone on the foundation on the same upper mesh; uniform refinement)\n")
    say(table(["level", "dofs (pair)", "reaction rel. diff.", "force rel. diff.", "contact length (one / pair)"],
              [[r["level"], r["dofs"], fmt(r["reaction"]), fmt(r["force"]),
                f"{r['contact']:.4f} / {r['contact_pair']:.4f}"] for r in nm]))
    if len(nm) > 1:
        say(f"\nfitted slope of the reaction's difference against dofs: "
            f"{slope([r['dofs'] for r in nm], [r['reaction'] for r in nm]):.2f}")
    return rows, nm


# --- (c), (d), (e) Hertz -----------------------------------------------------------------------------

def hertz_2d(row, e_modulus=1.0e3, nu=0.3, radius=0.5):
    force = abs(row["pair1_force"][1])
    e_star = e_modulus / (2 * (1 - nu ** 2))
    a = 2 * math.sqrt(force * radius / (math.pi * e_star))
    return force, a, 2 * force / (math.pi * a)


def hertz_3d(row, e_modulus=1.0e3, nu=0.3, radius=1.0):
    force = 4 * abs(row["pair1_force"][2])
    e_star = e_modulus / (2 * (1 - nu ** 2))
    a = (3 * force * radius / (4 * e_star)) ** (1 / 3)
    return force, a, 3 * force / (2 * math.pi * a ** 2)


def run_case(name, levels, refine="adaptive", overrides=()):
    problem = nc.load_problem(name, list(overrides))
    t = time.perf_counter()
    history = nc.adapt(problem, comm=COMM, levels=levels, refine=refine).history
    return history, time.perf_counter() - t


def part_hertz2d(quick):
    history, seconds = run_case("two_cylinders", 2 if quick else 6)
    rows = []
    for r in history:
        force, a, p0 = hertz_2d(r)
        half = r["pair1_contact_length"] / 2
        rows.append({"level": r["level"], "dofs": r["dofs"], "F": force, "a": half, "a_H": a,
                     "p": r["pair1_max_pressure"],
                     "p_H": p0, "err_a": rel(half, a), "err_p": rel(r["pair1_max_pressure"], p0), "eta": r["eta"],
                     "pen": r["pair1_max_penetration"]})
    say(f"\n**(c) Two cylinders against Hertz** (case two_cylinders, adaptive, {seconds:.0f} s)\n")
    say(table(["level", "dofs", "F", "a", "a Hertz", "rel. err. a", "p_max", "p0 Hertz", "rel. err. p",
               "max penetration", "η"],
              [[r["level"], r["dofs"], f"{r['F']:.4f}", f"{r['a']:.4f}", f"{r['a_H']:.4f}", fmt(r["err_a"]),
                f"{r['p']:.3f}", f"{r['p_H']:.3f}", fmt(r["err_p"]), fmt(r["pen"]), fmt(r["eta"])] for r in rows]))
    if not quick:  # what limits the agreement: the penalty (c_n = 1e3 E) and the finite bodies
        stiff = 'pairs=[{faces = ["upper_contact", "lower_contact"], c_n = "1.0e4*E"}]'
        last = run_case("two_cylinders", 6, overrides=[stiff])[0][-1]
        force, a, p0 = hertz_2d(last)
        half = last["pair1_contact_length"] / 2
        say(f"\nthe same, c_n = 1e4 E, last level ({last['dofs']} dofs): F {force:.4f}, a {half:.4f} "
            f"(Hertz {a:.4f}, rel. err. {fmt(rel(last['pair1_contact_length'] / 2, a))}), p_max "
            f"{last['pair1_max_pressure']:.3f} (Hertz {p0:.3f}, rel. err. {fmt(rel(last['pair1_max_pressure'], p0))}), "
            f"max penetration {fmt(last['pair1_max_penetration'])}")
    return rows


def part_hertz3d(quick):
    history, seconds = run_case("sphere_on_block", 2 if quick else 4)
    rows = []
    for r in history:
        force, a, p0 = hertz_3d(r)
        area = math.sqrt(4 * r["pair1_contact_area"] / math.pi)
        rows.append({"level": r["level"], "dofs": r["dofs"], "F": force, "a": area, "a_H": a,
                     "p": r["pair1_max_pressure"],
                     "p_H": p0, "err_a": rel(area, a), "err_p": rel(r["pair1_max_pressure"], p0), "eta": r["eta"]})
    say(f"\n**(d) Sphere on a block against Hertz** (case sphere_on_block, a quarter model, adaptive, "
        f"{seconds:.0f} s; the block is a finite body of size R, Hertz's a half-space)\n")
    say(table(["level", "dofs", "F (full ball)", "a = sqrt(4A/π)", "a Hertz", "rel. err. a", "p_max", "p0 Hertz",
               "rel. err. p", "η"],
              [[r["level"], r["dofs"], f"{r['F']:.4f}", f"{r['a']:.4f}", f"{r['a_H']:.4f}", fmt(r["err_a"]),
                f"{r['p']:.2f}", f"{r['p_H']:.2f}", fmt(r["err_p"]), fmt(r["eta"])] for r in rows]))
    return rows


def part_eta(quick, adaptive_rows=None):
    levels = 2 if quick else 4
    uniform, seconds = run_case("two_cylinders", levels, refine="uniform")
    adaptive = adaptive_rows or [{"dofs": r["dofs"], "eta": r["eta"]} for r in run_case("two_cylinders", levels)[0]]
    say(f"\n**(e) η against dofs, two_cylinders** (uniform: {seconds:.0f} s)\n")
    n = max(len(adaptive), len(uniform))
    rows = []
    for i in range(n):
        a = adaptive[i] if i < len(adaptive) else None
        u = uniform[i] if i < len(uniform) else None
        rows.append([i, a["dofs"] if a else "-", fmt(a["eta"]) if a else "-", u["dofs"] if u else "-",
                     fmt(u["eta"]) if u else "-"])
    say(table(["level", "dofs (adaptive)", "η (adaptive)", "dofs (uniform)", "η (uniform)"], rows))
    s_a = slope([r["dofs"] for r in adaptive], [r["eta"] for r in adaptive])
    s_u = slope([r["dofs"] for r in uniform], [r["eta"] for r in uniform])
    say(f"\nfitted slopes of log η against log dofs: adaptive {s_a:.2f}, uniform {s_u:.2f} "
        "(optimal for P1 in 2D: -0.5)")
    return {"adaptive": adaptive, "uniform": uniform, "slope_adaptive": s_a, "slope_uniform": s_u}


PARTS = ("patch", "symmetry", "hertz2d", "hertz3d", "eta")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="coarse and few levels: a check that it runs (a minute or two)")
    parser.add_argument("--parts", nargs="+", default=list(PARTS), choices=PARTS)
    args = parser.parse_args(argv)
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(COMM.bcast(folder if COMM.rank == 0 else None))
        say(f"verification/two_bodies.py ({'quick' if args.quick else 'full'}, {COMM.size} rank(s), "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())})")
        if "patch" in args.parts:
            results["patch"] = part_patch(tmp, args.quick)
        if "symmetry" in args.parts:
            results["symmetry"] = part_symmetry(tmp, args.quick)
        if "hertz2d" in args.parts:
            results["hertz2d"] = part_hertz2d(args.quick)
        if "hertz3d" in args.parts:
            results["hertz3d"] = part_hertz3d(args.quick)
        if "eta" in args.parts:
            adaptive = results.get("hertz2d")
            if adaptive is not None and not args.quick:
                adaptive = [{"dofs": r["dofs"], "eta": r["eta"]} for r in adaptive]
            else:
                adaptive = None
            results["eta"] = part_eta(args.quick, adaptive)
    return results


if __name__ == "__main__":
    main()
