"""A body that nothing but the foundation holds along some rigid motions (no Γ_D): the cold start settles
it rigidly onto the foundation (nc_dolfinx.solver.settling), then Newton solves (7).

A block resting on the foundation, cut by symmetry planes (which hold the tangential motions), pressed
by a uniform pressure p on its top: the stress is uniaxial, σ = −p e_z (3D) or −p e_y (2D, plane strain),
the strain uniform (Hooke's law inverted with sympy below), and the foundation's law gives the base's
penetration d = (p / c_n)^{1/m_n} beyond the gap g_0. The exact u is linear, so u_h equals it at the
nodes up to the solver's tolerance — for m_n = 1, 1.5 and 3 (whose law has no stiffness at all at a
cold start), with and without a gap, in 2D and 3D.

Without the symmetry planes, friction holds the motions that slide the block along the foundation
(tests/mpi/held_by_friction.py): refused without friction or with μ = 0, solved with μ > 0 on 1, 2 and 3
ranks, where the friction force balances the shear; under a symmetric load the block equals its half cut by
a symmetry plane.
"""
import json

import numpy as np
import pytest
import sympy as sp
from dolfinx import fem
from mpi4py import MPI

import nc_dolfinx as nc
from conftest import ROOT, run
from mpi.held_by_friction import MU, block, sorted_nodal_values
from nc_dolfinx.errors import InputError

SCRIPT = ROOT / "tests" / "mpi" / "held_by_friction.py"

E, NU, P, C_N = 1.0e3, 0.3, 10.0, 1.0e4


def uniaxial_strain(dim):
    """The uniform strain (ε_11, ε_22[, ε_33]) under σ = −P along the last axis, the others zero (plane
    strain in 2D: ε_zz = 0), from Hooke's law σ = λ tr ε I + 2μ ε solved with sympy."""
    lam, mu = E * NU / ((1 + NU) * (1 - 2 * NU)), E / (2 * (1 + NU))
    eps = sp.symbols(f"e0:{dim}")
    stress = [lam * sum(eps) + 2 * mu * e for e in eps]  # the normal stresses (ε_zz = 0 in plane strain)
    target = [0.0] * (dim - 1) + [-P]
    solution = sp.solve([s - t for s, t in zip(stress, target)], eps, dict=True)[0]
    return np.array([float(solution[e]) for e in eps])


def test_uniaxial_strain_is_hookes():
    """The strains above against the closed forms: plane strain ε_xx = ν(1+ν)p/E, ε_yy = −(1−ν²)p/E; 3D
    ε_xx = ε_yy = νp/E, ε_zz = −p/E."""
    np.testing.assert_allclose(uniaxial_strain(2), [NU * (1 + NU) * P / E, -(1 - NU**2) * P / E], rtol=1e-14)
    np.testing.assert_allclose(uniaxial_strain(3), [NU * P / E, NU * P / E, -P / E], rtol=1e-14)


def pressed_block(dim, m_n, gap):
    corners = [[0, 0], [1, 0.5]] if dim == 2 else [[0, 0, 0], [1, 0.5, 0.5]]
    top, bottom = ("top", "bottom")
    data = {"mesh": {"rectangle" if dim == 2 else "box": corners, "cells": [6, 3] if dim == 2 else [3, 2, 2],
                     "symmetry": ["left"] if dim == 2 else ["left", "front"], "contact": [bottom],
                     "neumann": [top, "right"] + ([] if dim == 2 else ["back"])},
            "material": {"E": E, "nu": NU},
            "loads": {"g": {top: ["0"] * (dim - 1) + [str(-P)]}},
            "contact": {"c_n": C_N, "m_n": m_n, "gap": gap}}
    return nc.Problem.from_dict(data)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("m_n, gap", [(1.0, 0.0), (1.5, 0.0), (3.0, 0.0), (1.5, 0.05), (3.0, 0.05)])
def test_a_block_resting_on_the_foundation(dim, m_n, gap):
    problem = pressed_block(dim, m_n, gap)
    solution = nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    V = solution.u.function_space
    x = V.tabulate_dof_coordinates()[:, :dim]
    exact = x * uniaxial_strain(dim)
    exact[:, -1] -= gap + (P / C_N) ** (1 / m_n)  # the base sinks by g_0 + d
    error = np.abs(solution.u.x.array.reshape(-1, dim) - exact).max()
    assert MPI.COMM_WORLD.allreduce(error, MPI.MAX) <= 1e-8 * np.abs(exact).max()
    vertical = "translation along y" if dim == 2 else "translation along z"
    assert f"no support holds {vertical}: the foundation does" in " ".join(solution.fields.notes)


@pytest.mark.parametrize("change, expected", [
    ({"symmetry": []}, "translation along x; the foundation does not move under it"),
    ({"g": ["0", "10"]}, "translation along y; the loads pull it off the foundation"),
    ({"g": ["1", "0"]}, "translation along y; nothing presses the body onto the foundation"),
])
def test_what_the_foundation_cannot_hold_is_named_before_newton(change, expected):
    problem = pressed_block(2, 1.5, 0.0)
    raw = problem.raw
    if "symmetry" in change:
        raw["mesh"]["symmetry"], raw["mesh"]["neumann"] = [], ["top", "right", "left"]
    else:
        raw["loads"]["g"] = {"top": change["g"]}
    problem = nc.Problem.from_dict(raw)
    with pytest.raises(InputError) as err:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    assert f"the body is free to move: {expected}" in str(err.value)


@pytest.mark.parametrize("dim, friction, expected", [
    (2, None, "translation along x; the foundation does not move under it (a frictionless foundation holds only "
              "what moves it normally)"),
    (2, 0.0, "translation along x; its friction does not hold it (contact.friction = 0 where the body is pressed)"),
    (3, 0.0, "rotation about z, translation along x, translation along y; its friction does not hold it "
             "(contact.friction = 0 where the body is pressed)"),
])
def test_what_friction_cannot_hold_is_named_before_newton(dim, friction, expected):
    """No symmetry plane: the sliding motions are refused without friction and with μ = 0 everywhere."""
    problem = block(dim, friction, shear=1.0)
    with pytest.raises(InputError) as err:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    assert str(err.value).startswith(f"the body is free to move: {expected}: hold it with")


def test_friction_holds_nothing_unpressed():
    """Friction on, the vertical motion held by a roller pressing the top down: at the cold start nothing
    presses the base yet (u = 0), so no friction bound exists for the solver's first pass: refused, naming
    the sliding motion; the same with the bound given as c_t names that key."""
    raw = block(2).raw
    raw["mesh"]["dirichlet"], raw["mesh"]["neumann"] = ["top"], ["left", "right"]
    raw["loads"] = {"u_D": ["free", "-0.01"]}
    with pytest.raises(InputError) as err:
        nc.solve(nc.Problem.from_dict(raw), nc.build_domain(nc.Problem.from_dict(raw), MPI.COMM_WORLD))
    assert "free to move: translation along x; nothing presses the body onto the foundation, whose friction" \
        in str(err.value)
    raw = block(2, friction=None, shear=1.0).raw
    raw["contact"] |= {"c_t": "0", "m_t": 1.5}
    with pytest.raises(InputError) as err:
        nc.solve(nc.Problem.from_dict(raw), nc.build_domain(nc.Problem.from_dict(raw), MPI.COMM_WORLD))
    assert "translation along x; its friction does not hold it (contact.c_t = 0 where" in str(err.value)


def test_loads_beyond_friction_are_named_before_newton():
    """A shear beyond μ times the normal load slides the block off: the first pass's energy has no minimum
    along the translation, refused with the ratio, which on the flat base is shear / (μ P) (the settled
    pressure's resultant balances P to the settling's tolerance)."""
    shear = 3.5
    problem = block(2, shear=shear)
    with pytest.raises(InputError) as err:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    message = str(err.value)
    assert message.startswith("the body is free to move: translation along x; the loads pull it along the "
                              "foundation with ")
    assert "times the most its friction holds (contact.friction times the pressure)" in message
    ratio = float(message.split(" with ")[1].split()[0])
    # the law's bound at the vertices, Σ m_i μ c_n (u·N − g̃_0)_+(x_i), lumps the settled pressure: μP to 1 %
    assert ratio == pytest.approx(shear / (MU * P * 1.0), rel=1e-2)  # base length 1


def grid_minimum(along):
    """min C(τ) over λ L(τ) = 1 (settling._check_friction_limit's problem) by brute force, independent of its
    Nelder–Mead: a grid of 21 points per free amplitude over ±10 |base|, zoomed 5× around the best point 8
    times (C is convex, so the best point stays inside the next grid)."""
    from nc_dolfinx.physics import rigid
    base = along.load / (along.load @ along.load)
    others = rigid.null_space(np.outer(along.load, along.load))
    best, centre, span = along.capacity(base), np.zeros(others.shape[1]), 10 * np.linalg.norm(base)
    best_z = centre
    for _ in range(8):
        axis = np.linspace(-span, span, 21)
        for z in centre + np.stack(np.meshgrid(*[axis] * others.shape[1]), -1).reshape(-1, others.shape[1]):
            capacity = along.capacity(base + others @ z)
            if capacity < best:
                best, best_z = capacity, z
        centre, span = best_z, span / 5
    return best


@pytest.mark.parametrize("shear, twist", [(2.9, 1.0), (0.3, 9.5), (0.0, 9.0), (3.1, 0.0), (1.0, 6.0)])
def test_the_friction_limit_in_3d_is_the_grid_s(monkeypatch, shear, twist):
    """3D: the limit along the three sliding motions (x, y, the rotation about z) is found by Nelder–Mead
    over two amplitudes. Against a brute-force grid (grid_minimum): the same decision and the same ratio to
    the printed digits, also 0.13 % beyond the limit with shear and twist together (0.3 + 9.5: 1.0013 with the
    law's bound at the vertices, issue 50; 0.3 + 8.5 was 1.002 with the Gauss-point bound)."""
    from nc_dolfinx.solver import settling
    seen, check = {}, settling._check_friction_limit

    def check_and_measure(along, key):
        seen["ratio"] = 1 / grid_minimum(along)
        check(along, key)
    monkeypatch.setattr(settling, "_check_friction_limit", check_and_measure)
    problem = block(3, shear=shear, twist=twist)
    try:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
        refused = None
    except InputError as err:
        refused = float(str(err).split(" with ")[1].split()[0])
    ratio = seen["ratio"]
    assert abs(ratio - 1.0) > 1e-3  # (a decision the grid can make)
    if ratio < 1.0:
        assert refused is None
    else:
        assert refused == pytest.approx(ratio, abs=0.006)  # (printed to 3 digits)


def test_a_load_beyond_friction_that_the_check_missed_ends_in_one_clear_error(monkeypatch):
    """Were the limit check to miss a load beyond friction (0.3 + 9.6: 1.01 times the limit; at 1.0013 the
    final pressure still held it), Newton runs, fails, and the fallbacks end in one clear error. The
    stronger_pc fallback switches CG to GMRES;
    after the friction solver's consistent steps had set the preconditioning side explicitly, that ended in
    PETSc's error 56 (GMRES has no unpreconditioned norm with a left preconditioner) on every 3D friction
    run that reached it."""
    from nc_dolfinx.solver import settling
    monkeypatch.setattr(settling, "_check_friction_limit", lambda along, key: None)
    problem = block(3, shear=0.3, twist=9.6)
    with pytest.raises(InputError) as err:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    assert str(err.value).startswith("SNES diverged") and "stronger_pc" in str(err.value)


def test_the_sliding_motions_stick_at_the_previous_state():
    """Δu_t is measured from the previous load state: a previous state translated along the base moves the
    solution by the same translation (the elastic and normal energies do not see it), exactly."""
    problem = block(2, shear=1.0)
    domain = nc.build_domain(problem, MPI.COMM_WORLD)
    start = nc.solve(problem, domain)
    previous = fem.Function(start.u.function_space)
    previous.x.array[:] = np.tile([0.01, 0.0], len(previous.x.array) // 2)
    moved = nc.solve(problem, domain, previous_state=previous)
    error = np.abs(moved.u.x.array - previous.x.array - start.u.x.array).max()
    assert MPI.COMM_WORLD.allreduce(error, MPI.MAX) <= 1e-9 * np.abs(start.u.x.array).max()


def test_a_symmetric_block_held_by_friction_is_its_half():
    """Vertical load only, a mirror-symmetric mesh: friction holds the block's horizontal position (the
    solution is then symmetric, u_x = 0 on x = 1/2) and the block equals its half cut by the symmetry plane
    x = 1/2 at every common node; the friction force that restrains the Poisson expansion cancels over the
    whole base, while on the half it balances the plane's reaction."""
    full, half = (nc.adapt(block(2, half=cut)) for cut in (False, True))
    (x_full, u_full), (x_half, u_half) = (sorted_nodal_values(r.final.u, MPI.COMM_WORLD) for r in (full, half))
    if MPI.COMM_WORLD.rank == 0:
        right = x_full[:, 0] >= 0.5 - 1e-12
        np.testing.assert_allclose(x_full[right], x_half, rtol=0, atol=1e-12)
        np.testing.assert_allclose(u_full[right], u_half, rtol=0, atol=1e-9 * np.abs(u_half).max())
    restraint = half.history[-1]["friction_force"][0]
    assert restraint == pytest.approx(-half.history[-1]["reaction_left"][0], rel=1e-9)
    assert abs(restraint) > 1e-2 * P  # friction does act,
    assert abs(full.history[-1]["friction_force"][0]) < 1e-9 * abs(restraint)  # and cancels over the base


@pytest.mark.parametrize("dim", [2, 3])
def test_friction_holds_the_sheared_block_on_any_ranks(dim):
    """Sheared (and in 3D twisted) below μ times the pressure, held by friction alone: the friction force
    balances the applied shear, the pressure's resultant the vertical load, and 1, 2 and 3 ranks give the
    same nodal values."""
    outputs = [run([SCRIPT, dim], n) for n in (1, 2, 3)]
    for out in outputs:
        assert out.returncode == 0, out.stderr[-3000:]
    results = [json.loads(out.stdout.strip().splitlines()[-1]) for out in outputs]
    for result in results:
        applied = np.array(result["applied_load"])
        assert result["force_balance"] < 1e-9
        np.testing.assert_allclose(result["friction_force"][:-1], -applied[:-1], rtol=0, atol=1e-9 * abs(applied[-1]))
        assert abs(applied[0]) > 0.05 * abs(applied[-1])  # a real shear
        assert result["contact_resultant"] == pytest.approx(-applied[-1], rel=1e-9)
    serial = np.array(results[0]["nodal_values"])
    for parallel in results[1:]:
        np.testing.assert_allclose(parallel["nodal_values"], serial, rtol=0, atol=1e-9 * np.abs(serial).max())
