"""The geometric term: how far the discrete boundary Γ_C ∪ Γ_N lies from the true one.

Definition 5 estimates the error of (7) *on the mesh's own body*: on a faceted approximation Ω_h of a curved
body Ω its η measures u_h against the solution on Ω_h, and falls to zero while u_h converges to the wrong body
(a coarse ball refined without its shape converges to a flat punch). The term below measures what η cannot:

    η_geo,K² = Σ_{F ⊂ ∂K ∩ (Γ_C ∪ Γ_N)} δ_F ‖σ(u_h)‖²_F,

δ_F the largest distance of the facet F from the true surface of its group (:func:`nc_dolfinx.mesh.shape.
facet_sag`: the chord's sag, ≈ h_F²/8R on a curve of radius R whose vertices lie on it; the level-0 facets'
sag, which refinement never reduces, for a group given no shape). It is the energy, times E, of the sliver
of thickness δ_F between Ω_h and Ω under F loaded by the stress next to it: the square of a term with the
units of the η_iK (stress × length^{d/2}), computed from the same σ(u_h) (constant on each cell for P1).

What it rests on, and what is not proved: residual estimators on curved domains carry a term for the
boundary approximation whose size is the distance between the boundaries (Dörfler & Rumpf, Math. Comp. 67,
1998; Bartels, Carstensen & Dolzmann, Numer. Math. 99, 2004, for domains approximated by polygons); this
weighting follows their scaling, δ_F^{1/2} times a boundary stress, but the paper's Theorems 6 and 7 are
proved on polygonal domains only and no theorem here bounds the error on Ω by η and η_geo. It is reported
(column ``eta_geometry``, DG0 field ``eta_geometry``) beside η, not inside it, and it joins η_K² in the
marking, so that refinement goes where the geometry is coarse too; ``geometry_sag`` is the largest δ_F.
"""
import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem

from ..mesh import shape
from ..mesh.domain import cell_space, cells_of_facets


def geometric_form(u, fields):
    """(the form of η_geo,K² against the DG0 test function of ``Q``, ``Q``; the largest δ_F over Γ_C ∪ Γ_N,
    the same on every rank); the form is None where every facet there is flat (nothing to assemble)."""
    domain = fields.domain
    msh, comm = domain.mesh, domain.comm
    groups = tuple(fields.ids["contact"]) + tuple(fields.ids["neumann"])
    tags = domain.facet_tags
    on = np.isin(tags.values, groups)
    facets, facet_groups = tags.indices[on], tags.values[on]
    sag = shape.facet_sag(domain, facets, facet_groups)
    largest = comm.allreduce(float(sag.max()) if len(sag) else 0.0, MPI.MAX)
    Q = cell_space(msh)
    if largest == 0.0:
        return None, Q, 0.0
    delta = fem.Function(cell_space(msh))  # δ_K at the (local) cell of each facet this rank integrates
    _, cells, _ = cells_of_facets(msh, facets)
    np.maximum.at(delta.x.array, cells, sag)
    s = fields.sigma(u)  # constant on each cell (P1): a one-point rule is exact
    form = delta * ufl.inner(s, s) * ufl.TestFunction(Q) * fields.ds(groups, metadata={"quadrature_degree": 0})
    return form, Q, largest
