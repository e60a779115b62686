"""Global quantities of a discrete solution: energy, contact force, and errors against an exact solution."""
import numpy as np
import ufl
from mpi4py import MPI

from petsc4py import PETSc

from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc

from . import forms
from . import physics

ERROR_DEGREE = 8


def integrate(expr, comm):
    return comm.allreduce(fem.assemble_scalar(fem.form(expr)), MPI.SUM)


def solution_quantities(u, fields):
    """Elastic energy ½a(u_h, u_h), the normal contact resultant ∫_Γ_C p and the force on the body."""
    comm = fields.domain.comm
    n = ufl.FacetNormal(fields.domain.mesh)
    p = forms.contact_pressure(u, fields, n)
    dC = forms.contact_measure(fields)
    force = [-integrate(p * n[i] * dC, comm) for i in range(fields.dim)]
    penetration = contact_projection(forms.penetration(u, fields, n), fields, "penetration")
    n_owned = penetration.function_space.dofmap.index_map.size_local
    max_penetration = comm.allreduce(float(np.max(penetration.x.array[:n_owned], initial=0.0)), MPI.MAX)
    pressure = contact_projection(p, fields, "contact_pressure")
    max_pressure = comm.allreduce(float(np.max(pressure.x.array[:n_owned], initial=0.0)), MPI.MAX)
    return {
        "max_contact_pressure": max_pressure,
        "elastic_energy": integrate(forms.elastic_energy(u, fields), comm),
        "contact_resultant": integrate(p * dC, comm),
        "contact_force": force,
        # the measure of {p > 0} on Γ_C: a length in 2D, an area in 3D
        "contact_length" if fields.dim == 2 else "contact_area":
            integrate(ufl.conditional(ufl.gt(p, 0), 1.0, 0.0) * dC, comm),
        "max_penetration": max_penetration,
    }


def contact_projection(expr, fields, name):
    """Lumped L² projection of a Γ_C quantity onto P1: q_i = ∫_Γ_C q φ_i / ∫_Γ_C φ_i, zero off Γ_C."""
    V = fem.FunctionSpace(fields.domain.mesh, ("CG", 1))
    v = ufl.TestFunction(V)
    dC = forms.contact_measure(fields)
    num, den = (fem_petsc.assemble_vector(fem.form(q * v * dC)) for q in (expr, 1.0))
    for vec in (num, den):
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    out = fem.Function(V, name=name)
    n_owned = V.dofmap.index_map.size_local
    d = den.array[:n_owned]
    out.x.array[:n_owned] = np.where(d > 0, num.array[:n_owned] / np.where(d > 0, d, 1.0), 0.0)
    out.x.scatter_forward()
    num.destroy()
    den.destroy()
    return out


def errors(u, fields):
    """‖u − u_h‖ in L² and H¹ and the contact-augmented error ẽ of Remark 9."""
    if fields.u_exact is None:
        return {}
    comm = fields.domain.comm
    e = fields.u_exact - u
    dx = ufl.dx(metadata={"quadrature_degree": ERROR_DEGREE})
    l2 = np.sqrt(integrate(ufl.inner(e, e) * dx, comm))
    h1 = np.sqrt(l2 ** 2 + integrate(ufl.inner(ufl.grad(e), ufl.grad(e)) * dx, comm))
    n = ufl.FacetNormal(fields.domain.mesh)
    sigma_n_err = physics.normal_stress(fields.sigma(e), n)
    h_E = ufl.FacetArea(fields.domain.mesh)
    contact = np.sqrt(integrate(h_E * sigma_n_err ** 2 * forms.contact_measure(fields, 16), comm))
    return {"l2_error": l2, "h1_error": h1, "augmented_error": h1 + contact}
