"""Fields for output beside the solution and its indicators, and the XDMF files that hold them."""
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
    """With friction, the law at the vertices of Γ_C, where it is evaluated (:func:`~nc_dolfinx.physics.
    forms.law_measure`; P1, nodal values, 0 elsewhere): its tangential traction s_t (the foundation's on the
    body), its bound F = μ c_n (u·N − g̃_0)_+^{m_n} in Coulomb's case (``friction_bound``), the slip
    increment Δu_t over the load increment, and ``stick_slip``: 0 where the vertex is out of contact
    ((u·N − g̃_0)_+ = 0), 2 where it slips by the law's own test |s| > ε_r (u·N − g̃_0)_+ (s the spring's
    slip :func:`~nc_dolfinx.physics.friction.spring_slip`; then |s_t| = F), 1 where it sticks (|s_t| ≤ F):
    the state and the traction written beside it are the same evaluation of the law, so they cannot
    disagree. Without friction: an empty list."""
    law = fields.friction
    if not fields.friction_on_foundation():
        return []
    depth = forms.law_penetration(u, fields, law.normal)
    traction = friction.at_vertices(friction.tangential_traction(u, depth, law), law, "tangential_traction")
    bound = friction.at_vertices(friction.friction_bound(depth, law), law, "friction_bound")
    slip = friction.at_vertices(friction.slip_increment(u, law), law, "slip")
    in_contact = ufl.conditional(ufl.gt(depth, 0), 1.0, 0.0)
    state = friction.at_vertices(in_contact + friction.slipping(u, depth, law), law, "stick_slip")
    return [traction, bound, slip, state]


def pair_fields(u, fields):
    """With [[pairs]], the pressure on both faces of every pair (``pair_pressure``, P1: the nodal mean
    Σ_q w_q λ_i p_q / Σ_q w_q λ_i over the pair's integration points, 0 off the faces) and the body of every
    owned cell (an integer array, 0, 1, … as :mod:`nc_dolfinx.pairs.bodies` numbers them). Without: [], None."""
    if not fields.pairs:
        return [], None
    import numpy as np
    from ..mesh.domain import dof_of_node
    coupling = fields.pair_coupling(u)
    p = coupling.pressure()
    msh = u.function_space.mesh
    Q = versions.p1_space(msh)
    total, weight = fem.Function(Q, name="pair_pressure"), fem.Function(Q)
    at_node = dof_of_node(Q)
    for rows, where in coupling.by_rows():
        dofs = at_node[rows.face.nodes[rows.facet]].ravel()
        share = rows.measure[:, None] * rows.bary
        np.add.at(total.x.array, dofs, (share * p[where][:, None]).ravel())
        np.add.at(weight.x.array, dofs, share.ravel())
    for fn in (total, weight):
        fn.x.scatter_reverse(versions.SCATTER_ADD)
    seen = weight.x.array > 0
    total.x.array[seen] /= weight.x.array[seen]
    total.x.scatter_forward()
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    return [total, *_pair_friction_fields(u, coupling)], fields.bodies.of_cell[:n_owned].astype(np.int32)


def _pair_friction_fields(u, coupling):
    """With friction between pairs, the law at the faces' vertices (:mod:`nc_dolfinx.pairs.friction`; P1,
    nodal values, 0 elsewhere): ``pair_traction`` (σ_t on each face's own body) and ``pair_stick_slip``
    (0 out of contact, 1 stick, 2 slip, as the foundation's ``stick_slip``)."""
    if coupling.friction is None:
        return []
    traction = coupling.friction.write_traction(fem.Function(u.function_space, name="pair_traction"))
    state = fem.Function(versions.p1_space(u.function_space.mesh), name="pair_stick_slip")
    for rows, _, active, sticking, _ in coupling.friction.vertex_states():
        state.x.array[rows.local] = active * (2.0 - sticking)
    state.x.scatter_forward()
    return [traction, state]
