"""The pairs' set-up (nc_dolfinx.pairs.search and .segments) checked against the plain computations it replaces:
the closest facet among the NEAREST midpoints' with every distance computed (the search computes only those
that may win), and each (triangle, triangle) pair clipped one at a time (the 3D cut clips all pairs at once);
and the 3D cut's pieces tile the facets that the other face covers. Serial, on small synthetic faces (no mesh).
"""
import numpy as np
import pytest
from mpi4py import MPI

from nc_dolfinx.pairs import faces, search, segments


def synthetic_face(gdim, n=9, seed=0, height=0.0, flip=False):
    """A jittered grid of segments (2D) or triangles (3D) on a wavy curve or surface z = height + bump."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, n + 1)
    if gdim == 2:
        x = s + rng.uniform(-0.3, 0.3, n + 1) / n * (np.arange(n + 1) % n != 0)
        nodes = np.stack([x, height + 0.05 * np.sin(3 * x)], axis=1)
        cells = np.stack([np.arange(n), np.arange(1, n + 1)], axis=1)
    else:
        X, Y = np.meshgrid(s, s, indexing="ij")
        inner = ((X > 0) & (X < 1) & (Y > 0) & (Y < 1)).ravel()
        xy = np.stack([X.ravel(), Y.ravel()], axis=1) + rng.uniform(-0.3, 0.3, ((n + 1) ** 2, 2)) / n * inner[:, None]
        nodes = np.column_stack([xy, height + 0.05 * np.sin(3 * xy[:, 0]) * np.cos(2 * xy[:, 1])])
        v = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b, c, d = v[:-1, :-1].ravel(), v[1:, :-1].ravel(), v[1:, 1:].ravel(), v[:-1, 1:].ravel()
        cells = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)])
    vertices = nodes[cells]
    normals, sizes = faces._normals_and_sizes(vertices)
    up = normals[:, -1] > 0
    normals[up != (not flip)] *= -1.0  # outward: down for the upper face (flip), up for the lower one
    count = len(cells)
    return faces.Face("synthetic", np.arange(count), np.arange(count), cells, vertices, cells.astype(np.int64),
                      cells.astype(np.int64), normals, sizes)


def brute_force(points, face_):
    """The closest facet among the NEAREST midpoints', every distance computed; ties to the lowest midpoint."""
    from scipy.spatial import cKDTree
    midpoints = face_.vertices.mean(axis=1)
    count = min(search.NEAREST, face_.count)
    _, facet = cKDTree(midpoints).query(points, k=count)
    facet = np.asarray(facet).reshape(len(points), count)
    owner = np.repeat(np.arange(len(points)), count)
    closest, bary = search.closest_on_simplices(points[owner], face_.vertices[facet.ravel()])
    distance = np.linalg.norm(closest - points[owner], axis=1)
    mid = midpoints[facet.ravel()]
    order = np.lexsort((*mid.T[::-1], distance, owner))
    best = order[np.unique(owner[order], return_index=True)[1]]
    return distance[best], closest[best], facet.ravel()[best], bary[best]


@pytest.mark.parametrize("gdim", [2, 3])
def test_the_search_finds_the_facet_every_distance_finds(gdim):
    face_ = synthetic_face(gdim)
    rng = np.random.default_rng(1)
    points = np.concatenate([rng.uniform(-0.2, 1.2, (400, gdim)),           # near and far
                             face_.vertices.reshape(-1, gdim)[:50],          # on vertices: ties between facets
                             face_.vertices[:40].mean(axis=1)])               # on the face
    points[:400, -1] = rng.uniform(-0.3, 0.3, 400)
    found = search.project(MPI.COMM_SELF, points, face_)
    distance, closest, facet, bary = brute_force(points, face_)
    assert np.array_equal(found.distance, distance)
    assert np.array_equal(found.point, closest)
    assert np.array_equal(found.dofs, face_.dofs[facet])
    assert np.array_equal(found.bary, bary)


def clip_one_pair(S, T, normal):
    """Sutherland–Hodgman of S projected onto T's plane by T, one pair at a time (the plain loop)."""
    polygon = S - np.outer((S - T[0]) @ normal, normal)
    for i in range(3):
        a, b, c = T[i], T[(i + 1) % 3], T[(i + 2) % 3]
        inward = np.cross(normal, b - a)
        inward = inward if inward @ (c - a) >= 0 else -inward
        side = (polygon - a) @ inward if len(polygon) else np.zeros(0)
        out = []
        for j in range(len(polygon)):
            k = (j + 1) % len(polygon)
            if side[j] >= 0:
                out.append(polygon[j])
            if (side[j] >= 0) != (side[k] >= 0):
                out.append(polygon[j] + (polygon[k] - polygon[j]) * (side[j] / (side[j] - side[k])))
        polygon = np.array(out)
    return [np.stack([polygon[0], polygon[i], polygon[i + 1]]) for i in range(1, len(polygon) - 1)]


def test_the_pairs_clipped_at_once_as_one_at_a_time():
    own, other = synthetic_face(3, n=7, seed=2, flip=True), synthetic_face(3, n=9, seed=3, height=-0.01)
    depth = np.full(own.count, 0.2)
    facet, S = search.triangles_over(MPI.COMM_SELF, own.vertices, own.normals, depth, other)
    triangles, of = segments._pieces(own, facet, S)
    expected = [t for f, s in zip(facet, S) for t in clip_one_pair(s, own.vertices[f], own.normals[f])]
    assert np.array_equal(triangles, np.array(expected))
    assert np.array_equal(of, np.repeat(facet, [len(clip_one_pair(s, own.vertices[f], own.normals[f]))
                                                for f, s in zip(facet, S)]))


def test_the_pieces_tile_the_facets_the_other_face_covers():
    """Above a face that covers it, every facet is cut into pieces of its own area; points and weights on the
    pieces integrate affine data exactly."""
    own, other = synthetic_face(3, n=5, seed=4, height=0.02, flip=True), synthetic_face(3, n=8, seed=5)
    inside = np.all((own.vertices[:, :, :2] > 0.0) & (own.vertices[:, :, :2] < 1.0), axis=(1, 2))
    x, w, bary, facet, projection = segments.points_and_projection(MPI.COMM_SELF, own, other, 6)
    assert np.allclose(np.bincount(facet, weights=w, minlength=own.count), own.sizes, rtol=1e-12)
    assert np.allclose(np.einsum("nk,nkd->nd", bary, own.vertices[facet]), x, atol=1e-14)
    cut = np.bincount(facet, minlength=own.count) > len(faces.gauss_rule(3, 6)[1]) * 4  # more than composite
    assert np.all(cut[inside])
    first_moment = np.bincount(facet, weights=w * x[:, 0], minlength=own.count)
    assert np.allclose(first_moment, own.sizes * own.vertices[:, :, 0].mean(axis=1), rtol=1e-12)
    assert np.all(projection.distance < 0.2)
