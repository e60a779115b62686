"""Fields for output beside the solution and its indicators, and the XDMF files that hold them."""
from dolfinx import fem, io

from .. import dolfinx_versions as versions
from ..physics import elasticity, forms
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
