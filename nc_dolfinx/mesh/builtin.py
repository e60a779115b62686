"""The built-in domains: a rectangle (2D) and a box (3D) with their sides as boundary groups.

The sides are tagged geometrically: a facet is in the group of the side (a box face as simplices) that
holds its centroid.
"""
import itertools

import numpy as np

from .. import dolfinx_versions as versions
from ..errors import InputError
from .domain import Domain, region_function, tag_exterior_facets

RECTANGLE_SIDES = {"left": 1, "right": 2, "bottom": 3, "top": 4}
BOX_SIDES = {"left": 1, "right": 2, "front": 3, "back": 4, "bottom": 5, "top": 6}


def rectangle(comm, corners, cells, diagonal="right"):
    """Rectangle whose sides are the groups left/right/bottom/top (ids 1-4), one region 'body' (id 1)."""
    low, high, cells = _axis_aligned_input("rectangle", corners, cells, 2)
    msh = versions.create_rectangle(comm, [low, high], cells, diagonal)
    return _axis_aligned_domain(msh, low, high, RECTANGLE_SIDES)


def box(comm, corners, cells):
    """Box of tetrahedra whose faces are the groups left/right (x = x0/x1), front/back (y = y0/y1) and
    bottom/top (z = z0/z1), ids 1-6; one region 'body' (id 1)."""
    low, high, cells = _axis_aligned_input("box", corners, cells, 3)
    msh = versions.create_box(comm, [low, high], cells)
    return _axis_aligned_domain(msh, low, high, BOX_SIDES)


def _axis_aligned_input(kind, corners, cells, gdim):
    """Checked (low corner, high corner, cell counts) of a rectangle (gdim 2) or box (gdim 3)."""
    axes = "xyz"[:gdim]
    try:
        low, high = (np.array([float(c) for c in corner]) for corner in corners)
        valid = len(corners) == 2 and len(low) == len(high) == gdim and np.all(high > low)
    except (TypeError, ValueError):
        valid = False
    if not valid:
        form = f"[[{', '.join(a + '0' for a in axes)}], [{', '.join(a + '1' for a in axes)}]]"
        raise InputError(f"mesh.{kind} must be {form} with {', '.join(f'{a}1 > {a}0' for a in axes)}, "
                         f"got {corners}")
    if not (isinstance(cells, list) and len(cells) == gdim and all(isinstance(c, int) and c >= 1 for c in cells)):
        raise InputError(f"mesh.cells must be {['two', 'three'][gdim - 2]} positive integers, got {cells}")
    return low, high, [int(c) for c in cells]


def _axis_aligned_domain(msh, low, high, sides):
    msh = versions.with_equispaced_coordinates(msh)
    n_owned = msh.topology.index_map(msh.topology.dim).size_local
    return Domain(msh, tag_exterior_facets(msh, _box_faces(low, high)), region_function(msh, np.ones(n_owned)),
                  dict(sides), {"body": 1})


def _box_faces(low, high):
    """The sides of the axis-aligned box [low, high] as simplices (segments in 2D, two triangles per face
    in 3D), with ids 2·axis + 1 (side at low) and 2·axis + 2 (at high)."""
    gdim = len(low)
    simplices, ids = [], []
    for axis, side in itertools.product(range(gdim), (0, 1)):
        free = [a for a in range(gdim) if a != axis]
        for order in itertools.permutations(free):  # Kuhn's split of the face into simplices
            corners = np.zeros((gdim, gdim), dtype=bool)  # corner j: the first j free axes at high
            for j, a in enumerate(order):
                corners[j + 1:, a] = True
            corners[:, axis] = bool(side)
            simplices.append(np.where(corners, high, low))
            ids.append(2 * axis + side + 1)
    return np.array(simplices, dtype=float), np.array(ids, dtype=np.int32)
