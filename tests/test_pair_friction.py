"""Coulomb friction between two bodies ([[pairs]] friction, issue 47; nc_dolfinx.pairs.friction): the law's
consistent Jacobian against finite differences, its limits (μ = 0 is the frictionless pair; a block slid
past its limit carries exactly μ times its vertices' pressures, every vertex slipping), the shear's sign and
a stick zone below the limit, rank independence along a load path with refinement, and its refusals.

The problem: the stacked blocks of meshes/two_bodies.py (non-matching at their interface), pressed by d, then
the upper block's top moved sideways by dt while the lower block's left side is held in x.
"""
import json

import numpy as np
import pytest
from mpi4py import MPI

import nc_dolfinx as nc
from conftest import import_script, run_cli
from test_bad_input import assert_bad_input
from nc_dolfinx import dolfinx_versions as versions

two_bodies = import_script("meshes", "two_bodies")
MU = 0.3


@pytest.fixture(scope="module")
def blocks(tmp_path_factory):
    folder = tmp_path_factory.mktemp("friction_blocks")
    two_bodies.stacked_blocks_2d(str(folder / "b2.msh"))
    return folder / "b2.msh"


@pytest.fixture(scope="module")
def blocks3d(tmp_path_factory):
    folder = tmp_path_factory.mktemp("friction_blocks3d")
    two_bodies.stacked_blocks_3d(str(folder / "b3.msh"))
    return folder / "b3.msh"


def sheared_blocks(mesh, dt, mu=MU, m_n=1.0, steps=True, refine="none", friction=True, dim=2):
    pair = {"faces": ["upper_face", "lower_face"], "c_n": 1e3, "m_n": m_n}
    if friction:
        pair["friction"] = "mu"
    held = ["lower_left"] if dim == 2 else ["lower_x0", "lower_y0", "upper_y0"]  # (3D: sheared along x only)
    raw = {"title": "sheared blocks",
           "mesh": {"file": str(mesh), "dirichlet": ["bottom", "top"], "symmetry": held},
           "parameters": {"d": 0.0 if steps else 0.01, "dt": 0.0 if steps else dt, "mu": mu},
           "loads": {"u_D": {"bottom": [*["free"] * (dim - 1), "0"], "top": ["dt", *["free"] * (dim - 2), "-d"]}},
           "material": {"E": 100.0, "nu": 0.3},
           "pairs": [pair],
           "adapt": {"refine": refine, **({"levels": 2} if refine != "none" else {})}}
    if steps:
        raw["steps"] = [{"set": {"d": 0.01}}, {"set": {"dt": dt}, "increments": 2}]
    return raw


def last_row(raw):
    return nc.adapt(nc.Problem.from_dict(raw, "sheared")).history[-1]


@pytest.mark.parametrize("m_n", [1.0, 1.5])
def test_consistent_jacobian_is_the_residuals_derivative(blocks, m_n):
    """The consistent Jacobian (the fixed point's Newton finish) against central differences of the pairs'
    frictional residual with the bound of u itself, at a state with stick and slip and a memory."""
    problem = nc.Problem.from_dict(sheared_blocks(blocks, 0.003, m_n=m_n, steps=False), "fd")
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    u, law = solution.u, solution.fields.friction
    term = solution.fields.pair_coupling(u).friction
    law.previous.x.array[:] = 0.5 * u.x.array
    law.previous_traction.x.array.reshape(-1, 2)[term.local] = \
        3e-3 * np.random.default_rng(0).standard_normal((len(term.local), 2))
    state = term._state(u)
    assert state.stick.any() and (state.active & ~state.stick).any()

    def residual(x):
        u.x.array[:] = x
        law.frozen.x.array[:] = x
        vector = versions.petsc_vec(u).duplicate()
        vector.set(0.0)
        term.add_residual(vector)
        return vector.getArray().copy()

    keep = versions.petsc_vec(u).duplicate()
    keep.set(1.0)
    term.drop_dirichlet_columns(keep)
    x0 = u.x.array.copy()
    matrix = term.widen_pattern()
    matrix.zeroEntries()
    u.x.array[:] = law.frozen.x.array[:] = x0
    term.add_jacobian(matrix, "consistent")
    direction = 1e-3 * np.random.default_rng(1).standard_normal(len(x0))
    h = 1e-4
    difference = (residual(x0 + h * direction) - residual(x0 - h * direction)) / (2 * h)
    d_vec = versions.petsc_vec(u).duplicate()
    d_vec.setArray(direction)
    product = d_vec.duplicate()
    matrix.mult(d_vec, product)
    assert np.linalg.norm(product.getArray() - difference) < 1e-6 * np.linalg.norm(difference)


def test_mu_zero_is_the_frictionless_pair(blocks):
    with_zero = last_row(sheared_blocks(blocks, 0.01, mu=0.0))
    without = last_row(sheared_blocks(blocks, 0.01, friction=False))
    assert np.allclose(with_zero["pair1_force"], without["pair1_force"], rtol=0, atol=1e-9)
    assert np.abs(with_zero["pair1_friction_force"]).max() == 0.0
    assert with_zero["pair1_stick_length"] == 0.0


@pytest.mark.parametrize("dim", [2, 3])
def test_sliding_block_carries_mu_times_its_pressure(blocks, blocks3d, dim):
    """dt far past the limit: every vertex in contact slips, and the friction force is μ Σ w p at the
    vertices, along −x on the upper body (it is dragged along +x)."""
    mesh = blocks if dim == 2 else blocks3d
    problem = nc.Problem.from_dict(sheared_blocks(mesh, 0.05, steps=False, dim=dim), "slide")
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    q = nc.solution_quantities(solution.u, solution.fields)
    term = solution.fields.pair_coupling(solution.u).friction
    state = term._state(solution.u)
    assert MPI.COMM_WORLD.allreduce(bool(state.active.any()), op=MPI.LOR) and not state.stick.any()
    # (both faces' vertices drag the upper body back: σ_t = −F ŝ on each face's own body, ŝ opposite)
    pressure_sum = MPI.COMM_WORLD.allreduce(float(term.w @ (state.bound / MU)), op=MPI.SUM)
    if dim == 2:  # (every slip along ±x)
        assert q["pair1_friction_force"][0] == pytest.approx(-MU * pressure_sum, rel=1e-10)
    else:  # (the slip directions turn a little with the blocks' lateral strain: |Σ F ŝ| ≤ Σ F)
        assert 0.999 * MU * pressure_sum < np.linalg.norm(q["pair1_friction_force"]) <= MU * pressure_sum * (1 + 1e-12)
        assert q["pair1_friction_force"][0] < 0
    size = "length" if dim == 2 else "area"
    assert q[f"pair1_slip_{size}"] == pytest.approx(q[f"pair1_contact_{size}"], rel=1e-12)
    assert np.abs(q["pair1_friction_force"][1:dim - 1]).max(initial=0.0) < 0.05 * abs(q["pair1_friction_force"][0])
    # against the normal force of the cut rule: the vertices' lumped rule differs from it by O(h²)
    assert abs(q["pair1_friction_force"][0]) / q["pair1_resultant"] == pytest.approx(MU, rel=0.02)
    assert q["force_balance"] < 1e-8


def test_below_the_limit_part_sticks_and_the_force_grows_with_the_shear(blocks):
    small, large = (last_row(sheared_blocks(blocks, dt)) for dt in (0.002, 0.01))
    for row in (small, large):
        assert abs(row["pair1_friction_force"][0]) < MU * row["pair1_resultant"]
        assert row["pair1_stick_length"] > 0
        assert row["force_balance"] < 1e-8
    assert large["pair1_friction_force"][0] < small["pair1_friction_force"][0] < 0  # resisting the shear
    assert large["pair1_stick_length"] < small["pair1_stick_length"]


def test_friction_path_with_refinement_is_independent_of_ranks(blocks, tmp_path):
    """The load path (press, shear in two increments) with adaptive refinement after each step: the law's
    memory moves with the mesh; 1, 2 and 3 ranks give the same rows to 1e-8."""
    raw = sheared_blocks(blocks, 0.01, refine="adaptive")
    path = tmp_path / "sheared.toml"
    path.write_text(_toml(raw))
    rows = {}
    for n in (1, 2, 3):
        out = tmp_path / f"out{n}"
        result = run_cli([path, "--out", out], nprocs=n)
        assert result.returncode == 0, result.stderr[-2000:]
        rows[n] = json.loads((out / "history.json").read_text())
    names = ("pair1_friction_force", "pair1_force", "pair1_stick_length", "dofs")
    for n in (2, 3):
        assert len(rows[n]) == len(rows[1])
        for a, b in zip(rows[1], rows[n]):
            scale = np.abs(a["pair1_force"]).max()  # (the solver's tolerance is relative to the forces' size)
            for name in names:
                assert np.allclose(a[name], b[name], rtol=1e-8, atol=1e-8 * scale), (n, name, a[name], b[name])
    assert rows[1][-1]["pair1_friction_force"][0] < 0
    written = (tmp_path / "out2" / "solution.xdmf").read_text()
    assert "pair_traction" in written and "pair_stick_slip" in written
    assert "stick_slip\"" not in written.replace("pair_stick_slip\"", "")  # (Γ_C has no friction here)


def test_3d_friction_path_is_independent_of_ranks(blocks3d, tmp_path):
    """The 3D blocks pressed and sheared (no refinement): 1 and 2 ranks give the same rows to 1e-8."""
    path = tmp_path / "sheared3d.toml"
    path.write_text(_toml(sheared_blocks(blocks3d, 0.01, dim=3)))
    rows = {}
    for n in (1, 2):
        out = tmp_path / f"out{n}"
        result = run_cli([path, "--out", out], nprocs=n)
        assert result.returncode == 0, result.stderr[-2000:]
        rows[n] = json.loads((out / "history.json").read_text())
    assert len(rows[2]) == len(rows[1]) == 3
    for a, b in zip(rows[1], rows[2]):
        scale = np.abs(a["pair1_force"]).max()  # (the solver's tolerance is relative to the forces' size)
        for name in ("pair1_friction_force", "pair1_force"):
            assert np.allclose(a[name], b[name], rtol=1e-8, atol=1e-8 * scale), (name, a[name], b[name])
        for name in ("pair1_stick_area", "pair1_slip_area"):
            assert np.allclose(a[name], b[name], rtol=1e-8, atol=1e-12), (name, a[name], b[name])
    last = rows[1][-1]
    assert last["pair1_friction_force"][0] < 0 and last["pair1_stick_area"] > 0 and last["pair1_slip_area"] > 0


def test_negative_mu_is_refused_naming_the_key(blocks, tmp_path):
    raw = sheared_blocks(blocks, 0.01, mu=-0.1)
    path = tmp_path / "bad.toml"
    path.write_text(_toml(raw))
    out = tmp_path / "out"
    assert_bad_input(run_cli([path, "--out", out], nprocs=2), "pairs[1].friction must be >= 0", out, nprocs=2)


def _toml(raw):
    """A problem table as TOML (the few shapes used here)."""
    def value(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + " }"
        return repr(v)
    lines = [f"title = {value(raw['title'])}"]
    for section in ("parameters", "mesh", "material", "loads", "adapt"):
        lines.append(f"[{section}]")
        lines += [f"{k} = {value(v)}" for k, v in raw[section].items()]
    for section in ("pairs", "steps"):
        for entry in raw.get(section, []):
            lines.append(f"[[{section}]]")
            lines += [f"{k} = {value(v)}" for k, v in entry.items()]
    return "\n".join(lines) + "\n"
