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

In 3D the faces are triangles and the cut would be a polygon clipping; the rule is instead applied on a
composite of ``4^levels`` sub-triangles (``COMPOSITE_LEVELS_3D``), which makes the kinks' error smaller but not
zero (measured in tests/test_pairs.py, and stated in the guide).
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
        x, w, bary, facet = _composite_triangles(own, degree, COMPOSITE_LEVELS_3D)
        return x, w, bary, facet, search.project(comm, x, other)
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


def _composite_triangles(own, degree, levels):
    """The rule of ``degree`` on each of the 4^levels sub-triangles of each facet (midpoint subdivision)."""
    bary_ref, weights = gauss_rule(3, degree)
    triangles = [np.eye(3)]  # sub-triangles by the barycentric coordinates of their corners
    for _ in range(levels):
        finer = []
        for t in triangles:
            m01, m12, m20 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2
            finer += [np.stack(c) for c in ((t[0], m01, m20), (m01, t[1], m12), (m20, m12, t[2]), (m01, m12, m20))]
        triangles = finer
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
