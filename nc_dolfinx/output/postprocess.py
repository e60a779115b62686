"""Fields for output beside the solution and its indicators, and the XDMF files that hold them."""
import numpy as np
import ufl
from dolfinx import fem, io

from .. import dolfinx_versions as versions
from ..physics import elasticity, forms, friction
from ..physics.quantities import contact_projection


def write_xdmf(comm, path, mesh, functions):
    """One XDMF file (one mesh) holding the given functions (collective)."""
    with io.XDMFFile(comm, path, "w") as xdmf:
        xdmf.write_mesh(mesh)
        for fn in functions:
            xdmf.write_function(fn)


def postprocess_fields(u, fields):
    """Stress (3×3: plane strain has σ_zz = λ tr ε), von Mises (DG0) and the nodal contact pressure (P1)."""
    msh = u.function_space.mesh
    T = versions.dg0_space(msh, (3, 3))
    Q = versions.dg0_space(msh)
    stress = _interpolate(T, elasticity.stress_3x3(u, fields.lmbda, fields.mu), "stress")
    vm = _interpolate(Q, elasticity.von_mises(u, fields.lmbda, fields.mu), "von_mises")
    pressure = contact_projection(forms.contact_pressure(u, fields), fields, "contact_pressure")
    return [stress, vm, pressure]


def _interpolate(space, expr, name):
    fn = fem.Function(space, name=name)
    fn.interpolate(fem.Expression(expr, versions.interpolation_points(space)))
    return fn


def friction_fields(u, fields):
    """With friction, on Γ_C (P1, lumped projections, 0 elsewhere): the law's tangential traction s_t (the
    foundation's tangential traction on the body), the slip increment Δu_t over the load increment, and
    ``stick_slip``: 0 out of contact, 1 where the vertex sticks (|s| <= ε_r (u_n − g_0)_+, s the spring's
    slip :func:`~nc_dolfinx.physics.friction.spring_slip`), 2 where it slips. Without friction: an empty list."""
    law = fields.friction
    if law is None:
        return []
    n = ufl.FacetNormal(u.function_space.mesh)
    penetration = forms.penetration(u, fields, n)
    traction = contact_projection(friction.tangential_traction(u, penetration, law), fields, "tangential_traction")
    slip = contact_projection(friction.slip_increment(u, law), fields, "slip")
    spring = contact_projection(friction.spring_slip(u, penetration, law), fields, "spring_slip")
    depth = contact_projection(penetration, fields, "penetration")
    state = fem.Function(depth.function_space, name="stick_slip")
    slip_size = np.linalg.norm(spring.x.array.reshape(-1, fields.dim), axis=1)
    in_contact = depth.x.array > 0
    state.x.array[:] = np.where(in_contact, np.where(slip_size > float(law.epsilon.value) * depth.x.array, 2.0, 1.0),
                                0.0)
    return [traction, slip, state]
