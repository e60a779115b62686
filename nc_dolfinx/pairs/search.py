"""The search for the other body's facets: the closest point Π x on a face spread over the ranks.

Each rank holds its owned facets of the face searched. Every rank publishes one bounding box of them
(nothing of global size: one box per rank). A point is sent only to the ranks whose box may hold its
closest facet: with U the smallest distance from the point to the farthest corner of a box (each box holds
a facet vertex, so the closest facet is no farther than U), the ranks whose box lies within U. Each of those
answers with its own closest facet (the closest of the facets of the NEAREST midpoints, from a k-d tree: on a
surface mesh the closest facet of a point near the face is among them; of a point farther than a few facets,
a facet as close up to a fraction of a facet's size, where the gap is large anyway; exact distances are
computed only to those that may be closer than the facet of the nearest midpoint), and the asker
keeps the closest answer; ties (a point closest to a shared edge or vertex) go to
the facet with the lowest midpoint, lexicographically, so the result does not depend on the partition.
"""
import itertools
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree


NEAREST = 16  # facets whose midpoints are nearest a point: the candidates for its closest facet


@dataclass
class Projection:
    """For n points: the closest point on the face searched, its distance, the facet's vertices' global dof
    blocks and the point's barycentric coordinates there, and the facet's outward normal."""
    point: np.ndarray      # (n, gdim)
    distance: np.ndarray   # (n,)
    dofs: np.ndarray       # (n, k) global dof blocks
    bary: np.ndarray       # (n, k)
    normal: np.ndarray     # (n, gdim)
    vertices: np.ndarray   # (n, k, gdim) the closest facet's vertices


def project(comm, points, face_):
    """Π of ``points`` (n, gdim), this rank's, onto ``face_`` (each rank passes its owned facets of it)."""
    gdim = points.shape[1] if len(points) else face_.vertices.shape[2]
    boxes = np.array(comm.allgather(_box(face_, gdim)))  # (ranks, 2, gdim)
    destinations = _candidate_ranks(points, boxes)
    sent = [np.flatnonzero(destinations[:, r]) for r in range(comm.size)]
    received = comm.alltoall([points[index] for index in sent])
    answers = comm.alltoall([_closest_on_face(face_, asked) for asked in received])
    return _closest_of_answers(points, sent, answers, face_.vertices.shape[1])


def _box(face_, gdim):
    if face_.count == 0:
        return np.stack([np.full(gdim, np.inf), np.full(gdim, -np.inf)])
    flat = face_.vertices.reshape(-1, gdim)
    return np.stack([flat.min(axis=0), flat.max(axis=0)])


def _candidate_ranks(points, boxes):
    """(n, ranks) booleans: the ranks whose box may hold the closest facet of each point."""
    lo, hi = boxes[:, 0], boxes[:, 1]
    empty = ~np.all(np.isfinite(lo), axis=1)
    p = points[:, None, :]
    near = _box_distances(points, boxes)  # (n, ranks)
    far = np.sqrt((np.maximum(np.abs(p - lo), np.abs(p - hi)) ** 2).sum(axis=2))
    near[:, empty], far[:, empty] = np.inf, np.inf
    bound = far.min(axis=1, initial=np.inf)
    return near <= bound[:, None] * (1 + 1e-12) + 1e-300


def _box_distances(points, boxes):
    """(n, ranks) the distance from each point to each rank's box."""
    p = points[:, None, :]
    return np.sqrt((np.maximum(np.maximum(boxes[:, 0] - p, p - boxes[:, 1]), 0.0) ** 2).sum(axis=2))


def _closest_on_face(face_, points):
    """This rank's answer for ``points``: (distance, closest point, facet midpoint, dofs, bary, normal, vertices).

    The closest of the facets of the NEAREST midpoints, as if the exact distance to each were computed, but
    computed only where it may win: first to the facet of the nearest midpoint (d₀), then to those of the
    others that may come within d₀ of the point: a facet lies in its plane within its bounding circle (its
    midpoint, the largest distance to a vertex), no nearer than the point's distance to that disc; a few a
    point instead of NEAREST."""
    n, gdim, k = len(points), face_.vertices.shape[2], face_.vertices.shape[1]
    if face_.count == 0 or n == 0:
        return (np.full(n, np.inf), np.zeros((n, gdim)), np.full((n, gdim), np.inf),
                np.zeros((n, k), dtype=np.int64), np.zeros((n, k)), np.zeros((n, gdim)), np.zeros((n, k, gdim)))
    midpoints, radius = _spheres(face_)
    count = min(NEAREST, face_.count)
    reach, facet = cKDTree(midpoints).query(points, k=count)
    reach, facet = reach.reshape(n, count), np.asarray(facet, dtype=np.int64).reshape(n, count)
    first_point, first_bary, first = _closest(points, face_.vertices[facet[:, 0]])
    bound = first * (1 + 1e-9)
    r = radius[facet[:, 1:]]
    row, column = np.nonzero(reach[:, 1:] - r <= bound[:, None] + 1e-9 * r)  # within the bounding sphere
    column += 1
    other, r = facet[row, column], radius[facet[row, column]]
    height = np.einsum("nd,nd->n", points[row] - midpoints[other], face_.normals[other])
    across = np.sqrt(np.maximum(reach[row, column] ** 2 - height ** 2, 0.0))
    below = np.sqrt(height ** 2 + np.maximum(across - r, 0.0) ** 2)  # no point of the facet is nearer
    maybe = below <= bound[row] + 1e-9 * r
    row, column = row[maybe], column[maybe]
    point, bary, near = _closest(points[row], face_.vertices[facet[row, column]])
    distance = np.full((n, count), np.inf)
    distance[:, 0] = first
    distance[row, column] = near
    where = np.full((n, count), -1, dtype=np.int64)  # the index of each evaluated candidate's closest point
    where[:, 0] = np.arange(n)
    where[row, column] = n + np.arange(len(row))
    point, bary = np.concatenate([first_point, point]), np.concatenate([first_bary, bary])
    best = np.argmin(distance, axis=1)
    tied_row, tied_column = np.nonzero(distance == distance[np.arange(n), best][:, None])
    if len(tied_row) > n:  # a point closest to an edge or vertex shared by facets: the lowest midpoint wins
        mid = midpoints[facet[tied_row, tied_column]]
        order = np.lexsort((*mid.T[::-1], tied_row))
        first_of_row = order[np.unique(tied_row[order], return_index=True)[1]]
        best[tied_row[first_of_row]] = tied_column[first_of_row]
    chosen = facet[np.arange(n), best]
    at = where[np.arange(n), best]
    return (distance[np.arange(n), best], point[at], midpoints[chosen], face_.dofs[chosen], bary[at],
            face_.normals[chosen], face_.vertices[chosen])


def _closest_of_answers(points, sent, answers, k):
    n, gdim = points.shape
    distance = np.full(n, np.inf)
    mid = np.full((n, gdim), np.inf)
    result = Projection(np.zeros((n, gdim)), distance, np.zeros((n, k), dtype=np.int64), np.zeros((n, k)),
                        np.zeros((n, gdim)), np.zeros((n, k, gdim)))
    for index, (d, point, m, dofs, bary, normal, vertices) in zip(sent, answers):
        better = (d < distance[index]) | ((d == distance[index]) & _lexicographically_less(m, mid[index]))
        chosen = index[better]
        distance[chosen], mid[chosen] = d[better], m[better]
        result.point[chosen], result.dofs[chosen] = point[better], dofs[better]
        result.bary[chosen], result.normal[chosen] = bary[better], normal[better]
        result.vertices[chosen] = vertices[better]
    return result


def _lexicographically_less(a, b):
    less = np.zeros(len(a), dtype=bool)
    equal = np.ones(len(a), dtype=bool)
    for i in range(a.shape[1]):
        less |= equal & (a[:, i] < b[:, i])
        equal &= a[:, i] == b[:, i]
    return less


def closest_on_simplices(points, vertices):
    """The closest point of each simplex (n, k, gdim) — a segment (k = 2) or a triangle (k = 3) — to each
    point (n, gdim), pairwise, and its barycentric coordinates (n, k)."""
    best, bary, _ = _closest(points, vertices)
    return best, bary


EDGE_SLACK = 1e-6  # a point projecting inside a triangle by more than this (barycentric) is nearest inside


def _closest(points, vertices):
    """:func:`closest_on_simplices` and the distances (n,). A point whose projection falls outside the
    triangle, or inside by less than ``EDGE_SLACK``, is also tried on the three edges (the nearest wins);
    one inside by more is nearer its projection than any edge point (but by round-off, far away)."""
    if vertices.shape[1] == 2:
        best, bary = _closest_on_segments(points, vertices[:, 0], vertices[:, 1])
        return best, bary, _norms(best - points)
    a, b, c = vertices[:, 0], vertices[:, 1], vertices[:, 2]
    e1, e2, r = b - a, c - a, points - a
    g11, g12, g22 = (np.einsum("ij,ij->i", u, v) for u, v in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = np.einsum("ij,ij->i", r, e1), np.einsum("ij,ij->i", r, e2)
    det = g11 * g22 - g12 ** 2
    s = (g22 * r1 - g12 * r2) / det
    t = (g11 * r2 - g12 * r1) / det
    bary = np.stack([1 - s - t, s, t], axis=1)
    best = a + s[:, None] * e1 + t[:, None] * e2
    lowest = bary.min(axis=1)
    distance = np.where(lowest >= 0, _norms(best - points), np.inf)
    edge = np.flatnonzero(lowest < EDGE_SLACK)
    p, d_edge = points[edge], distance[edge]
    for i, j in ((0, 1), (1, 2), (2, 0)):  # outside the triangle: the closest point is on an edge
        q, lam = _closest_on_segments(p, vertices[edge, i], vertices[edge, j])
        d = _norms(q - p)
        better = d < d_edge
        chosen = edge[better]
        d_edge[better] = d[better]
        distance[chosen], best[chosen] = d[better], q[better]
        edge_bary = np.zeros((len(chosen), 3))
        edge_bary[:, i], edge_bary[:, j] = lam[better, 0], lam[better, 1]
        bary[chosen] = edge_bary
    return best, bary, distance


def _norms(v):
    """The Euclidean norms of the rows of v (n, gdim), as np.linalg.norm(v, axis=1) rounds them."""
    square = v * v
    total = square[:, 0] + square[:, 1]
    for i in range(2, v.shape[1]):
        total = total + square[:, i]
    return np.sqrt(total)


def _closest_on_segments(points, a, b):
    e = b - a
    t = np.minimum(np.maximum(np.einsum("ij,ij->i", points - a, e) / np.einsum("ij,ij->i", e, e), 0.0), 1.0)
    return a + t[:, None] * e, np.stack([1 - t, t], axis=1)


# --- the other face's triangles over a triangle (3D): the candidates of segments' clipping -----------------

def triangles_over(comm, triangles, normals, depth, face_):
    """For each of this rank's ``triangles`` (n, 3, 3) with unit normal ``normals`` (n, 3): the triangles S
    of ``face_`` (each rank passes its owned facets) that may overlap it seen along its normal and lie
    within ``depth`` (n,) of its plane, facing it (ν·ν_S < 0): S's bounding sphere (midpoint, largest
    distance to a vertex) within the triangle's own (about its centroid) across the normal, and within
    ``depth`` of the plane along it. Returns (triangle index (m,), S's vertices (m, 3, 3)), ordered by
    triangle, then by S's midpoint (lexicographically): the same on any number of ranks.

    As :func:`project`: every rank publishes one bounding box of its facets (and their largest sphere); a
    triangle is sent only to the ranks whose box comes within its reach."""
    n = len(triangles)
    centre = triangles.mean(axis=1) if n else np.zeros((0, 3))
    radius = np.sqrt(((triangles - centre[:, None, :]) ** 2).sum(axis=2).max(axis=1)) if n else np.zeros(0)
    own_midpoints, own_radius = _spheres(face_)
    published = comm.allgather((_box(face_, 3), float(own_radius.max(initial=0.0))))
    boxes = np.array([box for box, _ in published])
    largest = np.array([r for _, r in published])
    reach = (radius + depth)[:, None] + 2 * largest[None, :]
    destinations = (_box_distances(centre, boxes) <= reach * (1 + 1e-9)) & np.all(np.isfinite(boxes[:, 0]), axis=1)
    sent = [np.flatnonzero(destinations[:, r]) for r in range(comm.size)]
    received = comm.alltoall([(centre[i], radius[i], normals[i], depth[i]) for i in sent])
    answers = comm.alltoall([_over(face_, own_midpoints, own_radius, *asked) for asked in received])
    index = np.concatenate([sent[r][local] for r, (local, _, _) in enumerate(answers)]).astype(np.int64)
    vertices = np.concatenate([v for _, v, _ in answers]) if answers else np.zeros((0, 3, 3))
    mid = np.concatenate([m for _, _, m in answers]) if answers else np.zeros((0, 3))
    order = np.lexsort((*mid.T[::-1], index))
    return index[order], vertices[order].reshape(-1, 3, 3)


def _spheres(face_):
    """Each facet's midpoint and the largest distance from it to a vertex."""
    if face_.count == 0:
        return np.zeros((0, face_.vertices.shape[2])), np.zeros(0)
    midpoints = face_.vertices.mean(axis=1)
    return midpoints, np.sqrt(((face_.vertices - midpoints[:, None, :]) ** 2).sum(axis=2).max(axis=1))


SIZE_CLASSES = 2.0  # facets grouped by radius within this factor: one k-d tree each (graded meshes)


def _over(face_, midpoints, radius, centre, own_radius, normal, depth):
    """This rank's answer of :func:`triangles_over`: (asked index (m,), S's vertices (m, 3, 3), S's midpoint)."""
    if face_.count == 0 or len(centre) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros((0, 3, 3)), np.zeros((0, 3))
    size_class = np.floor(np.log(radius / radius.min()) / np.log(SIZE_CLASSES)).astype(np.int64)
    asked, found = [], []
    for c in np.unique(size_class):
        members = np.flatnonzero(size_class == c)
        lists = cKDTree(midpoints[members]).query_ball_point(
            centre, (own_radius + depth + 2 * radius[members].max()) * (1 + 1e-9))
        lengths = np.fromiter((len(a) for a in lists), dtype=np.int64, count=len(lists))
        asked.append(np.repeat(np.arange(len(centre)), lengths))
        found.append(members[np.fromiter(itertools.chain.from_iterable(lists), dtype=np.int64,
                                          count=int(lengths.sum()))])
    asked, found = np.concatenate(asked), np.concatenate(found)
    offset = midpoints[found] - centre[asked]
    along = np.einsum("ij,ij->i", offset, normal[asked])
    across = np.sqrt(np.maximum((offset ** 2).sum(axis=1) - along ** 2, 0.0))
    r = radius[found]
    keep = ((across <= (own_radius[asked] + r) * (1 + 1e-9)) & (np.abs(along) <= (depth[asked] + r) * (1 + 1e-9))
            & (np.einsum("ij,ij->i", face_.normals[found], normal[asked]) < 0))
    asked, found = asked[keep], found[keep]
    return asked, face_.vertices[found], midpoints[found]
