"""The search for the other body's facets: the closest point Π x on a face spread over the ranks.

Each rank holds its owned facets of the face searched. Every rank publishes one bounding box of them
(nothing of global size: one box per rank). A point is sent only to the ranks whose box may hold its
closest facet: with U the smallest distance from the point to the farthest corner of a box (each box holds
a facet vertex, so the closest facet is no farther than U), the ranks whose box lies within U. Each of those
answers with its own closest facet (exact distances to the facets of the NEAREST midpoints, from a k-d tree:
on a surface mesh the closest facet of a point near the face is among them; of a point farther than a few
facets, a facet as close up to a fraction of a facet's size, where the gap is large anyway), and the asker
keeps the closest answer; ties (a point closest to a shared edge or vertex) go to
the facet with the lowest midpoint, lexicographically, so the result does not depend on the partition.
"""
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
    near = np.sqrt((np.maximum(np.maximum(lo - p, p - hi), 0.0) ** 2).sum(axis=2))  # (n, ranks)
    far = np.sqrt((np.maximum(np.abs(p - lo), np.abs(p - hi)) ** 2).sum(axis=2))
    near[:, empty], far[:, empty] = np.inf, np.inf
    bound = far.min(axis=1, initial=np.inf)
    return near <= bound[:, None] * (1 + 1e-12) + 1e-300


def _closest_on_face(face_, points):
    """This rank's answer for ``points``: (distance, closest point, facet midpoint, dofs, bary, normal)."""
    n, gdim, k = len(points), face_.vertices.shape[2], face_.vertices.shape[1]
    if face_.count == 0 or n == 0:
        return (np.full(n, np.inf), np.zeros((n, gdim)), np.full((n, gdim), np.inf),
                np.zeros((n, k), dtype=np.int64), np.zeros((n, k)), np.zeros((n, gdim)), np.zeros((n, k, gdim)))
    midpoints = face_.vertices.mean(axis=1)
    count = min(NEAREST, face_.count)
    _, facet = cKDTree(midpoints).query(points, k=count)
    owner = np.repeat(np.arange(n), count)
    facet = np.asarray(facet, dtype=np.int64).reshape(-1)
    closest, bary = closest_on_simplices(points[owner], face_.vertices[facet])
    distance = np.linalg.norm(closest - points[owner], axis=1)
    mid = midpoints[facet]
    order = np.lexsort((*mid.T[::-1], distance, owner))  # by point, then distance, then midpoint
    best = order[np.unique(owner[order], return_index=True)[1]]
    return (distance[best], closest[best], mid[best], face_.dofs[facet[best]], bary[best],
            face_.normals[facet[best]], face_.vertices[facet[best]])


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
    if vertices.shape[1] == 2:
        return _closest_on_segments(points, vertices[:, 0], vertices[:, 1])
    a, b, c = vertices[:, 0], vertices[:, 1], vertices[:, 2]
    e1, e2, r = b - a, c - a, points - a
    g11, g12, g22 = (np.einsum("ij,ij->i", u, v) for u, v in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = np.einsum("ij,ij->i", r, e1), np.einsum("ij,ij->i", r, e2)
    det = g11 * g22 - g12 ** 2
    s = (g22 * r1 - g12 * r2) / det
    t = (g11 * r2 - g12 * r1) / det
    bary = np.stack([1 - s - t, s, t], axis=1)
    best = a + s[:, None] * e1 + t[:, None] * e2
    distance = np.where(np.all(bary >= 0, axis=1), np.linalg.norm(best - points, axis=1), np.inf)
    for i, j in ((0, 1), (1, 2), (2, 0)):  # outside the triangle: the closest point is on an edge
        q, lam = _closest_on_segments(points, vertices[:, i], vertices[:, j])
        d = np.linalg.norm(q - points, axis=1)
        better = d < distance
        distance[better], best[better] = d[better], q[better]
        edge_bary = np.zeros((better.sum(), 3))
        edge_bary[:, i], edge_bary[:, j] = lam[better, 0], lam[better, 1]
        bary[better] = edge_bary
    return best, bary


def _closest_on_segments(points, a, b):
    e = b - a
    t = np.clip(np.einsum("ij,ij->i", points - a, e) / np.einsum("ij,ij->i", e, e), 0.0, 1.0)
    return a + t[:, None] * e, np.stack([1 - t, t], axis=1)
