"""Where a pair's integrals are taken: a facet of one face cut where the other face's vertices project onto it.

On a facet F of Γ_A, v(Π x) is linear between the points where Π x crosses a vertex of Γ_B, and has a kink
there. A Gauss rule over F that steps over such a kink is not exact for the pair's term ∫_F p v(Π x)·ν even
where p is uniform, and a uniform pressure across non-matching meshes is then not transmitted exactly (the
contact patch test; measured on the stacked blocks of meshes/two_bodies.py, two half-passes: 2.2e-3 relative
error of the interface pressure with a rule of degree 8 on whole edges). So in 2D each edge of Γ_A is cut at
the orthogonal projections of Γ_B's vertices near it, and the rule is applied on each piece (exact for
affine data: the patch test to round-off). The vertices are found by the search itself: the facets of Γ_B
closest to the rule's points give their vertices, the edge is cut there and searched again, until no new cut
appears (two or three rounds; nothing is exchanged but the search's own messages).

In 3D each triangle near the other face (within its own size) is cut by the other face's triangles that
overlap it, projected onto its plane (Sutherland–Hodgman clipping), and the rule applied on each piece (a fan
of triangles): the patch test to 5e-10 (the pieces' tiling is accepted to 1e-9 of the triangle's area). The
candidates are the other face's triangles facing it within reach (:func:`.search.triangles_over`: across its
normal their bounding spheres come within its own, along it within its distance to the other face plus twice
its diameter), found across ranks as the search finds closest facets (one bounding box per rank), and all
(triangle, candidate) pairs are clipped at once, with numpy over the pairs. A triangle that the pieces do
not tile (the other face ends there, or is not a graph over its plane) keeps a composite rule on
``4^levels`` sub-triangles (``COMPOSITE_LEVELS_3D``), one far from the other face the rule on the whole
triangle.
"""
import numpy as np

from . import search
from .faces import gauss_rule, quadrature_points

MAX_ROUNDS = 4
COMPOSITE_LEVELS_3D = 1
_EPS = 1e-10  # relative to the edge: cuts closer than this to an end or to each other are one


def points_and_projection(comm, own, other, degree, integration="cut"):
    """The integration points of ``own`` and their closest points on ``other``: (x (n, gdim), w (n,), bary
    in their facet (n, k), facet (n,), :class:`~.search.Projection`). ``integration``: "cut" (above),
    "gauss" (the rule on whole facets) or "nodes" (the facets' vertices with a k-th of the facet's measure
    each: a node-to-segment scheme, for comparison)."""
    if integration != "cut":
        x, w, bary, facet = _vertex_points(own) if integration == "nodes" else quadrature_points(own, degree)
        return x, w, bary, facet, search.project(comm, x, other)
    if own.vertices.shape[2] == 3:
        return _clipped_triangles(comm, own, other, degree)
    cuts = [np.zeros(0) for _ in range(own.count)]
    for _ in range(MAX_ROUNDS):
        x, w, bary, facet = _cut_edges(own, degree, cuts)
        projection = search.project(comm, x, other)
        cuts, new = _cuts_from(own, facet, projection, cuts)
        if not comm.allreduce(new):
            return x, w, bary, facet, projection
    x, w, bary, facet = _cut_edges(own, degree, cuts)
    return x, w, bary, facet, search.project(comm, x, other)


def _cut_edges(own, degree, cuts):
    """The rule of ``degree`` on each piece of each edge, cut at ``cuts`` (parameters in (0, 1) per edge)."""
    bary_ref, weights = gauss_rule(2, degree)
    t_ref = bary_ref[:, 1]
    xs, ws, ts, facets = [], [], [], []
    for f in range(own.count):
        ends = np.concatenate([[0.0], cuts[f], [1.0]])
        lengths = np.diff(ends)
        t = (ends[:-1, None] + lengths[:, None] * t_ref[None, :]).ravel()
        ts.append(t)
        ws.append((own.sizes[f] * lengths[:, None] * weights[None, :]).ravel())
        facets.append(np.full(len(t), f))
    t = np.concatenate(ts) if ts else np.zeros(0)
    facet = np.concatenate(facets).astype(np.int64) if facets else np.zeros(0, dtype=np.int64)
    bary = np.stack([1.0 - t, t], axis=1)
    x = np.einsum("nk,nkd->nd", bary, own.vertices[facet]) if len(t) else np.zeros((0, own.vertices.shape[2]))
    return x, (np.concatenate(ws) if ws else np.zeros(0)), bary, facet


def _cuts_from(own, facet, projection, cuts):
    """The cuts of each edge by the vertices of the other face's facets found closest to its points; whether
    any edge got a cut it did not have."""
    a, b = own.vertices[facet, 0], own.vertices[facet, 1]
    edge = b - a
    found = [list(c) for c in cuts]
    new = False
    for j in range(projection.vertices.shape[1]):
        t = np.einsum("nd,nd->n", projection.vertices[:, j] - a, edge) / np.einsum("nd,nd->n", edge, edge)
        inside = (t > _EPS) & (t < 1 - _EPS)
        for f, value in zip(facet[inside], t[inside]):
            if not any(abs(value - c) <= _EPS for c in found[f]):
                found[f].append(value)
                new = True
    return [np.sort(np.array(c)) for c in found], new


def _sub_triangles(levels):
    """The 4^levels sub-triangles of the reference triangle (midpoint subdivision), each by the barycentric
    coordinates of its corners (3, 3)."""
    triangles = [np.eye(3)]
    for _ in range(levels):
        finer = []
        for t in triangles:
            m01, m12, m20 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2
            finer += [np.stack(c) for c in ((t[0], m01, m20), (m01, t[1], m12), (m20, m12, t[2]), (m01, m12, m20))]
        triangles = finer
    return triangles


def _composite_triangles(own, degree, levels):
    """The rule of ``degree`` on each of the 4^levels sub-triangles of each facet (midpoint subdivision)."""
    bary_ref, weights = gauss_rule(3, degree)
    triangles = _sub_triangles(levels)
    sub = np.concatenate([bary_ref @ t for t in triangles])            # (m·s, 3) barycentric in the facet
    sub_w = np.tile(weights / len(triangles), len(triangles))
    n = own.count
    bary = np.tile(sub, (n, 1))
    facet = np.repeat(np.arange(n), len(sub_w))
    x = np.einsum("qk,nkd->nqd", sub, own.vertices).reshape(-1, 3)
    w = (own.sizes[:, None] * sub_w[None, :]).ravel()
    return x, w, bary, facet


def _vertex_points(own):
    """Each facet's vertices as its points, a k-th of its measure each (the lumped, node-to-segment rule)."""
    n, k, gdim = own.vertices.shape
    bary = np.tile(np.eye(k), (n, 1))
    return (own.vertices.reshape(-1, gdim), np.repeat(own.sizes / k, k), bary, np.repeat(np.arange(n), k))


# --- 3D: each triangle of one face cut by the triangles of the other, projected onto its plane -------------

def _clipped_triangles(comm, own, other, degree):
    """3D "cut": each facet T of ``own`` near the other face is cut by the facets S of ``other`` that overlap
    it, projected onto T's plane (Sutherland–Hodgman), and the rule applied on the pieces (fans of triangles);
    a facet that the pieces do not tile (the other face ends, or is not a graph over T's plane) keeps the
    composite rule, one far from the other face (farther than its own size: the law acts nowhere there) the
    rule on the whole facet. The candidates S of a facet are the other face's triangles facing it within
    reach of it (:func:`~.search.triangles_over`: its own distance to the other face and twice its diameter
    along its normal); all pairs are clipped at once (numpy over the pairs). Searches: the whole facets'
    points once (their distance to the other face, and the far facets' projection), the candidates once,
    and the new points once."""
    x, w, bary, facet = quadrature_points(own, degree)
    projection = search.project(comm, x, other)
    distance = np.full(own.count, np.inf)
    np.minimum.at(distance, facet, projection.distance)
    close = distance <= np.sqrt(own.sizes)
    near = np.flatnonzero(close)
    diameter = np.linalg.norm(own.vertices - np.roll(own.vertices, 1, axis=1), axis=2).max(axis=1)
    pair, S = search.triangles_over(comm, own.vertices[near], own.normals[near],
                                    distance[near] + 2 * diameter[near], other)
    pair = near[pair]
    triangles, of = _pieces(own, pair, S)
    area = _areas(triangles)
    covered = np.bincount(of, weights=area, minlength=own.count)
    pieces = np.bincount(of, minlength=own.count)
    tiled = close & (pieces > 0) & (np.abs(covered - own.sizes) <= 1e-9 * own.sizes)
    keep = tiled[of]
    cut = _rule_on(own, degree, triangles[keep], area[keep], of[keep])
    composite = _composite_triangles(own, degree, COMPOSITE_LEVELS_3D)
    composite = tuple(part[(close & ~tiled)[composite[3]]] for part in composite)
    new = tuple(np.concatenate([a, b]) for a, b in zip(cut, composite))
    far = ~close[facet]
    new_projection = search.project(comm, new[0], other)
    parts = [(x[far], w[far], bary[far], facet[far]), new]
    order = np.argsort(np.concatenate([part[3] for part in parts]), kind="stable")
    x, w, bary, facet = (np.concatenate(column)[order] for column in zip(*parts))
    both = search.Projection(*(np.concatenate([getattr(projection, name)[far], getattr(new_projection, name)])[order]
                               for name in ("point", "distance", "dofs", "bary", "normal", "vertices")))
    return x, w, bary, facet.astype(np.int64), both


def _pieces(own, facet, S):
    """The fans of the polygons S (m, 3, 3), projected onto the plane of own's facet ``facet`` (m,), clipped
    by that facet (Sutherland–Hodgman, all pairs at once): (triangles (t, 3, 3), the facet of each (t,))."""
    T, normal = own.vertices[facet], own.normals[facet]
    polygon = S - _rows_dot(S - T[:, None, 0], normal)[:, :, None] * normal[:, None, :]
    count = np.full(len(facet), 3)
    for i in range(3):
        a, b, c = T[:, i], T[:, (i + 1) % 3], T[:, (i + 2) % 3]
        inward = np.cross(normal, b - a)  # T's vertices are not oriented: point it to the third vertex
        inward[np.einsum("md,md->m", inward, c - a) < 0] *= -1.0
        polygon, count = _clip_half(polygon, count, a, inward)
    if polygon.shape[1] < 3:  # (no polygon left with three vertices)
        return np.zeros((0, 3, 3)), np.zeros(0, dtype=np.int64)
    rows, first = np.nonzero(np.arange(polygon.shape[1])[None, :] < (count - 2)[:, None])  # fan triangle (row, i)
    triangles = np.stack([polygon[rows, 0], polygon[rows, first + 1], polygon[rows, first + 2]], axis=1)
    return triangles, facet[rows]


def _clip_half(polygon, count, a, inward):
    """The convex polygons (m, M, 3) of ``count`` vertices each cut to the side of the planes through ``a``
    (m, 3) where ``inward`` (m, 3) points: each vertex kept if inside, and the crossing of each edge that
    crosses, in the order of the vertices (one step of Sutherland–Hodgman)."""
    m, M, _ = polygon.shape
    if M == 0:
        return polygon, count
    j = np.arange(M)
    valid = j[None, :] < count[:, None]
    following = np.where(j[None, :] + 1 < count[:, None], j[None, :] + 1, 0)
    side = _rows_dot(polygon - a[:, None, :], inward)
    inside = side >= 0
    q = np.take_along_axis(polygon, following[:, :, None], axis=1)
    sq = np.take_along_axis(side, following, axis=1)
    keep = valid & inside
    crossing = valid & (inside != (sq >= 0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, side / np.where(crossing, side - sq, 1.0), 0.0)
    candidates = np.stack([polygon, polygon + (q - polygon) * t[:, :, None]], axis=2).reshape(m, 2 * M, 3)
    chosen = np.stack([keep, crossing], axis=2).reshape(m, 2 * M)
    new_count = chosen.sum(axis=1)
    width = int(new_count.max(initial=0))
    out = np.zeros((m, width, 3))
    rows, slots = np.nonzero(chosen)
    out[rows, (np.cumsum(chosen, axis=1) - 1)[rows, slots]] = candidates[rows, slots]
    return out, new_count


def _rows_dot(rows, vector):
    """(m, M) the dot products of the rows of each (M, 3) matrix of ``rows`` with its ``vector`` (m, 3): a
    stack of matrix-vector products, as each pair's own ``rows @ vector`` (the same rounding: which
    vertices a clip keeps hangs on the sign of these, and the fan on which it keeps)."""
    m, M, _ = rows.shape
    if M < 2:  # (a single row would be a dot product, rounded otherwise)
        return _rows_dot(np.concatenate([rows, np.zeros((m, 2 - M, 3))], axis=1), vector)[:, :M]
    return np.matmul(rows, vector[:, :, None])[:, :, 0]


def _areas(triangles):
    """The areas of the triangles (t, 3, 3), rounded as the norm of each one's cross product alone."""
    cross = np.cross(triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0])
    return 0.5 * np.sqrt(np.matmul(cross[:, None, :], cross[:, :, None])[:, 0, 0])


def _rule_on(own, degree, triangles, area, facet):
    """The rule of ``degree`` on each triangle (t, 3, 3) lying in own's facet ``facet`` (t,): (x, w, bary in
    the facet, facet), triangle by triangle. (Rounded as triangle by triangle too: a point on an edge of the
    other face has two closest facets, and its last bits choose which.)"""
    bary_ref, weights = gauss_rule(3, degree)
    m = len(weights)
    x = np.matmul(bary_ref, triangles).reshape(-1, 3)  # (each triangle's bary_ref @ t, rounded as alone)
    w = (area[:, None] * weights[None, :]).ravel()
    point_facet = np.repeat(facet, m)
    return x, w, _barycentric(x, own.vertices[point_facet]), point_facet


def _barycentric(points, T):
    """Barycentric coordinates (n, 3) of points (n, 3) in the plane of the triangles T (n, 3, 3)."""
    e1, e2, r = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0], points - T[:, 0]
    g11, g12, g22 = (np.einsum("nd,nd->n", u, v) for u, v in ((e1, e1), (e1, e2), (e2, e2)))
    r1, r2 = np.einsum("nd,nd->n", r, e1), np.einsum("nd,nd->n", r, e2)
    det = g11 * g22 - g12 ** 2
    s, t = (g22 * r1 - g12 * r2) / det, (g11 * r2 - g12 * r1) / det
    return np.stack([1 - s - t, s, t], axis=1)
