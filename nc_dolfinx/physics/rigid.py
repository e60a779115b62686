"""Which rigid motions the supports leave free, decided before any solve.

Elasticity alone does not resist a rigid motion r (ε(r) = 0): (7) has a unique solution only if every r
is held, by the Dirichlet groups and symmetry planes or, once pressed, by the foundation. What the supports
leave free is found here; whether the foundation holds it is decided at the cold start
(:mod:`nc_dolfinx.solver.settling`). A rigid motion is held by the supports if some held component of some
held point moves: with the rigid-motion basis r_a (translations along, rotations about the coordinate axes, in
coordinates centred on the body's bounding box and scaled by its size) the Gram matrix

    G_ab = Σ over held (point, component i) of r_a,i r_b,i

(a 3×3 matrix in 2D, 6×6 in 3D, summed over the ranks in one allreduce) is singular exactly on the free
motions: its null space (eigenvalues below NULL_TOLERANCE times the largest) is what the supports leave
free. The points are the vertices of the held groups' facets; a vertex counted twice only reweights G.
"""
import numpy as np
from mpi4py import MPI

NULL_TOLERANCE = 1e-10
AXES = "xyz"


def rigid_motions(xi):
    """The rigid-motion basis at centred, scaled points ``xi`` (n, dim): an array (n, k, dim), k = 3 in
    2D (translations along x, y; rotation about z), 6 in 3D (translations, then rotations about x, y, z)."""
    n, dim = xi.shape
    if dim == 2:
        ones, zeros = np.ones(n), np.zeros(n)
        return np.stack([np.stack([ones, zeros], 1), np.stack([zeros, ones], 1),
                         np.stack([-xi[:, 1], xi[:, 0]], 1)], axis=1)
    translations = np.broadcast_to(np.eye(3), (n, 3, 3))
    rotations = np.cross(np.eye(3)[None, :, :], xi[:, None, :])  # e_a × ξ: the rotation about axis a
    return np.concatenate([translations, rotations], axis=1)


def motion_names(dim):
    translations = [f"translation along {a}" for a in AXES[:dim]]
    return translations + (["rotation about z"] if dim == 2 else [f"rotation about {a}" for a in AXES])


def gram_matrix(held_points, centre, scale, comm):
    """Σ r_a·r_b over the held (points, components): ``held_points`` is a list of (points (n, dim),
    components held there); summed over the ranks of ``comm``."""
    dim = len(centre)
    k = 3 if dim == 2 else 6
    local = np.zeros((k, k))
    for points, components in held_points:
        r = rigid_motions((np.asarray(points, dtype=float).reshape(-1, dim) - centre) / scale)
        r = r[:, :, list(components)]
        local += np.einsum("nai,nbi->ab", r, r)
    total = np.empty_like(local)
    comm.Allreduce(local, total, MPI.SUM)
    return total


def free_motions(gram):
    """A basis of G's null space (k, m), reduced so that each vector is one motion where it can be (the
    rotations first): the row-echelon form of its transpose."""
    return readable(null_space(gram))


def null_space(matrix, complement=False):
    """An orthonormal basis (columns) of the null space of a symmetric positive semi-definite matrix: its
    eigenvalues up to NULL_TOLERANCE times the largest (all of it for the zero matrix); ``complement``: of
    its orthogonal complement instead (the other eigenvalues)."""
    values, vectors = np.linalg.eigh(matrix)
    largest = max(float(values.max()), 0.0) if len(values) else 0.0
    null = values <= NULL_TOLERANCE * largest if largest > 0 else np.ones(len(values), dtype=bool)
    return vectors[:, ~null if complement else null]


def readable(motions):
    """The same span of rigid motions (coefficients, (k, m)), reduced so that each vector is one motion
    where it can be (the rotations first): the row-echelon form of its transpose."""
    if motions.shape[1] == 0:
        return motions
    k = len(motions)
    translations = 2 if k == 3 else 3  # the basis holds the translations, then the rotations
    order = list(range(translations, k)) + list(range(translations))  # rotations first
    rows = _row_echelon(motions.T[:, order])
    reduced = np.zeros_like(rows)
    reduced[:, order] = rows
    return reduced.T


def _row_echelon(matrix):
    """The reduced row-echelon form of a full-rank (m, k) matrix, with partial pivoting."""
    a = matrix.copy()
    row = 0
    for column in range(a.shape[1]):
        if row == a.shape[0]:
            break
        pivot = row + int(np.argmax(np.abs(a[row:, column])))
        if abs(a[pivot, column]) < 1e-8:
            continue
        a[[row, pivot]] = a[[pivot, row]]
        a[row] /= a[row, column]
        for other in range(a.shape[0]):
            if other != row:
                a[other] -= a[other, column] * a[row]
        row += 1
    a[np.abs(a) < 1e-8] = 0.0
    return a


def describe(vector, centre, scale):
    """A free rigid motion (coefficients of the basis of :func:`rigid_motions`) in words."""
    dim = len(centre)
    names = motion_names(dim)
    used = np.flatnonzero(vector)
    if len(used) == 1:
        return names[used[0]]
    translation = np.zeros(3)
    translation[:dim] = vector[:dim]
    rotation = np.array([0.0, 0.0, vector[2]]) if dim == 2 else vector[3:]
    if not rotation.any():
        direction = translation[:dim] / np.linalg.norm(translation)
        return "translation along (" + ", ".join(f"{c:.3g}" for c in direction) + ")"
    # ω × (ξ − p) + s ω: the rotation about the axis ω through p, p ⊥ ω, and a slide s along it
    omega2 = rotation @ rotation
    p = np.cross(rotation, translation) / omega2
    point = ", ".join(f"{c:.4g}" for c in (centre + scale * p[:dim]))
    if dim == 2:
        return f"rotation about z about the point ({point})"
    axis = rotation / np.sqrt(omega2)
    along = next((f"{a}" for a, e in zip(AXES, np.eye(3)) if abs(abs(axis @ e) - 1) < 1e-8), None)
    text = f"rotation about {along or 'the axis (' + ', '.join(f'{c:.3g}' for c in axis) + ')'} through ({point})"
    slide = translation @ rotation / omega2
    return text + (" with a translation along that axis" if abs(slide) > 1e-8 else "")


def free_rigid_motions(held_points, centre, scale, comm):
    """The rigid motions the held (points, components) leave free, in words (empty: none)."""
    return describe_all(free_motions(gram_matrix(held_points, centre, scale, comm)), centre, scale)


def describe_all(motions, centre, scale):
    """Each column of ``motions`` (k, m) in words (:func:`describe`)."""
    return [describe(motions[:, j], np.asarray(centre, dtype=float), scale) for j in range(motions.shape[1])]
