"""Normal compliance between two deformable bodies: the pairs' part of the residual, Jacobian and energy of (7).

For a pair of faces (Γ_A on one body, Γ_B on the other) and a point x of Γ_A, Π x is the closest point of
Γ_B in the reference configuration (:mod:`.search`), n the mean of the outward normals ν_A at x and −ν_B at
Π x (:func:`.faces.pair_normal`: ν_A itself on flat faces), and

    u_n(x) = (u(x) − u(Π x))·n,     g_0(x) = (Π x − x)·n + offset,      p = c_n (u_n − g_0)_+^{m_n},

the law (4) of the paper with the normal jump across the pair in place of u_n (the foundation's side is the
other body). The pair's term of the residual of (7) is

    j_AB(u, v) = ∫_Γ_A p (v(x) − v(Π x))·n,

discretised at the Gauss points x_q of Γ_A's facets (weights w_q): with the sparse gap operator B,
(B u)_q = u_n(x_q) (row q: λ_i n at the facet's vertices, −λ'_j n at those of the facet of Γ_B that
holds Π x_q), the term is Bᵀ W p(B u − g), its Jacobian Bᵀ W p'(B u − g) B and its energy
Σ_q w_q c_n/(m_n + 1) (B u − g)_+^{m_n + 1}: the solver's Newton steps, line search and preconditioner see
one more convex, C¹ energy term and one more SPD Jacobian term, as for the foundation.

Two half-passes (default, ``passes = "two"``): the same on Γ_B with Γ_A as the other face, each with the
weight ½. Unbiased: neither face is the "slave", and a uniform pressure across non-matching meshes is
transmitted (the contact patch test; a one-pass scheme evaluated at the nodes is known to fail it, Zavarise
& De Lorenzis, IJNME 79, 2009). ``passes = "one"``: Γ_A's points only (Γ_B's rows stay, with weight 0, for
the estimator and the output). B is a PETSc MPIAIJ matrix: its rows are the points on the ranks that own
their facets, its columns the dofs wherever they are owned: nothing of global size on one rank.
"""
from dataclasses import dataclass
from functools import partial

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from .. import dolfinx_versions as versions
from ..errors import InputError
from ..problem.expressions import values_at
from . import faces, operators, search, segments
from .cache import kept
from .friction import PairFriction


@dataclass
class Pair:
    """One [[pairs]] entry bound to a mesh: its faces' group ids and names, its law and options."""
    number: int
    names: tuple
    ids: tuple
    bodies: tuple       # the names of the bodies of the two faces
    c_n: object         # number or expression text
    m_n: float
    offset: float
    passes: str
    degree: int
    integration: str    # "cut", "gauss" or "nodes" (:mod:`.segments`)
    search_distance: float
    parameters: dict    # the problem's parameters (c_n may be an expression of them and of x)
    friction: object = None  # Coulomb's μ (number or expression text), or None: frictionless (:mod:`.friction`)


@dataclass
class Rows:
    """The points of one pass (one face's Gauss points projected onto the other face)."""
    pair: Pair
    side: int               # 0: the points are on the pair's first face, 1: on its second
    face: faces.Face
    x: np.ndarray           # (n, gdim)
    w: np.ndarray           # (n,) the quadrature weights (times ½ with two passes; 0 where not taking part)
    facet: np.ndarray       # (n,) the point's facet in ``face``
    normal: np.ndarray      # (n, gdim) ν of the face at the point
    direction: np.ndarray   # (n, gdim) n, the law's normal (:func:`.faces.pair_normal`)
    gap: np.ndarray         # (n,) g_0
    c_n: np.ndarray         # (n,)
    m_n: float
    projection: search.Projection
    measure: np.ndarray     # (n,) the plain quadrature weight (for the face's integrals, whatever the passes)
    bary: np.ndarray        # (n, k) the point's barycentric coordinates in its facet


class PairCoupling:
    """The pairs' term of (7) on one mesh (rebuilt after each refinement: the projection is made once per
    mesh). ``u``: the displacement Function the solver iterates on; reads its current values."""

    def __init__(self, u, fields):
        self._u, self.fields = u, fields  # (the setter also tells self.friction, made below)
        comm = u.function_space.mesh.comm
        self.rows, frictional = [], []
        for pair in fields.pairs:
            sides = [kept(fields.domain.mesh, ("face", pair.ids[i]), partial(
                faces.face, fields.domain, u.function_space, pair.ids[i], pair.names[i])) for i in (0, 1)]
            for side in (0, 1):
                self.rows.append(_pass(comm, pair, side, sides[side], sides[1 - side], fields))
            if pair.friction is not None:
                frictional.append((pair, sides))
        self.friction = PairFriction(u, fields, frictional) if frictional else None  # (:mod:`.friction`)
        self.B = _gap_operator(u.function_space, self.rows)
        self.g = _concatenate([r.gap for r in self.rows])
        self.w = _concatenate([r.w for r in self.rows])
        self.c_n = _concatenate([r.c_n for r in self.rows])
        self.m_n = _concatenate([np.full(len(r.w), r.m_n) for r in self.rows])
        self.e, self.scaled, self.g_vec = (self.B.createVecLeft() for _ in range(3))
        self.g_vec.setArray(self.g)
        self.B0 = self.J = self.DB0 = None  # made by widen and the first add_jacobian, kept for this mesh

    @property
    def u(self):
        """The displacement whose values the term reads (whoever asks last: solver, estimator, output)."""
        return self._u

    @u.setter
    def u(self, u):
        self._u = u
        if self.friction is not None:
            self.friction.u = u

    # --- the solver's protocol: widen K's sparsity, add to the residual and the Jacobian, the energy ----

    def widen(self, K, bcs):
        """K with the sparsity of K + BᵀB (values unchanged), the Dirichlet dofs' columns of B zeroed for
        the Jacobian (the solver's J keeps its identity rows there)."""
        if self.B0 is None:  # (the same bcs for every solver of this mesh's fields)
            keep = K.createVecRight()
            keep.set(1.0)
            versions.set_dirichlet_rows(keep, bcs, 0.0)  # (0 on the held dofs)
            self.B0 = self.B.copy()
            self.B0.diagonalScale(R=keep)
            if self.friction is not None:
                self.friction.drop_dirichlet_columns(keep)
            keep.destroy()
        patterns = [self.B.transposeMatMult(self.B)]
        if self.friction is not None:
            patterns.append(self.friction.widen_pattern())
        lgmaps = K.getLGMap()  # (DOLFINx assembles into copies of K by local indices)
        for pattern in patterns:
            pattern.zeroEntries()
            K.axpy(1.0, pattern, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
            pattern.destroy()
        K.setLGMap(*lgmaps)
        return K

    def penetration(self):
        """e = B u − g at every point (a PETSc Vec of the rows; its local array on this rank's points)."""
        self.B.mult(versions.petsc_vec(self.u), self.e)
        self.e.axpy(-1.0, self.g_vec)
        return self.e.getArray(readonly=True)

    def pressure(self):
        """p = c_n (B u − g)_+^{m_n} at every point of this rank."""
        return self.c_n * np.maximum(self.penetration(), 0.0) ** self.m_n

    def add_residual(self, vector):
        """vector += Bᵀ W p(B u − g)."""
        self.scaled.setArray(self.w * self.pressure())
        self.B.multTransposeAdd(self.scaled, vector, vector)  # (no work vector on this hot path)
        if self.friction is not None:
            self.friction.add_residual(vector)

    def add_jacobian(self, matrix, kind="frozen"):
        """matrix += B0ᵀ W p'(B u − g) B0 (B0: B without the Dirichlet columns); the kink closed: for
        m_n = 1 a point with B u = g counts as in contact, as the foundation's closed Jacobian. With friction
        between the faces, the friction's Jacobian of ``kind`` ("frozen", "stiffened", "consistent":
        :meth:`.friction.PairFriction.add_jacobian`)."""
        e = self.penetration()
        slope = np.where(e >= 0.0, self.c_n * self.m_n * np.abs(e) ** (self.m_n - 1), 0.0)  # (0^0 = 1: m_n = 1)
        self.scaled.setArray(self.w * slope)
        if self.DB0 is None:
            self.DB0 = self.B0.copy()
        else:
            self.B0.copy(self.DB0, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self.DB0.diagonalScale(L=self.scaled)
        if self.J is None:
            self.J = self.B0.transposeMatMult(self.DB0)
        else:
            self.B0.transposeMatMult(self.DB0, result=self.J)
        matrix.axpy(1.0, self.J, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        if self.friction is not None:
            self.friction.add_jacobian(matrix, kind)

    def energy(self):
        """Σ_q w_q c_n/(m_n + 1) (B u − g)_+^{m_n + 1} over all ranks."""
        e = np.maximum(self.penetration(), 0.0)
        normal = self.u.function_space.mesh.comm.allreduce(
            float(np.sum(self.w * self.c_n / (self.m_n + 1) * e ** (self.m_n + 1))), op=MPI.SUM)
        return normal if self.friction is None else normal + self.friction.energy()

    def destroy(self):
        for obj in (self.B, self.B0, self.J, self.DB0, self.e, self.scaled, self.g_vec):
            if obj is not None:
                obj.destroy()
        if self.friction is not None:
            self.friction.destroy()

    # --- what the output and the estimator read ---------------------------------------------------------

    def by_rows(self):
        """(Rows, slice of this rank's points) of each pass."""
        start = 0
        for rows in self.rows:
            yield rows, slice(start, start + len(rows.w))
            start += len(rows.w)


def _concatenate(arrays):
    return np.concatenate(arrays) if arrays else np.zeros(0)


def _pass(comm, pair, side, own, other, fields):
    """The rows of one pass: ``own``'s Gauss points projected onto ``other``."""
    x, w, bary, facet, projection = kept(fields.domain.mesh, ("points", pair.ids, side, pair.degree, pair.integration),
                                         partial(segments.points_and_projection, comm, own, other, pair.degree,
                                                 pair.integration))
    normal = own.normals[facet]
    direction = faces.pair_normal(normal, projection.normal)
    gap = np.einsum("ij,ij->i", projection.point - x, direction) + pair.offset
    _check_facing(comm, pair, side, normal, projection)
    _check_overlap(comm, pair, side, x, gap, own.sizes[facet])
    weight = w * (0.5 if pair.passes == "two" else 1.0 if side == 0 else 0.0)
    if pair.search_distance is not None:
        beyond = projection.distance > pair.search_distance
        weight = np.where(beyond, 0.0, weight)
        count = comm.allreduce(int(beyond.sum()), op=MPI.SUM)
        if count:
            total = comm.allreduce(len(x), op=MPI.SUM)
            fields.warnings.append(
                f"pairs[{pair.number}]: {count} of {total} points of '{pair.names[side]}' have no facet of "
                f"'{pair.names[1 - side]}' within search_distance {pair.search_distance:g}: they take no part")
    c_n = np.broadcast_to(values_at(str(pair.c_n), x, pair.parameters), (len(x),)).astype(float) \
        if len(x) else np.zeros(0)
    if not np.all(np.isfinite(c_n)) or np.any(c_n < 0):
        raise InputError(f"pairs[{pair.number}].c_n must be finite and >= 0 on '{pair.names[side]}'")
    return Rows(pair, side, own, x, weight, facet, normal, direction, gap, c_n, pair.m_n, projection, w, bary)


def _check_facing(comm, pair, side, normal, projection):
    """The faces face each other somewhere: ν_A·ν_B < 0 at the closest point of some point."""
    facing = np.einsum("ij,ij->i", normal, projection.normal) < 0
    if not comm.allreduce(bool(facing.any()), op=MPI.LOR):
        raise InputError(f"pairs[{pair.number}]: faces '{pair.names[0]}' and '{pair.names[1]}' never face each "
                         "other (their outward normals never point against each other)")


def _check_overlap(comm, pair, side, x, gap, sizes):
    """No point lies inside the other body by more than its facet's size at level 0: there the closest point
    no longer tells which way the bodies must move apart (beyond the law's range)."""
    depth = -gap / sizes
    worst = comm.allreduce(float(depth.max()) if len(depth) else -np.inf, op=MPI.MAX)
    if worst > 1.0:
        where = x[np.argmax(depth)] if len(depth) and depth.max() == worst else None
        located = comm.allreduce(None if where is None else where.tolist(), op=_first)
        raise InputError(f"pairs[{pair.number}]: '{pair.names[side]}' lies inside the other body by "
                         f"{worst:.3g} of its facet size near {np.round(located, 6).tolist()}: the bodies overlap "
                         "beyond the law's range (mesh them apart, or give pairs.offset)")


def _first(a, b, _=None):
    return a if a is not None else b


def _gap_operator(space, rows_list):
    """B (points × dofs, :func:`.operators.point_operator`): row q reads (u(x_q) − u(Π x_q))·n."""
    gdim = space.dofmap.index_map_bs
    k = gdim  # (the vertices of a facet)
    def joined(get, shape):
        arrays = [get(rows) for rows in rows_list]
        return np.concatenate(arrays) if arrays else np.zeros(shape)
    normal = joined(lambda r: r.direction, (0, gdim))
    own = (joined(lambda r: r.face.dofs[r.facet], (0, k)).astype(np.int64), joined(lambda r: r.bary, (0, k)))
    other = (joined(lambda r: r.projection.dofs, (0, k)).astype(np.int64), -joined(lambda r: r.projection.bary, (0, k)))
    return operators.point_operator(space, normal[:, None, :], [own, other])
