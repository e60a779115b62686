"""The test suite's oracle of boundary groups: the whole boundary of a mesh gathered on every rank.

A test gathers the level-0 boundary once and checks that every facet of a refined mesh lies in a level-0
simplex of its own group (Plaza refinement only bisects edges, so a descendant of a boundary facet lies
inside it). The package itself never gathers the boundary: it carries groups by the parent maps.
"""
import numpy as np

from nc_dolfinx.mesh.domain import UNTAGGED, owned_exterior_facets
from nc_dolfinx import dolfinx_versions as versions


def gather_boundary(msh, facet_tags):
    """Every owned exterior facet of every rank as (vertices (n, tdim, gdim), ids (n,)), on all ranks
    (``facet_tags``: on the owned exterior facets; ``UNTAGGED`` where a facet has none)."""
    tdim, gdim = msh.topology.dim, msh.geometry.dim
    facets = owned_exterior_facets(msh)
    nodes = versions.entities_to_geometry(msh, tdim - 1, facets)
    vertices = msh.geometry.x[nodes.reshape(-1)][:, :gdim].reshape(len(facets), tdim, gdim)
    ids = np.full(len(facets), UNTAGGED, dtype=np.int32)
    if facet_tags is not None and len(facet_tags.indices):
        position = np.minimum(np.searchsorted(facet_tags.indices, facets), len(facet_tags.indices) - 1)
        tagged = facet_tags.indices[position] == facets
        ids[tagged] = facet_tags.values[position[tagged]]
    gathered = msh.comm.allgather((vertices, ids))
    return (np.concatenate([v for v, _ in gathered]).reshape(-1, tdim, gdim),
            np.concatenate([i for _, i in gathered]).astype(np.int32))
