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
overlapping triangles are found by the search too (those closest to the rule's points, then a flood from them
across their edges and vertices until the pieces tile the triangle). A triangle that the pieces do not tile
(the other face ends there, or is not a graph over its plane) and one far from the other face keep a
composite rule on ``4^levels`` sub-triangles (``COMPOSITE_LEVELS_3D``).
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
    rule on the whole facet. Searches: the whole facets' points once, the probes of the facets not yet tiled
    in each round (few), and the final points once."""
    x, _, _, facet = quadrature_points(own, degree)
    projection = search.project(comm, x, other)
    distance = np.full(own.count, np.inf)
    np.minimum.at(distance, facet, projection.distance)
    close = distance <= np.sqrt(own.sizes)
    near = [dict() for _ in range(own.count)]
    _collect(near, facet[close[facet]], projection.vertices[close[facet]])
    pieces, waiting = {}, np.flatnonzero(close)
    for _ in range(MAX_ROUNDS):
        for f in waiting:
            pieces[f] = _tiling(own, f, near[f])
        waiting = [f for f in waiting if pieces[f] is None]
        # where the pieces leave a gap, a triangle of the other face overlaps only a sliver: look closer
        probes, probe_facet = _probes(own, waiting, near)
        new = _collect(near, probe_facet, search.project(comm, probes, other).vertices)
        if not comm.allreduce(new):
            break
    for f in waiting:
        pieces[f] = _tiling(own, f, near[f])
    x, w, bary, facet = _points(own, degree, close, pieces)
    return x, w, bary, facet, search.project(comm, x, other)


def _tiling(own, f, candidates):
    """The triangles (a list of (3, 3)) that the candidates cut facet ``f`` into, or None if they do not tile it."""
    T, normal = own.vertices[f], own.normals[f]
    inward = _inward_normals(T, normal)
    triangles = [t for S in candidates.values() for t in _fan(_clip(_onto_plane(S, T, normal), T, inward))]
    area = sum(0.5 * np.linalg.norm(_cross(t[1] - t[0], t[2] - t[0])) for t in triangles)
    return triangles if triangles and abs(area - own.sizes[f]) <= 1e-9 * own.sizes[f] else None


def _points(own, degree, close, pieces):
    """The rule on the pieces of every tiled facet, the composite rule on the other close ones, the rule on
    the whole facet on the far ones."""
    bary_ref, weights = gauss_rule(3, degree)
    whole = quadrature_points(own, degree)
    composite = _composite_triangles(own, degree, COMPOSITE_LEVELS_3D)
    parts = []
    for f in range(own.count):
        triangles = pieces.get(f)
        if triangles is None:
            rule = composite if close[f] else whole
            mine = rule[3] == f
            parts.append(tuple(part[mine] for part in rule))
            continue
        points = np.concatenate([bary_ref @ t for t in triangles])
        areas = [0.5 * np.linalg.norm(_cross(t[1] - t[0], t[2] - t[0])) for t in triangles]
        parts.append((points, np.concatenate([a * weights for a in areas]), _barycentric(points, own.vertices[f]),
                      np.full(len(points), f)))
    if not parts:
        return np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    x, w, bary, facet = (np.concatenate(column) for column in zip(*parts))
    return x, w, bary, facet.astype(np.int64)


PROBE_STEP = 1e-3  # how far beyond a candidate's edge or vertex (relative) its neighbours are looked for


def _probes(own, facets, near):
    """Points just beyond the edges and vertices of the candidates of the given facets (those whose pieces
    leave a gap): their closest facets of the other face are the candidates' neighbours, which overlap the
    facet where the candidates leave it uncovered (a flood over the other face, from one round to the next)."""
    points, owner = [], []
    for f in facets:
        for S in near[f].values():
            centre = S.mean(axis=0)
            corners = np.concatenate([S, 0.5 * (S + np.roll(S, -1, axis=0))])  # vertices, edge midpoints
            points.append(corners + PROBE_STEP * (corners - centre))
            owner.append(np.full(len(corners), f))
    if not points:
        return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
    return np.concatenate(points), np.concatenate(owner)


def _collect(near, facet, vertices):
    """Add to each facet's candidates the other face's triangles found closest to its points; whether any
    facet got a new one."""
    new = False
    keys = np.round(vertices.reshape(vertices.shape[0], vertices.shape[1] * vertices.shape[2]), 12)
    for f, key, triangle in zip(facet, map(tuple, keys), vertices):
        if key not in near[f]:
            near[f][key] = triangle
            new = True
    return new


def _onto_plane(S, T, normal):
    """The vertices of S moved along ``normal`` into the plane of T."""
    return S - np.outer((S - T[0]) @ normal, normal)


def _cross(a, b):
    """a × b of two 3-vectors (np.cross costs 40 µs a call: this is the inner loop)."""
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _inward_normals(T, normal):
    """For each edge i (T[i] → T[i+1]) of the triangle T, a vector in its plane normal to it, into T."""
    inward = []
    for i in range(3):
        a, b = T[i], T[(i + 1) % 3]
        n = _cross(normal, b - a)  # T's vertices are not oriented: point it to the third vertex
        inward.append(n if n @ (T[(i + 2) % 3] - a) >= 0 else -n)
    return inward


def _clip(polygon, T, inward):
    """The part of the convex ``polygon`` (in T's plane) inside the triangle T (Sutherland–Hodgman;
    ``inward``: :func:`_inward_normals`)."""
    for i in range(3):
        a = T[i]
        side = (polygon - a) @ inward[i] if len(polygon) else np.zeros(0)
        out = []
        for j in range(len(polygon)):
            p, q, sp, sq = polygon[j], polygon[(j + 1) % len(polygon)], side[j], side[(j + 1) % len(polygon)]
            if sp >= 0:
                out.append(p)
            if (sp >= 0) != (sq >= 0):
                out.append(p + (q - p) * (sp / (sp - sq)))
        polygon = np.array(out)
    return polygon


def _fan(polygon):
    """Triangles (3, 3) fanning a convex polygon; none for fewer than 3 vertices."""
    return [np.stack([polygon[0], polygon[i], polygon[i + 1]]) for i in range(1, len(polygon) - 1)]


def _barycentric(points, T):
    """Barycentric coordinates (n, 3) of points in the plane of the triangle T."""
    e1, e2 = T[1] - T[0], T[2] - T[0]
    gram = np.array([[e1 @ e1, e1 @ e2], [e1 @ e2, e2 @ e2]])
    st = np.linalg.solve(gram, np.stack([(points - T[0]) @ e1, (points - T[0]) @ e2]))
    return np.stack([1 - st[0] - st[1], st[0], st[1]], axis=1)
