"""Prescribed displacements u = u_D on Dirichlet groups (loads.u_D), rollers ("free" components), their
reactions, and the rigid-motion check of bind: against the exact uniaxial solution (tests/mpi/uniaxial.py)
and identities."""
import json

import numpy as np
import pytest
import sympy
from mpi4py import MPI

import nc_dolfinx as nc
from conftest import ROOT, run
from mpi.uniaxial import DELTA, E, NU, exact_reaction, outcome, uniaxial_problem
from nc_dolfinx.errors import InputError

SCRIPT = ROOT / "tests" / "mpi" / "uniaxial.py"


def test_plane_strain_uniaxial_constants():
    """Hooke's law with σ_yy = 0 and ε_zz = 0 (plane strain) gives σ_xx = E/(1 − ν²) ε_xx and
    ε_yy = −ν/(1 − ν) ε_xx, the constants of tests/mpi/uniaxial.py; with σ_yy = σ_zz = 0 (3D), E and −ν."""
    e, nu, exx, eyy, ezz = sympy.symbols("E nu e_xx e_yy e_zz")
    lmbda, mu = e * nu / ((1 + nu) * (1 - 2 * nu)), e / (2 * (1 + nu))

    def stress(i, strains):
        return 2 * mu * strains[i] + lmbda * sum(strains)

    plane = sympy.solve(stress(1, (exx, eyy, 0)), eyy)[0]
    assert sympy.simplify(plane + nu / (1 - nu) * exx) == 0
    assert sympy.simplify(stress(0, (exx, plane, 0)) - e / (1 - nu ** 2) * exx) == 0
    lateral = sympy.solve([stress(1, (exx, eyy, ezz)), stress(2, (exx, eyy, ezz))], [eyy, ezz])
    assert sympy.simplify(lateral[eyy] + nu * exx) == 0
    assert sympy.simplify(stress(0, (exx, lateral[eyy], lateral[ezz])) - e * exx) == 0


def solve(problem):
    return nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))


@pytest.mark.parametrize("dim", [2, 3])
def test_uniaxial_stress_from_rollers_and_a_prescribed_end(dim):
    """The nodal values are the exact linear solution; the right end's reaction is σ_xx times its area (the
    support pulls the body), the left roller's its opposite; a roller's free components and the symmetry
    planes carry no force; nothing touches the foundation; the balance closes."""
    result = outcome(solve(uniaxial_problem(dim)))
    force = exact_reaction(dim)
    assert result["nodal_error"] < 1e-10
    assert result["reaction_right"] == pytest.approx([force] + [0.0] * (dim - 1), rel=1e-10, abs=1e-10 * force)
    assert result["reaction_left"] == pytest.approx([-force] + [0.0] * (dim - 1), rel=1e-10, abs=1e-10 * force)
    for plane in ("bottom", "front")[:dim - 1]:
        assert np.abs(result[f"reaction_{plane}"]).max() < 1e-10 * force
    assert result["contact_resultant"] == 0.0
    assert result["applied_load"] == [0.0] * dim
    assert result["force_balance"] < 1e-10


def test_load_steps_ramp_the_prescribed_displacement():
    """Three load steps (u_D = δ/3, 2δ/3, δ) and the iterative preset reach the same exact solution."""
    result = outcome(solve(uniaxial_problem(3, load_steps=3, preset="iterative")))
    assert result["nodal_error"] < 1e-8
    assert result["reaction_right"][0] == pytest.approx(exact_reaction(3), rel=1e-8)


@pytest.mark.parametrize("dim", [2, 3])
def test_serial_and_parallel_agree(dim):
    """2 and 3 ranks give the serial reactions and the exact nodal values."""
    results = []
    for nprocs in (1, 2, 3):
        proc = run([SCRIPT, dim], nprocs, timeout=300)
        assert proc.returncode == 0, proc.stderr
        results.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    serial, force = results[0], exact_reaction(dim)
    for parallel in results[1:]:
        assert parallel["nodal_error"] < 1e-10
        for key in ("reaction_right", "reaction_left"):
            assert parallel[key] == pytest.approx(serial[key], rel=1e-10, abs=1e-10 * force)


def test_one_vector_for_every_group_and_clamped_groups_by_default():
    """u_D = [...] applies to every Dirichlet group; a group the table does not name stays clamped, so
    naming it with u_D = 0 changes nothing."""
    base = uniaxial_problem(2)
    everywhere = base.replace({"loads.u_D": ["0.5*delta", "free"], "mesh.dirichlet": ["right"],
                               "mesh.symmetry": ["bottom", "left"]})
    result = outcome(solve(everywhere))  # the right end at δ/2, the left a symmetry plane
    assert result["reaction_right"][0] == pytest.approx(exact_reaction(2) / 2, rel=1e-10)
    clamped = base.replace({"loads.u_D": {"right": ["delta", "0"]}})
    named = base.replace({"loads.u_D": {"right": ["delta", "0"], "left": ["0", "0"]}})
    u_clamped, u_named = (solve(p).u.x.array for p in (clamped, named))
    assert np.array_equal(u_clamped, u_named)


def test_a_parameter_of_u_D_scales_the_solution():
    """u_D = [delta, free] with delta doubled doubles u (linear elasticity, no contact)."""
    base = uniaxial_problem(2)
    u1 = solve(base).u.x.array
    u2 = solve(base.replace({"parameters.delta": 2 * DELTA})).u.x.array
    assert np.abs(u2 - 2 * u1).max() < 1e-12 * np.abs(u1).max()


FREE_MOTIONS = [
    (2, {"dirichlet": ["bottom"], "u_D": {"bottom": ["free", "0"]}}, ["translation along x"]),
    (2, {"dirichlet": ["left"], "u_D": {"left": ["0", "free"]}}, ["translation along y"]),
    (2, {"dirichlet": ["bottom"], "u_D": {"bottom": ["0", "free"]}},
     ["rotation about z about the point (1, 0)", "translation along y"]),
    (3, {"dirichlet": ["left"], "u_D": {"left": ["0", "free", "free"]}}, ["translation along y"]),
    (3, {"dirichlet": ["left"], "symmetry": ["front"], "u_D": {"left": ["0", "free", "free"]}},
     ["translation along z"]),
]


@pytest.mark.parametrize("dim, mesh, free", FREE_MOTIONS)
def test_bind_names_the_free_rigid_motions(dim, mesh, free):
    """The supports' Gram matrix of the rigid motions is singular exactly on the motions they leave free; the
    foundation (on 'top', loaded by nothing) holds none of them, so the solve refuses the problem before
    Newton, naming them (a bottom roller holding x holds the rotation about any point off the line y = 0, so
    the rotation about its point (1, 0) on it and the translation along y are free). Where the foundation
    moves under some of them but not others, the others are named: a roller holding x on 'left' leaves
    the rotation about x and the translations along y and z, of which the top foundation moves under all
    but the translation along y."""
    corners = [[0, 0], [2, 1]] if dim == 2 else [[0, 0, 0], [2, 1, 1]]
    cells = [4, 2] if dim == 2 else [2, 1, 1]
    u_D = mesh.pop("u_D")
    data = {"mesh": {"rectangle" if dim == 2 else "box": corners, "cells": cells, "contact": ["top"], **mesh},
            "material": {"E": E, "nu": NU}, "loads": {"f": ["0"] * dim, "u_D": u_D},
            "contact": {"c_n": 1.0, "m_n": 1.0}}
    problem = nc.Problem.from_dict(data)
    with pytest.raises(InputError) as err:
        nc.solve(problem, nc.build_domain(problem, MPI.COMM_WORLD))
    assert f"the body is free to move: {', '.join(free)};" in str(err.value)


def test_every_case_holds_every_rigid_motion():
    """Clamped Γ_D (every built-in case) holds every rigid motion: bind accepts them all."""
    for case in nc.case_names():
        problem = nc.load_problem(case)
        nc.bind(problem, nc.build_domain(problem, MPI.COMM_WORLD))


def test_a_rotation_about_an_off_centre_axis_is_named_by_its_axis():
    """Points on the line x = 1, y = 0 holding every component leave free exactly the rotation about that
    line (the Gram matrix's null space, one vector): named by its axis and a point of it."""
    from nc_dolfinx.physics import rigid
    line = np.column_stack([np.ones(5), np.zeros(5), np.linspace(-1, 1, 5)])
    free = rigid.free_rigid_motions([(line, (0, 1, 2))], np.zeros(3), 1.0, MPI.COMM_SELF)
    assert free == ["rotation about z through (1, 0, 0)"]


def test_load_steps_reach_the_same_contact_solution():
    """block pressed onto its foundation while its clamped side is also moved (u_D = (0.002, −0.001) on
    'left'): one load step and four (u_D ramped with f and g) converge to the same solution of (7)."""
    problem = nc.load_problem("block", ["mesh.cells=[12,6]", 'loads.u_D=["0.002", "-0.001"]'])
    solutions = [solve(problem.replace({"solver.load_steps": n})) for n in (1, 4)]
    u1, u4 = (s.u.x.array for s in solutions)
    assert np.abs(u4 - u1).max() < 1e-8 * np.abs(u1).max()
    left = solutions[0].u.function_space.tabulate_dof_coordinates()[:, 0] == 0.0
    assert np.array_equal(u1.reshape(-1, 2)[left], np.tile([0.002, -0.001], (left.sum(), 1)))
    assert nc.solution_quantities(solutions[0].u, solutions[0].fields)["contact_resultant"] > 0


@pytest.mark.parametrize("dim", [2, 3])
def test_a_roller_in_a_coordinate_plane_is_a_symmetry_plane(dim):
    """u_D = ["0", "free"(, "free")] on x = 0 is the symmetry plane x = 0: the same u_h, the same reaction,
    and the same η (the roller's free traction is the symmetry facet's σ_t; without that term η_2 would
    differ: 29.500 against 29.513 in 2D)."""
    mesh = {"rectangle": [[0, 0], [2, 1]], "cells": [8, 4]} if dim == 2 else \
        {"box": [[0, 0, 0], [2, 1, 1]], "cells": [4, 2, 2]}
    mesh.update({"dirichlet": ["right"], "neumann": ["top"], "contact": ["bottom"], "symmetry": ["left"]})
    down = ["0"] * (dim - 1)
    data = {"mesh": mesh, "material": {"E": E, "nu": NU}, "loads": {"f": [*down, "-10"], "g": [*down, "-20*x"]},
            "contact": {"c_n": 100 * E, "m_n": 1.5}, "solver": {"preset": "direct"}}
    symmetric = nc.Problem.from_dict(data)
    roller = symmetric.replace({"mesh.symmetry": [], "mesh.dirichlet": ["right", "left"],
                                "loads.u_D": {"left": ["0", *["free"] * (dim - 1)]}})
    solutions = [solve(p) for p in (symmetric, roller)]
    u_s, u_r = (s.u.x.array for s in solutions)
    assert np.abs(u_s - u_r).max() < 1e-10 * np.abs(u_s).max()
    q_s, q_r = (nc.solution_quantities(s.u, s.fields) for s in solutions)
    assert q_r["reaction_left"] == pytest.approx(q_s["reaction_left"], rel=1e-8)
    eta_s, eta_r = (nc.estimate(s.u, s.fields).totals for s in solutions)
    for key in ("eta_1", "eta_2", "eta_3", "eta_4", "eta"):
        assert eta_r[key] == pytest.approx(eta_s[key], rel=1e-10), key
