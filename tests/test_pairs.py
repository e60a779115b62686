"""Contact between two deformable bodies ([[pairs]], issue 47): the patch test, the symmetry identity, Hertz
between two cylinders, rank independence, and the refusals of bad pairs.

- Patch test: two stacked blocks, non-matching at their interface, pressed by a prescribed displacement
  (uniaxial stress): the exact solution is linear in each block, with the uniform interface pressure
  p = d / ((1 − ν²)/E + 1/c_n) (2D, plane strain; 3D: 1/E). The discrete pair must transmit it: to
  round-off (the facets are cut where the other face's vertices or triangles project:
  :mod:`nc_dolfinx.pairs.segments`; 5e-10 in 3D), and not without the cut; and the estimator, which vanishes on the exact solution, is
  at round-off.
- Symmetry identity: a body and its mirror image pressed together equal the body on a foundation at the
  mirror plane with c_n' = 2^m c_n and g_0' = g_0/2 (flat faces: the pair's jump is twice the body's normal
  displacement); reactions and energies to 1e-8.
"""
import json
import math

import numpy as np
import pytest
from mpi4py import MPI

import nc_dolfinx as nc
from conftest import import_script, run_cli

two_bodies = import_script("meshes", "two_bodies")
E, NU, D, C_N = 100.0, 0.3, 0.01, 1.0e3


def stacked_problem(mesh, dim, passes="two", extra=()):
    held = {2: ["lower_left", "upper_left"], 3: ["lower_x0", "upper_x0", "lower_y0", "upper_y0"]}[dim]
    free = "free, " * (dim - 1)
    raw = {"title": "stacked blocks",
           "mesh": {"file": str(mesh), "dirichlet": ["bottom", "top"], "symmetry": held},
           "parameters": {"d": D},
           "loads": {"u_D": {"bottom": [*["free"] * (dim - 1), "0"], "top": [*["free"] * (dim - 1), "-d"]}},
           "material": {"E": E, "nu": NU},
           "pairs": [{"faces": ["upper_face", "lower_face"], "c_n": C_N, "passes": passes, **dict(extra)}],
           "adapt": {"refine": "none"}}
    return nc.Problem.from_dict(raw, "stacked")


def exact_pressure(dim):
    compliance = (1 - NU ** 2) / E if dim == 2 else 1 / E
    return D / (compliance + 1 / C_N)


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    folder = tmp_path_factory.mktemp("blocks")
    two_bodies.stacked_blocks_2d(str(folder / "b2.msh"))
    two_bodies.stacked_blocks_3d(str(folder / "b3.msh"))
    return folder


def interface_pressure_error(problem):
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    solution = nc.solve(problem, domain)
    coupling = solution.fields.pair_coupling(solution.u)
    p = coupling.pressure()[coupling.w > 0]
    exact = exact_pressure(domain.mesh.geometry.dim)
    est = nc.estimate(solution.u, solution.fields)
    return float(np.abs(p - exact).max() / exact), est.totals["eta"], solution


@pytest.mark.parametrize("passes", ["two", "one"])
def test_patch_test_2d_transmits_the_uniform_pressure(blocks, passes):
    error, eta, solution = interface_pressure_error(stacked_problem(blocks / "b2.msh", 2, passes))
    assert error < 1e-12
    assert eta < 1e-10  # the estimator of the exact solution
    q = nc.solution_quantities(solution.u, solution.fields)
    assert q["pair1_force"][1] == pytest.approx(exact_pressure(2), rel=1e-12)  # the lower body pushes up
    assert q["force_balance"] < 1e-12


@pytest.mark.parametrize("passes", ["two", "one"])
def test_patch_test_3d_transmits_the_uniform_pressure(blocks, passes):
    error, eta, _ = interface_pressure_error(stacked_problem(blocks / "b3.msh", 3, passes))
    assert error < 1e-8  # (5e-10: the pieces' tiling is accepted to 1e-9 of a face's area)
    assert eta < 1e-7


def test_the_patch_test_fails_without_the_cut(blocks):
    """The same on whole facets (a Gauss rule across the kinks of v(Πx)) and at the nodes (node-to-segment):
    the uniform pressure is not transmitted — why the facets are cut."""
    errors = {kind: interface_pressure_error(stacked_problem(blocks / "b2.msh", 2, "one",
                                                             {"integration": kind}))[0]
              for kind in ("gauss", "nodes")}
    assert errors["gauss"] > 1e-4 and errors["nodes"] > 1e-2


def test_the_interface_nodes_do_not_match(blocks):
    """The patch test above is the non-matching one: no interior node of one face is on the other's."""
    problem = stacked_problem(blocks / "b2.msh", 2)
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    fields = nc.bind(problem, domain)
    coupling = fields.pair_coupling(nc.solve(problem, domain).u)
    for rows, _ in coupling.by_rows():
        other = rows.projection.bary
        assert np.sum(np.isclose(other, 1.0).any(axis=1)) < 0.1 * len(other)


def mirror_pair(tmp_path, m_n):
    """A square's mesh and its mirror image below it, at distance gap (a pair), and the square alone."""
    import gmsh
    single = tmp_path / "square.msh"
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("square")
        gmsh.model.occ.addRectangle(0, 0, 0, 1, 1)
        gmsh.model.occ.synchronize()
        names = {}
        for _, curve in gmsh.model.getEntities(1):
            x, y, _ = gmsh.model.occ.getCenterOfMass(1, curve)
            names[curve] = "bottom" if y < 1e-9 else "top" if y > 1 - 1e-9 else "left" if x < 1e-9 else "right"
        for tag, (curve, name) in enumerate(names.items(), 1):
            gmsh.model.addPhysicalGroup(1, [curve], tag)
            gmsh.model.setPhysicalName(1, tag, name)
        gmsh.model.addPhysicalGroup(2, [1], 1)
        gmsh.model.setPhysicalName(2, 1, "body")
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", 0.15)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(single))
    finally:
        gmsh.finalize()
    pair = tmp_path / "pair.msh"
    two_bodies.mirrored(str(single), str(pair), axis_value=-0.005)
    return single, pair


def test_mirror_images_equal_one_body_on_a_foundation(tmp_path):
    m_n, gap = 1.5, 0.01  # the faces 0.01 apart: each body 0.005 from the mirror plane
    single, pair = mirror_pair(tmp_path, m_n)
    press = {"parameters": {"d": 0.02}, "material": {"E": E, "nu": NU}, "adapt": {"refine": "none"}}
    one = nc.Problem.from_dict({**press, "title": "one", "mesh": {
        "file": str(single), "dirichlet": ["top"], "contact": ["bottom"], "neumann": ["left", "right"]},
        "loads": {"u_D": {"top": ["0.2*d*x", "-d*(x - 0.3)"]}},
        "contact": {"c_n": 2 ** m_n * C_N, "m_n": m_n, "gap": gap / 2}}, "one")
    two = nc.Problem.from_dict({**press, "title": "two", "mesh": {
        "file": str(pair), "dirichlet": ["upper_top", "lower_top"],
        "neumann": ["upper_left", "upper_right", "lower_left", "lower_right"]},
        "loads": {"u_D": {"upper_top": ["0.2*d*x", "-d*(x - 0.3)"], "lower_top": ["0.2*d*x", "d*(x - 0.3)"]}},
        "pairs": [{"faces": ["upper_bottom", "lower_bottom"], "c_n": C_N, "m_n": m_n}]}, "two")
    rows = [nc.adapt(p).history[0] for p in (one, two)]
    assert rows[1]["reaction_upper_top"] == pytest.approx(rows[0]["reaction_top"], rel=1e-8, abs=1e-12)
    assert rows[1]["elastic_energy"] == pytest.approx(2 * rows[0]["elastic_energy"], rel=1e-8)
    assert rows[1]["pair1_force"][1] == pytest.approx(rows[0]["contact_force"][1], rel=1e-8)  # both push up
    assert rows[0]["contact_length"] < 1.0  # part of the face only: the identity holds across the law's kink


def hertz_two_cylinders(force, E_=1.0e3, nu=0.3, R=0.5):
    e_star = E_ / (2 * (1 - nu ** 2))
    a = 2 * math.sqrt(force * R / (math.pi * e_star))
    return a, 2 * force / (math.pi * a)


@pytest.mark.long
def test_two_cylinders_against_hertz_and_independent_of_ranks(tmp_path):
    rows = {}
    for n in (1, 2, 3):
        out = tmp_path / f"np{n}"
        result = run_cli(["two_cylinders", "--levels", "4", "--out", out], nprocs=n)
        assert result.returncode == 0, result.stderr
        rows[n] = json.loads((out / "history.json").read_text())
    last = rows[1][-1]
    force = abs(last["pair1_force"][1])
    a, p0 = hertz_two_cylinders(force)
    assert last["pair1_contact_length"] / 2 == pytest.approx(a, rel=0.03)
    assert last["pair1_max_pressure"] == pytest.approx(p0, rel=0.03)
    assert rows[1][-1]["eta"] < 0.5 * rows[1][0]["eta"]
    for n in (2, 3):
        assert [r["dofs"] for r in rows[n]] == [r["dofs"] for r in rows[1]]
        for r, r1 in zip(rows[n], rows[1]):
            for key in ("eta", "pair1_max_pressure", "elastic_energy"):
                assert r[key] == pytest.approx(r1[key], rel=1e-8), (n, key)
            assert r["pair1_force"] == pytest.approx(r1["pair1_force"], rel=1e-8)


# --- bad pairs: one clear line, on every rank together ---------------------------------------------------

BAD_PAIRS = [  # (what is changed in the stacked blocks' problem, the words of the error)
    ({"pairs": [{"faces": ["upper_face", "nope"], "c_n": 1.0}]}, "pairs[1].faces group 'nope' is not in the mesh"),
    ({"pairs": [{"faces": ["upper_face", "top"], "c_n": 1.0}]}, "'top' is in both mesh.dirichlet and pairs[1].faces"),
    ({"pairs": [{"faces": ["upper_face", "upper_right"], "c_n": 1.0}]}, "are both on body 'upper'"),
    ({"pairs": [{"faces": ["upper_right", "lower_right"], "c_n": 1.0}]}, "never face each other"),
    ({"pairs": [{"faces": ["upper_face", "lower_face"], "c_n": 1.0, "offset": -0.5}]},
     "overlap beyond the law's range"),
    ({"mesh.dirichlet": ["bottom"]}, "body 'upper' is held by nothing but its contacts"),
    ({"pairs": [{"faces": ["upper_face", "lower_face"], "c_n": -1.0}]}, "pairs[1].c_n must be >= 0"),
    ({"pairs": [{"faces": ["upper_face"], "c_n": 1.0}]}, "pairs[1].faces must name two different boundary groups"),
    ({"pairs": [{"faces": ["upper_face", "lower_face"], "c_n": 1.0, "mu": 0.3}]}, "unknown key 'pairs[1].mu'"),
]


def write_stacked(folder, mesh, change):
    lines = ['title = "bad pair"', "[parameters]", "d = 0.01", "[mesh]", f'file = "{mesh}"',
             f'dirichlet = {change.get("mesh.dirichlet", ["bottom", "top"])!r}'.replace("'", '"'),
             'symmetry = ["lower_left", "upper_left"]', 'neumann = ["top"]' if "mesh.dirichlet" in change else "",
             "[loads.u_D]", 'bottom = ["free", "0"]',
             'top = ["free", "-d"]' if "mesh.dirichlet" not in change else '[loads.g]\ntop = ["0", "-1"]',
             "[material]", "E = 100.0", "nu = 0.3",
             "[adapt]", 'refine = "none"']
    for pair in change.get("pairs", [{"faces": ["upper_face", "lower_face"], "c_n": 1.0}]):
        lines.append("[[pairs]]")
        lines += [f"{key} = {value!r}".replace("'", '"') for key, value in pair.items()]
    path = folder / "bad.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("change, words", BAD_PAIRS, ids=[w[:24] for _, w in BAD_PAIRS])
def test_a_bad_pair_is_one_clear_line(blocks, tmp_path, change, words):
    from test_bad_input import assert_bad_input, cli
    problem = write_stacked(tmp_path, blocks / "b2.msh", change)
    out = tmp_path / "out"
    result = cli([problem, "--out", out, "--quiet"], nprocs=2)
    assert_bad_input(result, words, out, nprocs=2)


def test_points_beyond_the_search_distance_are_reported(tmp_path):
    """The two cylinders' arcs part as x²/R: with search_distance 0.01 the points beyond |x| ≈ 0.1 take no part,
    and the run says how many; the contact zone (|x| < 0.06) is the same."""
    rows = {}
    for name, distance in (("all", ""), ("near", ", search_distance = 0.01")):
        pair = f'pairs=[{{faces = ["upper_contact", "lower_contact"], c_n = "1.0e3*E"{distance}}}]'
        out = tmp_path / name
        result = run_cli(["two_cylinders", "--refine", "none", "--out", out, "--set", pair], nprocs=2)
        assert result.returncode == 0, result.stderr
        rows[name] = (result.stdout + result.stderr, json.loads((out / "history.json").read_text())[0])
    assert "have no facet of" not in rows["all"][0]
    assert "points of 'upper_contact' have no facet of 'lower_contact' within search_distance 0.01" in rows["near"][0]
    assert rows["near"][1]["pair1_force"] == pytest.approx(rows["all"][1]["pair1_force"], rel=1e-12)


def block_file(path, prefix, y0, h):
    """One block [0, 1] x [y0, y0 + 0.5] meshed alone (size h), groups PREFIX_face (the side at y = 0.5),
    PREFIX_left, PREFIX_end (its other horizontal side), PREFIX_right, cells PREFIX."""
    import gmsh
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(prefix)
        gmsh.model.occ.addRectangle(0, y0, 0, 1, 0.5)
        gmsh.model.occ.synchronize()
        for tag, (_, curve) in enumerate(gmsh.model.getEntities(1), 1):
            x, y, _ = gmsh.model.occ.getCenterOfMass(1, curve)
            side = "face" if abs(y - 0.5) < 1e-9 else "left" if x < 1e-9 else "right" if x > 1 - 1e-9 else "end"
            gmsh.model.addPhysicalGroup(1, [curve], tag)
            gmsh.model.setPhysicalName(1, tag, f"{prefix}_{side}")
        gmsh.model.addPhysicalGroup(2, [1], 1)
        gmsh.model.setPhysicalName(2, 1, prefix)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", h)
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def test_bodies_meshed_apart_in_two_files(tmp_path):
    """mesh.file as a list: each body its own file (and its own mesh size), read into one mesh; the patch
    test holds across them as in one file."""
    block_file(tmp_path / "lower.msh", "lower", 0.0, 1 / 5)
    block_file(tmp_path / "upper.msh", "upper", 0.5, 1 / 7)
    problem = tmp_path / "apart.toml"
    problem.write_text(write_stacked(tmp_path, "x.msh", {}).read_text()
                       .replace('file = "x.msh"', 'file = ["lower.msh", "upper.msh"]')
                       .replace('dirichlet = ["bottom", "top"]', 'dirichlet = ["lower_end", "upper_end"]')
                       .replace('bottom = ["free", "0"]', 'lower_end = ["free", "0"]')
                       .replace('top = ["free", "-d"]', 'upper_end = ["free", "-d"]')
                       .replace("c_n = 1.0", f"c_n = {C_N}"))
    result = run_cli([problem, "--out", tmp_path / "out"], nprocs=2)
    assert result.returncode == 0, result.stderr
    row = json.loads((tmp_path / "out" / "history.json").read_text())[0]
    assert row["pair1_force"][1] == pytest.approx(exact_pressure(2), rel=1e-12)
    assert row["pair1_max_pressure"] == pytest.approx(exact_pressure(2), rel=1e-12)
    clash = tmp_path / "clash.toml"
    block_file(tmp_path / "again.msh", "lower", 0.5, 1 / 7)
    clash.write_text(problem.read_text().replace('"upper.msh"', '"again.msh"'))
    from test_bad_input import assert_bad_input, cli
    out = tmp_path / "clash"
    assert_bad_input(cli([clash, "--out", out, "--quiet"], nprocs=2), "both have a group named 'lower", out, 2)
