"""Exact ‖u_a − u_b‖ in L² and H¹ between two P1 vector fields on two *different* triangulations of the
same polygon (serial, numpy + a DOLFINx bounding-box tree for the candidate pairs).

Interpolating a coarse P1 field into the P1 space of a non-nested fine mesh changes it by O(|[∇u_h]| (h_ref
h)^{1/2}) per coarse edge in H¹, which pollutes the H¹ error at the level of the error itself. So the error
is integrated on the overlay instead: every pair (A, B) of overlapping triangles is intersected exactly
(Sutherland–Hodgman clipping of A by the three edge half-planes of B, a convex polygon of at most 6
vertices), where both fields are affine; ∫|∇(u_a − u_b)|² = |A ∩ B| |G_A − G_B|² and ∫|u_a − u_b|² is
exact with the edge-midpoint rule on a fan triangulation of the polygon. The sum of |A ∩ B| over the pairs
of each cell A must give |A| (checked: ``coverage_error``), so no pair is missed.
"""
import numpy as np

CAPACITY = 16  # vertices of a clipped polygon: 6, plus duplicates where vertices lie on a clipping line


def _ccw(X, T):
    T = np.array(T, dtype=np.int64)
    p = X[T]
    det = (p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0])
    flip = det < 0
    T[flip] = T[flip][:, [0, 2, 1]]
    return T


def affine(X, T, U):
    """Per triangle: origin x0 (n, 2), value u0 (n, 2), gradient G (n, 2, 2) with G[:, i, j] = ∂u_i/∂x_j."""
    p, u = X[T], U[T]
    J = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)      # columns: edges, J[:, :, k]
    du = np.stack([u[:, 1] - u[:, 0], u[:, 2] - u[:, 0]], axis=2)     # du[:, i, k]
    G = du @ np.linalg.inv(J)
    return p[:, 0], u[:, 0], G


def _serial_mesh(X, T):
    """A serial DOLFINx mesh of (X, T) and, per DOLFINx cell, its row in T."""
    from mpi4py import MPI
    from nc_dolfinx import dolfinx_versions as versions
    msh = versions.create_serial_mesh(MPI.COMM_SELF, T, X)
    return msh, np.asarray(msh.topology.original_cell_index)


def _candidate_pairs(Xa, Ta, Xb, Tb):
    from nc_dolfinx import dolfinx_versions as versions
    ma, oa = _serial_mesh(Xa, Ta)
    mb, ob = _serial_mesh(Xb, Tb)
    pairs = versions.colliding_cell_pairs(ma, mb)
    return np.asarray(oa)[pairs[:, 0]], np.asarray(ob)[pairs[:, 1]]


def _clip(P, count, a, b):
    """Clip convex polygons P (n, M, 2) with ``count`` vertices by the half-planes left of a→b (n, 2)."""
    n, M, _ = P.shape
    out = np.zeros_like(P)
    out_count = np.zeros(n, dtype=np.int64)
    rows = np.arange(n)
    edge = b - a

    def side(q):
        return edge[:, 0] * (q[:, 1] - a[:, 1]) - edge[:, 1] * (q[:, 0] - a[:, 0])

    for i in range(M):
        valid = i < count
        cur = P[:, i]
        prev = P[rows, (i - 1) % np.maximum(count, 1)]
        sc, sp = side(cur), side(prev)
        cin, pin = sc >= 0, sp >= 0
        # crossing: add the intersection point
        cross = valid & (cin != pin)
        t = np.where(cross, sp / np.where(sp - sc == 0, 1.0, sp - sc), 0.0)
        inter = prev + t[:, None] * (cur - prev)
        idx = np.flatnonzero(cross)
        out[idx, out_count[idx]] = inter[idx]
        out_count[idx] += 1
        keep = valid & cin
        idx = np.flatnonzero(keep)
        out[idx, out_count[idx]] = cur[idx]
        out_count[idx] += 1
    return out, out_count


def difference_norms(mesh_a, mesh_b, chunk=400_000):
    """(‖u_a − u_b‖_0, ‖u_a − u_b‖_1, coverage_error) for (X, T, U) triples of P1 vector fields."""
    Xa, Ta, Ua = mesh_a
    Xb, Tb, Ub = mesh_b
    Ta, Tb = _ccw(Xa, Ta), _ccw(Xb, Tb)
    ia, ib = _candidate_pairs(Xa, Ta, Xb, Tb)
    xa0, ua0, Ga = affine(Xa, Ta, Ua)
    xb0, ub0, Gb = affine(Xb, Tb, Ub)
    area_a = np.zeros(len(Ta))
    l2_sq = grad_sq = 0.0
    for s in range(0, len(ia), chunk):
        A, B = ia[s:s + chunk], ib[s:s + chunk]
        n = len(A)
        P = np.zeros((n, CAPACITY, 2))
        P[:, :3] = Xa[Ta[A]]
        count = np.full(n, 3)
        qb = Xb[Tb[B]]
        for k in range(3):
            P, count = _clip(P, count, qb[:, k], qb[:, (k + 1) % 3])
            if count.max() > CAPACITY - 1:
                raise RuntimeError("overlay: clipped polygon exceeds the vertex capacity")
        # fan triangulation (v0, v_j, v_j+1), edge-midpoint rule (exact for quadratics)
        da = Ga[A] - Gb[B]
        gsq = np.einsum("nij,nij->n", da, da)
        for j in range(1, CAPACITY - 1):
            ok = count > j + 1
            if not ok.any():
                break
            v0, v1, v2 = P[ok, 0], P[ok, j], P[ok, j + 1]
            area = 0.5 * np.abs((v1[:, 0] - v0[:, 0]) * (v2[:, 1] - v0[:, 1]) - (v1[:, 1] - v0[:, 1]) * (v2[:, 0] - v0[:, 0]))
            Ak, Bk = A[ok], B[ok]
            np.add.at(area_a, Ak, area)
            grad_sq += float(np.sum(area * gsq[ok]))
            for m in ((v0 + v1) / 2, (v1 + v2) / 2, (v2 + v0) / 2):
                va = ua0[Ak] + np.einsum("nij,nj->ni", Ga[Ak], m - xa0[Ak])
                vb = ub0[Bk] + np.einsum("nij,nj->ni", Gb[Bk], m - xb0[Bk])
                l2_sq += float(np.sum(area / 3 * np.sum((va - vb) ** 2, axis=1)))
    p = Xa[Ta]
    true_area = 0.5 * np.abs((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    coverage = float(np.max(np.abs(area_a - true_area) / true_area))
    return float(np.sqrt(l2_sq)), float(np.sqrt(l2_sq + grad_sq)), coverage


def same_mesh_norms(X, T, Ua, Ub):
    """‖u_a − u_b‖_0 and ‖u_a − u_b‖_1 for two P1 fields on the same triangulation (exact)."""
    T = _ccw(X, T)
    D = Ua - Ub
    x0, d0, G = affine(X, T, D)
    p = X[T]
    area = 0.5 * ((p[:, 1, 0] - p[:, 0, 0]) * (p[:, 2, 1] - p[:, 0, 1]) - (p[:, 1, 1] - p[:, 0, 1]) * (p[:, 2, 0] - p[:, 0, 0]))
    grad_sq = float(np.sum(area * np.einsum("nij,nij->n", G, G)))
    mids = [(D[T[:, i]] + D[T[:, (i + 1) % 3]]) / 2 for i in range(3)]
    l2_sq = float(np.sum(area / 3 * sum(np.sum(m ** 2, axis=1) for m in mids)))
    return float(np.sqrt(l2_sq)), float(np.sqrt(l2_sq + grad_sq))


def locate(X, T, points, k=16):
    """The triangle of (X, T) containing each point (largest smallest barycentric coordinate among the
    k nearest centroids, widened where that is not enough); raises if a point is outside."""
    from scipy.spatial import cKDTree
    T = _ccw(X, T)
    x0, _, _ = affine(X, T, np.zeros((len(X), 2)))
    p = X[T]
    J = np.stack([p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]], axis=2)
    Jinv = np.linalg.inv(J)
    tree = cKDTree(p.mean(axis=1))
    cells = np.full(len(points), -1)
    todo = np.arange(len(points))
    while len(todo):
        k = min(k, len(T))
        _, near = tree.query(points[todo], k=k)
        near = near.reshape(len(todo), k)
        lam = np.einsum("nkij,nkj->nki", Jinv[near], points[todo][:, None, :] - x0[near])
        bary = np.concatenate([1 - lam.sum(axis=2, keepdims=True), lam], axis=2).min(axis=2)
        best = np.argmax(bary, axis=1)
        found = bary[np.arange(len(todo)), best] > -1e-10
        cells[todo[found]] = near[found, best[found]]
        todo = todo[~found]
        if k == len(T) and len(todo):
            raise ValueError("points outside the mesh")
        k *= 4
    return cells, T


def nested_difference(mesh_coarse, mesh_fine):
    """The norms of u_fine − u_coarse when the fine mesh refines the coarse one: u_coarse evaluated at the
    fine vertices is exact there (P1 on a refinement), so the norms are computed on the fine mesh."""
    Xc, Tc, Uc = mesh_coarse
    Xf, Tf, Uf = mesh_fine
    cells, Tc = locate(Xc, Tc, Xf)
    x0, u0, G = affine(Xc, Tc, Uc)
    Ui = u0[cells] + np.einsum("nij,nj->ni", G[cells], Xf - x0[cells])
    return same_mesh_norms(Xf, Tf, Uf, Ui)
