"""Coulomb friction on an unstructured tetrahedral mesh of a curved body (tests/test_friction_vertices.py):
half of the lower half of a ball (meshes/gmsh_common.lower_ball, made by the test), pressed onto a stiff
flat foundation with friction already on (μ = 0.3, one increment from the unloaded body), then sheared
along x in one increment (partial slip), then held at the same load for one more increment. Each increment
starts from the law's state at the end of the one before (nc.SlipState.after).

    mpirun -n N python3 tests/mpi/friction_vertices.py BALL.msh OUT.npz

Writes on rank 0, for the sheared and the held increments, every vertex's data sorted by coordinates: the
law's inputs (u, the state it started from: u_prev and σ_t,prev, the vertex normal N, the law's gap g̃_0,
the weight m_i = ∫_Γ_C φ_i by a Gauss rule), the fields written for ParaView (tangential_traction,
friction_bound, slip, stick_slip) and the history's friction figures; the test evaluates the law itself.
"""
import sys

import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem
import dolfinx.fem.petsc as fem_petsc

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions
from nc_dolfinx.output import postprocess
from nc_dolfinx.physics import quantities

MU, C_N, E, DN, DT = 0.3, 1.0e5, 1.0e3, 0.04, 0.004  # Q ≈ 0.23 μP: partial slip


def problem(path, dt):
    return nc.Problem.from_dict({
        "mesh": {"file": str(path), "dirichlet": ["top"], "symmetry": ["symmetry"], "neumann": ["free"],
                 "contact": ["contact"]},
        "material": {"E": E, "nu": 0.3}, "loads": {"u_D": [repr(dt), "0", repr(-DN)]},
        "contact": {"c_n": C_N, "m_n": 1, "gap": "1 - sqrt(max(1 - x**2 - y**2, 0))", "friction": MU}},
        "friction_vertices")


def vertex_weights(fields):
    """m_i = ∫_Γ_C φ_i by the default Gauss rule (not the law's vertex rule: an independent measure)."""
    V = versions.p1_space(fields.domain.mesh)
    weights = fem.Function(V)
    vec = versions.petsc_vec(weights)
    fem_petsc.assemble_vector(vec, fem.form(ufl.TestFunction(V) * fields.ds_of("contact")))
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    vec.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    return weights


def sorted_values(function, comm):
    """The owned vertex values of a P1 function of all ranks on rank 0, sorted by coordinates, (n, bs)."""
    V = function.function_space
    bs, n = V.dofmap.index_map_bs, V.dofmap.index_map.size_local
    gathered = comm.gather((V.tabulate_dof_coordinates()[:n], function.x.array[:n * bs].reshape(-1, bs)), root=0)
    if comm.rank != 0:
        return None
    points = np.concatenate([x for x, _ in gathered])
    values = np.concatenate([v for _, v in gathered])
    return values[np.lexsort(np.round(points, 12).T[::-1])]


def record(name, solution, start, comm):
    """The increment's vertex data and history figures, keyed ``name_...``."""
    law = solution.fields.friction
    written = {f.name: f for f in postprocess.friction_fields(solution.u, solution.fields)}
    functions = {"u": solution.u, "u_prev": start.displacement, "traction_prev": start.traction,
                 "normal": law.normal, "gap": law.gap, "weight": vertex_weights(solution.fields), **written}
    out = {f"{name}_{key}": sorted_values(fn, comm) for key, fn in functions.items()}
    figures = quantities.friction_quantities(solution.u, solution.fields)
    out.update({f"{name}_{key}": np.asarray(figures[key]) for key in ("friction_force", "stick_area", "slip_area")})
    return out


if __name__ == "__main__":
    comm = MPI.COMM_WORLD
    mesh_file, out_file = sys.argv[1:3]
    domain = nc.build_domain(problem(mesh_file, 0.0), comm)
    pressed = nc.solve(problem(mesh_file, 0.0), domain)  # friction on while pressing, from the unloaded body
    results = {}
    start, initial = nc.SlipState.after(pressed.u, pressed.fields), pressed.u
    for name in ("sheared", "held"):
        solution = nc.solve(problem(mesh_file, DT), domain, initial=initial, previous_state=start)
        results.update(record(name, solution, start, comm))
        start, initial = nc.SlipState.after(solution.u, solution.fields), solution.u
    if comm.rank == 0:
        np.savez(out_file, mu=MU, c_n=C_N, epsilon_r=float(pressed.fields.friction.epsilon.value), **results)
