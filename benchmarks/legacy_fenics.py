#!/usr/bin/env python3
"""The normal compliance problems ``block``, ``corner`` and the family's ``square`` in legacy FEniCS 2019
(Debian ``python3-dolfin``).

Run by ``benchmarks/run.py`` and ``benchmarks/family.py`` in its own process (never import dolfin and
dolfinx together)::

    [mpirun -n 2] /usr/bin/python3 benchmarks/legacy_fenics.py --problem block --cells 362 181 --json out.json
    [mpirun -n 2] /usr/bin/python3 benchmarks/legacy_fenics.py --problem corner --mesh-npz mesh.npz --json out.json
    /usr/bin/python3 benchmarks/legacy_fenics.py --problem square --cells 256 256 --cn 100 --mn 2 --json out.json

The way a careful legacy user writes it: the full residual in UFL,
    F(u; v) = a(u, v) + ∫_Γ_C c_n (u·n − g_0)_+^{m_n} v·n ds − L(v),
its Jacobian by ``derivative``, symmetric Dirichlet conditions (``SystemAssembler``), dolfin's
``NewtonSolver`` (no line search, residual criterion, rtol 1e-10, atol 1e-12) with a ``PETScKrylovSolver``
configured through ``PETScOptions``: CG + GAMG (the options of nc_dolfinx's ``iterative`` preset) with the
rigid-body near-nullspace, ksp_rtol 1e-10. The Jacobian is reassembled and GAMG set up again every
Newton step (that is what dolfin's NewtonSolver does). The problem data below repeat
``nc_dolfinx/cases/{block,corner}.toml`` and benchmarks/family.py (the unit square, E = 1, clamped top,
f = (0, −0.5), contact on the bottom with c_n, m_n and the gap a + b x given on the command line); the
drivers check that the energies agree.

A warm-up solve on a tiny mesh first keeps the JIT compilation out of the timings. Prints nothing;
writes {setup, solve, newton, krylov, energy, contact_force, dofs} as JSON (rank 0).
"""
import argparse
import json
import time

import numpy as np

import dolfin as df
from dolfin import (MPI, Constant, DirichletBC, FacetNormal, Function, Mesh, MeshFunction,
                    Measure, NewtonSolver, NonlinearProblem, PETScFactory, PETScKrylovSolver, PETScOptions,
                    SpatialCoordinate, SystemAssembler, TestFunction, TrialFunction, VectorFunctionSpace,
                    VectorSpaceBasis, as_backend_type, as_vector, assemble, conditional, derivative, dot,
                    dx, grad, gt, inner, sym, tr, Identity)

df.set_log_level(df.LogLevel.WARNING)

NU = 0.3
DIRICHLET, NEUMANN, CONTACT = 1, 2, 3
CONTACT_DEGREE = 8  # as nc_dolfinx.physics.forms.CONTACT_QUADRATURE_DEGREE

GAMG_OPTIONS = {"ksp_type": "cg", "ksp_rtol": 1e-10, "pc_type": "gamg", "pc_gamg_type": "agg",
                "pc_gamg_agg_nsmooths": 1, "mg_levels_ksp_type": "chebyshev", "mg_levels_pc_type": "jacobi"}


class Data:
    """The case's material, loads, contact law and boundary markers (as in its .toml file)."""

    def __init__(self, name, mesh, c_n=None, m_n=None, gap=(0.0, 0.0)):
        x = SpatialCoordinate(mesh)
        self.markers = MeshFunction("size_t", mesh, 1, 0)
        self.gap, self.g = Constant(0.0), Constant((0.0, 0.0))
        if name == "square":  # [0,1]^2: top clamped, bottom contact, sides free
            self.E, self.m_n, self.f = 1.0, m_n, Constant((0.0, -0.5))
            self.c_n, self.gap = Constant(c_n), gap[0] + gap[1] * x[0]
            self.mark("near(x[1], 1.0)", DIRICHLET)
            self.mark("near(x[1], 0.0)", CONTACT)
            return
        self.E, self.m_n = 1.0e3, 1.5
        self.mark("near(x[0], 0.0)", DIRICHLET)
        self.mark("near(x[1], 0.0)", CONTACT)
        if name == "block":  # [0,2]x[0,1]: left clamped, top traction (0, -20x), right free, bottom contact
            self.mark("near(x[1], 1.0)", NEUMANN)
            self.f, self.c_n, self.g = as_vector([0.0, -10.0]), 2.0e3 * (1 + x[0]), as_vector([0.0, -20 * x[0]])
        else:  # corner: L-shape, left clamped, top y = 2 traction (0, -10), bottom contact, the rest free
            self.mark("near(x[1], 2.0)", NEUMANN)
            self.f, self.c_n, self.g = Constant((0.0, 0.0)), Constant(1.0e3), Constant((0.0, -10.0))

    def mark(self, where, value):
        df.CompiledSubDomain("on_boundary && " + where).mark(self.markers, value)

    def sigma(self, u):
        lmbda, mu = self.E * NU / ((1 + NU) * (1 - 2 * NU)), self.E / (2 * (1 + NU))
        eps = sym(grad(u))
        return 2 * mu * eps + lmbda * tr(eps) * Identity(2)


def rigid_body_modes(V, x):
    """Two translations and the rotation (legacy elasticity demo), orthonormalised."""
    modes = [x.copy() for _ in range(3)]
    V.sub(0).dofmap().set(modes[0], 1.0)
    V.sub(1).dofmap().set(modes[1], 1.0)
    V.sub(0).set_x(modes[2], -1.0, 1)
    V.sub(1).set_x(modes[2], 1.0, 0)
    for m in modes:
        m.apply("insert")
    basis = VectorSpaceBasis(modes)
    basis.orthonormalize()
    return basis


class ContactProblem(NonlinearProblem):
    def __init__(self, F, J, bcs):
        NonlinearProblem.__init__(self)
        self.assembler = SystemAssembler(J, F, bcs)

    def F(self, b, x):
        self.assembler.assemble(b, x)

    def J(self, A, x):
        self.assembler.assemble(A)


class GamgNewton(NewtonSolver):
    def __init__(self, comm, nullspace):
        self.krylov = PETScKrylovSolver()
        NewtonSolver.__init__(self, comm, self.krylov, PETScFactory.instance())
        self.nullspace, self.krylov_iterations = nullspace, 0

    def solver_setup(self, A, P, problem, iteration):
        as_backend_type(A).set_near_nullspace(self.nullspace)
        self.krylov.set_operator(A)
        for key, value in GAMG_OPTIONS.items():
            PETScOptions.set(key, value)
        self.krylov.set_from_options()

    def update_solution(self, x, dx, relaxation, problem, iteration):
        self.krylov_iterations += self.krylov.ksp().getIterationNumber()
        NewtonSolver.update_solution(self, x, dx, relaxation, problem, iteration)


def solve(name, mesh, **contact):
    comm = mesh.mpi_comm()
    start = time.perf_counter()
    V = VectorFunctionSpace(mesh, "CG", 1)
    u, v, du = Function(V), TestFunction(V), TrialFunction(V)
    data = Data(name, mesh, **contact)
    ds = Measure("ds", domain=mesh, subdomain_data=data.markers)
    ds_c = ds(CONTACT, metadata={"quadrature_degree": CONTACT_DEGREE})
    n = FacetNormal(mesh)
    un = dot(u, n) - data.gap
    pressure = data.c_n * conditional(gt(un, 0), un, 0) ** data.m_n
    F = inner(data.sigma(u), sym(grad(v))) * dx + pressure * dot(v, n) * ds_c - inner(data.f, v) * dx \
        - inner(data.g, v) * ds(NEUMANN)
    J = derivative(F, u, du)
    bcs = [DirichletBC(V, Constant((0.0, 0.0)), data.markers, DIRICHLET)]
    problem = ContactProblem(F, J, bcs)
    newton = GamgNewton(comm, rigid_body_modes(V, u.vector()))
    prm = newton.parameters
    prm["convergence_criterion"] = "residual"
    prm["relative_tolerance"], prm["absolute_tolerance"] = 1e-10, 1e-12
    prm["maximum_iterations"], prm["error_on_nonconvergence"] = 50, False
    prm["report"] = False
    setup = time.perf_counter() - start
    t = time.perf_counter()
    try:
        its, converged = newton.solve(problem, u.vector())
    except RuntimeError:  # a failed Krylov solve (or NaN) ends dolfin's Newton with an exception
        its, converged = -1, False
    elapsed = time.perf_counter() - t
    energy = assemble(0.5 * inner(data.sigma(u), sym(grad(u))) * dx)
    force = assemble(pressure * ds_c)
    return {"setup": setup, "solve": elapsed, "newton": its, "krylov": newton.krylov_iterations,
            "converged": bool(converged), "energy": energy, "contact_force": force, "dofs": V.dim(),
            "ranks": MPI.size(comm)}


def rectangle(cells, comm=None, corner=(2.0, 1.0)):
    comm = comm or MPI.comm_world
    return df.RectangleMesh(comm, df.Point(0.0, 0.0), df.Point(*corner), cells[0], cells[1], "right")


def mesh_from_npz(path, comm):
    """The triangles exported by run.py; in parallel through an XDMF file written on rank 0."""
    data = np.load(path)
    points, cells = data["points"], data["cells"]

    def build(c):
        mesh = Mesh(c)
        editor = df.MeshEditor()
        editor.open(mesh, "triangle", 2, 2)
        editor.init_vertices(len(points))
        editor.init_cells(len(cells))
        for i, p in enumerate(points):
            editor.add_vertex(i, p)
        for i, c_ in enumerate(cells):
            editor.add_cell(i, c_)
        editor.close()
        return mesh

    if MPI.size(comm) == 1:
        return build(comm)
    xdmf = str(path) + ".legacy.xdmf"
    if MPI.rank(comm) == 0:
        with df.XDMFFile(MPI.comm_self, xdmf) as fh:
            fh.write(build(MPI.comm_self))
    MPI.barrier(comm)
    mesh = Mesh(comm)
    with df.XDMFFile(comm, xdmf) as fh:
        fh.read(mesh)
    return mesh


def warm_up(name, **contact):
    """JIT-compile every form on a tiny mesh (same forms, so the real run finds them compiled)."""
    if name == "corner":
        mesh = df.RectangleMesh(MPI.comm_self, df.Point(0.0, 0.0), df.Point(2.0, 2.0), 4, 4)
    else:
        mesh = rectangle([8, 4], MPI.comm_self, (1.0, 1.0) if name == "square" else (2.0, 1.0))
    solve(name, mesh, **contact)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--problem", choices=("block", "corner", "square"), required=True)
    p.add_argument("--cells", type=int, nargs=2, help="block, square: cells in x and y")
    p.add_argument("--mesh-npz", help="corner: the mesh exported by run.py")
    p.add_argument("--cn", type=float, help="square: c_n")
    p.add_argument("--mn", type=float, help="square: m_n")
    p.add_argument("--gap", type=float, nargs=2, default=(0.0, 0.0), metavar=("A", "B"),
                   help="square: the gap g_0 = A + B x")
    p.add_argument("--json", required=True)
    args = p.parse_args()
    comm = MPI.comm_world
    contact = {"c_n": args.cn, "m_n": args.mn, "gap": tuple(args.gap)} if args.problem == "square" else {}
    warm_up(args.problem, **contact)
    MPI.barrier(comm)
    if args.problem == "corner":
        mesh = mesh_from_npz(args.mesh_npz, comm)
    else:
        mesh = rectangle(args.cells, corner=(1.0, 1.0) if args.problem == "square" else (2.0, 1.0))
    result = solve(args.problem, mesh, **contact)
    if MPI.rank(comm) == 0:
        with open(args.json, "w") as fh:
            json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
