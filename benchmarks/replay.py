#!/usr/bin/env python3
"""The linear systems of one cold frictional solve, replayed under other preconditioners (issue 32's
speed target: each step within 2 x one linear solve).

    /usr/bin/python3 benchmarks/replay.py [--members 1-1-mu0.3 1e4-1-mu0.3 3d-1-1-mu0.3] [--cells 128]
                                          [--cells3d 16] [--rtol 1e-2] [--repeat 2]

A cold frictional solve of a ``family.py`` member (1 rank) takes one Krylov solve per Newton step. PETSc
writes each of them, operator and right-hand side, to a file (``-ksp_view_mat`` and ``-ksp_view_rhs`` with
``::append``, given through ``nc.solve``'s ``petsc_options``: nothing else is changed), and this harness
solves them all again, from zero, with GMRES (right preconditioning, unpreconditioned norm, relative
tolerance ``--rtol``) under each preconditioner:

- ``refresh``: BoomerAMG (the solver's settings in that dimension) set up on every system, what the solver
  does at most;
- ``kept``: BoomerAMG set up on the first system only and kept, what it does at least;
- ``block``: BoomerAMG set up once on the bulk block (the rows and columns off Γ_C: the contact forms touch
  Γ_C's dofs only, so that block never changes) and an LU factorisation of the Γ_C block on every system,
  applied as a symmetric block Gauss–Seidel sweep (bulk, Γ_C, bulk).

Times are against the floor (``family.py``'s: one BoomerAMG set-up and CG to 1e-8 on K u = L, the same
mesh), each the fastest of ``--repeat`` in this process; ``cold/floor`` is the solver's own cold solve.
Prints one table.
"""
import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(1, str(HERE.parent))  # (nc_dolfinx itself: this harness solves in its own process)
from common import FLOOR_HYPRE, LinearFloor, dofs, format_table, machine_load  # noqa: E402
import family  # noqa: E402

STRATEGIES = ("refresh", "kept", "block")


def captured_systems(problem, domain, path):
    """The cold solve's (operator, right-hand side) pairs, read back from PETSc's binary file, and its
    Newton steps."""
    import nc_dolfinx as nc
    from petsc4py import PETSc
    view = f"binary:{path}::append"
    solution = nc.solve(problem, domain, petsc_options={"ksp_view_mat": view, "ksp_view_rhs": view})
    viewer = PETSc.Viewer().createBinary(str(path), "r")
    systems = []
    while True:
        try:
            systems.append((PETSc.Mat().load(viewer), PETSc.Vec().load(viewer)))
        except PETSc.Error:  # (the end of the file)
            break
    viewer.destroy()
    return systems, solution.stats.newton_iterations


def boomeramg(matrix, dim):
    """A BoomerAMG preconditioner of ``matrix`` with the solver's settings for dimension ``dim``, set up."""
    from petsc4py import PETSc
    options = PETSc.Options("replay_")
    for key, value in FLOOR_HYPRE[dim].items():
        if key.startswith("pc_"):
            options[key] = value
    pc = PETSc.PC().create(matrix.getComm())
    pc.setOptionsPrefix("replay_")
    pc.setOperators(matrix)
    pc.setFromOptions()
    pc.setUp()
    return pc


class BlockGaussSeidel:
    """A petsc4py python PC: y = (bulk sweep, exact Γ_C solve, bulk sweep) applied to r."""

    def __init__(self, bulk_pc, bulk, contact):
        self.bulk_pc, self.bulk, self.contact = bulk_pc, bulk, contact

    def setUp(self, pc):
        from petsc4py import PETSc
        A, _ = pc.getOperators()
        self.blocks = {(i, j): A.createSubMatrix(self.contact if i == "c" else self.bulk,
                                                 self.contact if j == "c" else self.bulk)
                       for i in "bc" for j in "bc"}
        self.lu = PETSc.PC().create(A.getComm())
        self.lu.setOperators(self.blocks["c", "c"])
        self.lu.setType("lu")
        self.lu.setUp()
        # work vectors, made once (apply runs once per GMRES iteration)
        self.y_b, self.t_b, self.d_b = (self.blocks["b", "b"].createVecLeft() for _ in range(3))
        self.y_c, self.t_c = (self.blocks["c", "c"].createVecLeft() for _ in range(2))

    def apply(self, pc, r, y):
        r_b, r_c = r.getSubVector(self.bulk), r.getSubVector(self.contact)
        self.bulk_pc.apply(r_b, self.y_b)
        self.blocks["c", "b"].mult(self.y_b, self.t_c)  # t_c = r_c − A_cb y_b
        self.t_c.aypx(-1.0, r_c)
        self.lu.apply(self.t_c, self.y_c)
        self.blocks["b", "b"].mult(self.y_b, self.t_b)  # t_b = r_b − A_bb y_b − A_bc y_c
        self.blocks["b", "c"].multAdd(self.y_c, self.t_b, self.t_b)
        self.t_b.aypx(-1.0, r_b)
        self.bulk_pc.apply(self.t_b, self.d_b)
        self.y_b.axpy(1.0, self.d_b)
        r.restoreSubVector(self.bulk, r_b)
        r.restoreSubVector(self.contact, r_c)
        for part, values in ((self.bulk, self.y_b), (self.contact, self.y_c)):
            sub = y.getSubVector(part)
            values.copy(sub)
            y.restoreSubVector(part, sub)


def replay(systems, strategy, dim, contact, rtol):
    """(wall s, Krylov iterations, set-ups, largest true relative residual) of solving every system."""
    from petsc4py import PETSc
    start = time.perf_counter()
    its, setups, worst = 0, 0, 0.0
    A0 = systems[0][0]
    n = A0.getSize()[0]
    if strategy == "block":
        import numpy as np
        is_c = PETSc.IS().createGeneral(contact, comm=A0.getComm())
        is_b = PETSc.IS().createGeneral(np.setdiff1d(np.arange(n, dtype=np.int32), contact), comm=A0.getComm())
        bulk_pc = boomeramg(A0.createSubMatrix(is_b, is_b), dim)
        setups += 1
    elif strategy == "kept":
        kept = boomeramg(A0, dim)
        setups += 1
    for A, b in systems:
        ksp = PETSc.KSP().create(A.getComm())
        ksp.setType("gmres")
        ksp.setNormType(PETSc.KSP.NormType.UNPRECONDITIONED)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        ksp.setTolerances(rtol=rtol, max_it=2000)
        if strategy == "refresh":
            ksp.setPC(boomeramg(A, dim))
            setups += 1
        elif strategy == "kept":
            ksp.setPC(kept)
        else:
            ksp.getPC().setType("python")
            ksp.getPC().setPythonContext(BlockGaussSeidel(bulk_pc, is_b, is_c))
        ksp.setOperators(A, A if strategy != "kept" else A0)
        x = A.createVecRight()
        ksp.solve(b, x)
        its += ksp.getIterationNumber()
        residual = b.duplicate()
        A.mult(x, residual)
        residual.aypx(-1.0, b)
        worst = max(worst, residual.norm() / b.norm())
    return time.perf_counter() - start, its, setups, worst


def contact_dofs(V, dim):
    """The dofs at the family's Γ_C (its bottom side, the last coordinate 0), all components."""
    import numpy as np
    x = V.tabulate_dof_coordinates()
    vertices = np.flatnonzero(np.isclose(x[:, dim - 1], 0.0))
    return np.sort(np.concatenate([vertices * dim + k for k in range(dim)])).astype(np.int32)


def measure(member, cells, args, tmp):
    """One row of the table."""
    from mpi4py import MPI
    import nc_dolfinx as nc
    problem, domain = family.member_problem(member, cells, MPI.COMM_SELF, tmp)
    floor = LinearFloor(problem, domain)
    nc.solve(problem, domain)  # (warm-up: forms compiled)
    best = {"floor": min(floor.solve(amg="hypre")[0] for _ in range(args.repeat + 1))}
    solve = min(nc.solve(problem, domain).stats.time for _ in range(args.repeat))
    path = Path(tmp) / f"{member.name}.bin"
    systems, newton = captured_systems(problem, domain, path)
    os.remove(path)
    contact = contact_dofs(floor.V, member.dim)
    row = {"member": member.name, "dofs": dofs(domain), "Γ_C dofs": len(contact), "Newton": newton,
           "systems": len(systems), "cold/floor": solve / best["floor"]}
    for strategy in STRATEGIES:
        runs = [replay(systems, strategy, member.dim, contact, args.rtol) for _ in range(args.repeat)]
        wall, its, setups, worst = min(runs)
        if worst > 1.01 * args.rtol:
            raise RuntimeError(f"{member.name}, {strategy}: a replayed solve ended at {worst:.1e} > rtol")
        row.update({f"{strategy} its": its, f"{strategy} set-ups": setups,
                    f"{strategy}/floor": wall / best["floor"]})
    floor.destroy()
    return row


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--members", nargs="+", default=["1-1-mu0.3", "1e4-1-mu0.3", "3d-1-1-mu0.3"],
                   choices=[m.name for m in family.MEMBERS_FRICTION], metavar="MEMBER",
                   help="family.py's friction members")
    p.add_argument("--cells", type=int, default=128, help="2D members: cells a side")
    p.add_argument("--cells3d", type=int, default=16, help="3D members: cells a side")
    p.add_argument("--rtol", type=float, default=1e-2, help="each replayed solve's relative tolerance")
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--json-out", type=Path, help="also write the rows as JSON")
    args = p.parse_args(argv)
    print(f"load average at the start: {machine_load():.2f}", file=sys.stderr, flush=True)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.members:
            member = next(m for m in family.MEMBERS_FRICTION if m.name == name)
            rows.append(measure(member, args.cells if member.dim == 2 else args.cells3d, args, tmp))
    columns = [("member", "member", "{}"), ("dofs", "dofs", "{}"), ("Γ_C dofs", "Γ_C dofs", "{}"),
               ("Newton", "Newton", "{}"), ("systems", "systems", "{}"), ("cold/floor", "cold/floor", "{:.2f}")]
    columns += [(f"{s} {c}", f"{s} {c}", "{}") for s in STRATEGIES for c in ("its", "set-ups")]
    columns += [(f"{s}/floor", f"{s}/floor", "{:.2f}") for s in STRATEGIES]
    print(format_table(rows, columns))
    if args.json_out:
        args.json_out.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
