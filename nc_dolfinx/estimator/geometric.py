"""The geometric term: how far the discrete boundary Γ_C ∪ Γ_N (and the faces of [[pairs]]) lies from the true one.

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
import dolfinx
import numpy as np
import ufl
from mpi4py import MPI

from .. import dolfinx_versions as versions
from ..mesh import shape
from ..mesh.domain import cell_space, cells_of_facets
from .geometry import owned_values_with_ghosts


def geometric_term(u, fields):
    """(η_geo,K² on the owned cells, the largest δ_F over Γ_C ∪ Γ_N, the same on every rank); zeros, and no
    assembly, where every facet there is flat. σ(u_h) is constant on each cell (P1), so each facet's term is
    δ_F |F| |σ_K|² with |σ_K|² = ∫_K |σ|² / |K| from one cellwise assembly; a facet's term goes to its cell
    (a ghost's to the owner): per facet, since a cell may have facets of several groups."""
    from .indicators import assemble_cellwise  # (indicators imports this module)
    domain = fields.domain
    msh, comm = domain.mesh, domain.comm
    tdim = msh.topology.dim
    cells_map = msh.topology.index_map(tdim)
    groups = tuple(fields.ids["contact"]) + tuple(fields.ids["neumann"]) + tuple(i for pair in fields.pairs
                                                                               for i in pair.ids)
    tags = domain.facet_tags
    on = np.isin(tags.values, groups)
    facets = tags.indices[on]
    sag = shape.facet_sag(domain, facets, tags.values[on])
    largest = comm.allreduce(float(sag.max()) if len(sag) else 0.0, MPI.MAX)
    if largest == 0.0:
        return np.zeros(cells_map.size_local), 0.0
    Qv, s = cell_space(msh, 2), fields.sigma(u)
    w = ufl.TestFunction(Qv)
    volume_and_energy = assemble_cellwise((w[0] + ufl.inner(s, s) * w[1]) * ufl.dx(metadata={"quadrature_degree": 0}), Qv)
    stress_squared = owned_values_with_ghosts(cell_space(msh), volume_and_energy[:, 1] / volume_and_energy[:, 0])
    _, cells, _ = cells_of_facets(msh, facets)
    per_cell = dolfinx.la.vector(cells_map, 1)  # zeros, ghosts included
    np.add.at(per_cell.array, cells, sag * facet_measures(msh, facets) * stress_squared.x.array[cells])
    per_cell.scatter_reverse(versions.SCATTER_ADD)
    return per_cell.array[:cells_map.size_local].copy(), largest


def facet_measures(msh, facets):
    """|F| of local facets: the length of an edge, the area of a triangle."""
    x = shape.facet_points(msh, facets)
    if msh.topology.dim == 2:
        return np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
    return 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
