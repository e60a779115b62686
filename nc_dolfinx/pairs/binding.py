"""[[pairs]] bound to a mesh: the faces' groups, the bodies they lie on, and the checks that need the mesh.

Bodies are the mesh's connected parts (:mod:`.bodies`). A pair's two faces must each lie on one body, and
on two different ones. With pairs, every body must be held by its own supports (Dirichlet groups, symmetry
planes): a body held by nothing but its contacts is refused, naming it and what it leaves free.
"""
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from .. import dolfinx_versions as versions
from ..errors import InputError
from ..mesh.domain import global_bounds
from ..physics import rigid
from .bodies import body_names, body_of_cells, body_of_vertices
from .coupling import Pair
from .faces import DEFAULT_DEGREE


@dataclass
class Bodies:
    """The connected parts of a mesh: the body of each local cell and each body's name."""
    of_cell: np.ndarray
    names: list


def find_bodies(domain):
    """The :class:`Bodies` of ``domain``."""
    of_vertex, count = body_of_vertices(domain.mesh)
    of_cell = body_of_cells(domain.mesh, of_vertex)
    return Bodies(of_cell, body_names(domain, of_cell, count))


def bind_pairs(problem, domain, fields, group_id, counts):
    """fields.pairs (:class:`Pair` each) and fields.bodies, checked against the mesh."""
    values = problem.values["pairs"]
    if not values:
        return
    fields.bodies = find_bodies(domain)
    for number, given in enumerate(values, 1):
        ids = tuple(group_id(domain, name, f"pairs[{number}].faces") for name in given["faces"])
        for name, i in zip(given["faces"], ids):
            if counts.get(i, 0) == 0:
                raise InputError(f"pairs[{number}].faces: group '{name}' has no boundary facet")
        bodies = tuple(_body_of_group(domain, fields.bodies, i, name, number) for name, i in zip(given["faces"], ids))
        if bodies[0] == bodies[1]:
            raise InputError(f"pairs[{number}]: faces '{given['faces'][0]}' and '{given['faces'][1]}' are both on "
                             f"body '{fields.bodies.names[bodies[0]]}': a pair joins two bodies")
        degree = given["quadrature_degree"] or DEFAULT_DEGREE[domain.mesh.geometry.dim]
        fields.pairs.append(Pair(number, tuple(given["faces"]), ids,
                                 tuple(fields.bodies.names[b] for b in bodies), given["c_n"], float(given["m_n"]),
                                 float(given["offset"]), given["passes"], int(degree), given["integration"],
                                 given["search_distance"],
                                 dict(problem.parameters), given["friction"]))
    _check_each_body_held(fields)


def _body_of_group(domain, bodies, group_id, name, number):
    tags = domain.facet_tags
    facets = tags.indices[tags.values == group_id]
    tdim = domain.tdim
    domain.mesh.topology.create_connectivity(tdim - 1, tdim)
    f2c = domain.mesh.topology.connectivity(tdim - 1, tdim)
    cells = f2c.array[f2c.offsets[facets]] if len(facets) else np.zeros(0, dtype=np.int32)
    local = set(np.unique(bodies.of_cell[cells]).tolist())
    found = sorted(set().union(*domain.comm.allgather(local)))
    if len(found) != 1:
        raise InputError(f"pairs[{number}].faces: group '{name}' lies on {len(found)} bodies "
                         f"({', '.join(bodies.names[b] for b in found)}): a face is on one body")
    return found[0]


def _check_each_body_held(fields):
    """Each body's rigid motions held by its own Dirichlet groups and symmetry planes (:mod:`..physics.rigid`)."""
    domain, bodies = fields.domain, fields.bodies
    supports = [(i, fields.held_components(i)) for i in fields.ids["dirichlet"]]
    supports += [(i, (axis,)) for i, axis in fields.symmetry_axes.items()]
    for b, name in enumerate(bodies.names):
        points = _body_vertices(domain, bodies, b)
        low, high = global_bounds(domain.comm, points if len(points) else np.zeros((0, fields.dim)))
        centre, scale = 0.5 * (low + high), 0.5 * float(np.max(high - low))
        held = [(_body_vertices(domain, bodies, b, i), components) for i, components in supports]
        free = rigid.free_motions(rigid.gram_matrix(held, centre, scale, domain.comm))
        if free.shape[1]:
            raise InputError(f"body '{name}' is held by nothing but its contacts: no support holds "
                             f"{', '.join(rigid.describe_all(free, centre, scale))} (give it a Dirichlet group or "
                             "a symmetry plane: bodies held by contact alone are not supported with [[pairs]])")


def _body_vertices(domain, bodies, body, group_id=None):
    """Coordinates of the vertices of ``body``'s owned cells, or of its owned facets in group ``group_id``."""
    msh, tdim = domain.mesh, domain.tdim
    gdim = msh.geometry.dim
    if group_id is None:
        n_owned = msh.topology.index_map(tdim).size_local
        cells = np.flatnonzero(bodies.of_cell[:n_owned] == body).astype(np.int32)
        nodes = versions.entities_to_geometry(msh, tdim, cells)
    else:
        tags = domain.facet_tags
        facets = tags.indices[tags.values == group_id]
        msh.topology.create_connectivity(tdim - 1, tdim)
        f2c = msh.topology.connectivity(tdim - 1, tdim)
        cells = f2c.array[f2c.offsets[facets]] if len(facets) else np.zeros(0, dtype=np.int32)
        nodes = versions.entities_to_geometry(msh, tdim - 1, facets[bodies.of_cell[cells] == body])
    return msh.geometry.x[np.unique(nodes.ravel()), :gdim]
