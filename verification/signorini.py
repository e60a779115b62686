"""The discrete Signorini problem (the limit ε → 0 of the penalty, paper Remark 1), solved with PETSc's
semismooth variational-inequality Newton (SNES ``vinewtonrsls``).

    find u_h ∈ V_h:  u_hn(x) ≤ g_0(x) at every node x of Γ_C,
                     a(u_h, v_h − u_h) ≥ L(v_h − u_h)  for all admissible v_h.

On a flat bottom boundary Γ_C (outward normal ν = −e_d, the last coordinate: ν = (0, −1) in 2D,
(0, 0, −1) in 3D) u_hn = −u_hd, so the constraint is the box bound u_hd ≥ −g_0 on the vertical dofs of the
contact nodes, and every other dof is unbounded. The linear elasticity residual F(u) = K u − L and K are
assembled once; Dirichlet rows are identity rows (F = u on Γ_D, kept at zero). The solver works for any
body whose contact boundary is its bottom (y = y_min in 2D, z = z_min in 3D).
"""
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions


def external_load(fields, v):
    """L(v) = ∫_Ω f·v + Σ_Neumann groups ∫ g·v (the problem's loads, at full load)."""
    L = ufl.inner(fields.f, v) * ufl.dx
    for group_id, g in fields.g.items():
        L += ufl.inner(g, v) * fields.ds(group_id)
    return L


def solve_signorini(problem, domain, rtol=1e-12, atol=1e-13):
    """Returns (fields, u_S, info) on ``domain``; ``problem``'s c_n and m_n are not used."""
    fields = nc.bind(problem, domain)
    msh = domain.mesh
    V = versions.p1_space(msh, (msh.geometry.dim,))
    u = fem.Function(V, name="signorini")
    v, du = ufl.TestFunction(V), ufl.TrialFunction(V)
    a = fem.form(ufl.inner(nc.sigma(du, fields.lmbda, fields.mu), ufl.sym(ufl.grad(v))) * ufl.dx)
    L = fem.form(external_load(fields, v))
    bcs = fields.boundary_conditions(V)
    K = fem_petsc.assemble_matrix(a, bcs=bcs)
    K.assemble()
    load = fem_petsc.assemble_vector(L)
    load.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    fem_petsc.set_bc(load, bcs)

    # bounds: u_d >= -g_0 (d the vertical axis) at the contact nodes, unbounded elsewhere
    dim, fdim = msh.geometry.dim, msh.topology.dim - 1
    vertical = dim - 1
    tags = domain.facet_tags
    contact_facets = tags.indices[np.isin(tags.values, fields.ids["contact"])]
    Vy, _ = V.sub(vertical).collapse()
    dofs_y, dofs_Vy = fem.locate_dofs_topological((V.sub(vertical), Vy), fdim, contact_facets)
    gap = fem.Function(Vy)  # g_0 at the nodes
    gap.interpolate(fem.Expression(fields.gap, versions.interpolation_points(Vy)))
    normal_check = ufl.FacetNormal(msh)
    ny = fem.assemble_scalar(fem.form(normal_check[vertical] * fields.ds_of("contact")))
    length = fem.assemble_scalar(fem.form(1.0 * fields.ds_of("contact")))
    ny, length = msh.comm.allreduce(ny, MPI.SUM), msh.comm.allreduce(length, MPI.SUM)
    if abs(ny + length) > 1e-10 * length:
        raise ValueError("solve_signorini needs a flat bottom contact boundary (ν = −e_d, d the last axis)")

    lower, upper = versions.petsc_vec(u).duplicate(), versions.petsc_vec(u).duplicate()
    lower.set(PETSc.NINFINITY)
    upper.set(PETSc.INFINITY)
    n_owned = V.dofmap.index_map.size_local * dim
    owned = dofs_y[dofs_y < n_owned]
    lower.array[owned] = -gap.x.array[dofs_Vy[dofs_y < n_owned]]

    def residual(snes, x, b):
        K.mult(x, b)
        b.axpy(-1.0, load)

    def jacobian(snes, x, A, P):
        pass  # K is constant

    b = load.duplicate()
    snes = PETSc.SNES().create(msh.comm)
    snes.setOptionsPrefix("signorini_")
    opts = PETSc.Options("signorini_")
    for key, value in {"snes_type": "vinewtonrsls", "snes_rtol": rtol, "snes_atol": atol, "snes_stol": 0.0,
                       "snes_max_it": 100, "snes_linesearch_type": "basic", "ksp_type": "preonly",
                       "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}.items():
        opts[key] = value
    snes.setFunction(residual, b)
    snes.setJacobian(jacobian, K, K)
    snes.setVariableBounds(lower, upper)
    snes.setFromOptions()
    x = versions.petsc_vec(u).copy()
    x.set(0.0)
    snes.solve(None, x)
    reason = snes.getConvergedReason()
    its = snes.getIterationNumber()
    x.copy(versions.petsc_vec(u))
    u.x.scatter_forward()
    # active set and the contact reaction R = −(K u − L) on the bounded dofs (the discrete multiplier)
    r = load.duplicate()
    K.mult(x, r)
    r.axpy(-1.0, load)
    active_local = int(np.count_nonzero(np.isclose(x.array[owned], lower.array[owned], rtol=0, atol=1e-12)))
    reaction_local = float(np.sum(r.array[owned]))
    info = {"iterations": its, "reason": int(reason), "converged": bool(reason > 0),
            "active": msh.comm.allreduce(active_local, MPI.SUM),
            "contact_nodes": msh.comm.allreduce(len(owned), MPI.SUM),
            "reaction": msh.comm.allreduce(reaction_local, MPI.SUM)}
    for obj in (snes, K, load, lower, upper, b, r, x):
        obj.destroy()
    return fields, u, info
