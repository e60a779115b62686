"""Coulomb friction between the faces of a pair: the regularised law of the foundation
(:mod:`nc_dolfinx.physics.friction`) with the jump across the pair in place of the body's displacement.

At a vertex x of a pair's face Γ_A (weight m_x = ∫_Γ_A φ_x), with Π x its closest point on the other face Γ_B
(:mod:`.search`) and N the mean of Γ_A's vertex normal (the normalised ∫ ν φ_x, as on Γ_C) and −ν_B at Π x
(:func:`.faces.pair_normal`, as the pressure's rows):

    pressure      p  = c_n (u_n − g_0)_+^{m_n},   u_n = (u(x) − u(Π x))·N,   g_0 = (Π x − x)·N + offset,
    slip          Δu_t = (I − N Nᵀ)((u − u_prev)(x) − (u − u_prev)(Π x)),
    bound         F = μ p,  ε = ε_r (u_n − g_0)_+,
    traction      σ_t = −F s / max(|s|, ε),   s = Δu_t − (ε/F) σ_t,prev   (σ_t on Γ_A's body),

the law (4) and Coulomb's law of the paper's §2 with the relative displacement of the two bodies: u_prev
and σ_t,prev are the previous load state's (the memory, :mod:`nc_dolfinx.physics.slip_state`: σ_t,prev is
kept in the same P1 function as Γ_C's, at the faces' vertices, so that it moves with the mesh through
refinement as the foundation's does). The term of the residual is −Σ_x w_x σ_t(x)·((v(x) − v(Π x))_t):
Γ_B's body carries the opposite force through Π. Two half-passes as for the pressure
(:mod:`.coupling`): the vertices of both faces, each weighted ½ (one pass: Γ_A's only).

Why at the vertices: the foundation's law is evaluated there (issue 50: a stick zone and a slip history that
are exact at the points where the law holds, and a memory a P1 function carries exactly). The pressure of
the normal law stays on the cut facets (the patch test); the bound here is the pressure at the vertices.

The solver sees it as the foundation's law (:mod:`nc_dolfinx.solver.fixed_point`): with the bound F̄, ε̄ of
a frozen iterate ū (the law's ``frozen`` function) the term is the gradient of the convex, C¹
Σ w F̄ ψ_ε̄(s) (the energy its line search reads), with an SPD Jacobian Tᵀ D T (T the tangential operator);
its consistent Jacobian (the fixed point's Newton finish) adds the bound's derivative, C·B_N; the
stiffening along the slip of :func:`~nc_dolfinx.physics.friction.slip_stiffening` on the steps the solver
asks for it.
"""
from dataclasses import dataclass
from functools import partial

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

import dolfinx

from .. import dolfinx_versions as versions
from ..errors import InputError
from ..physics.friction import SLIP_STIFFENING, on_contact
from ..problem.expressions import values_at
from . import faces, operators, search
from .cache import kept


@dataclass
class VertexRows:
    """The vertices of one face of a frictional pair (this rank's owned ones) and their projections."""
    pair: object
    side: int
    local: np.ndarray      # (n,) the local dof block of each vertex (owned)
    x: np.ndarray          # (n, gdim)
    measure: np.ndarray    # (n,) m_x = ∫_face φ_x
    w: np.ndarray          # (n,) the law's weight (m_x, ½ of it with two passes, 0 where not taking part)
    normal: np.ndarray     # (n, gdim) N (:func:`.faces.pair_normal` of the vertex normal and −ν_B)
    gap: np.ndarray        # (n,) g_0 along N
    mu_c_n: np.ndarray     # (n,) μ c_n
    m_n: float
    projection: search.Projection


class PairFriction:
    """The frictional pairs' term of the residual, Jacobian and energy (the module's law) on one mesh."""

    def __init__(self, u, fields, faces_of_pairs):
        space, comm = u.function_space, u.function_space.mesh.comm
        self.u, self.law, self.comm, self.gdim = u, fields.friction, comm, fields.dim
        self.rows = []
        for pair, sides in faces_of_pairs:
            for side in (0, 1):
                self.rows.append(_vertex_rows(comm, space, pair, side, sides[side], sides[1 - side]))
        self._check_not_on_frictional_foundation(fields)
        gdim = self.gdim
        join = lambda name, shape: np.concatenate([getattr(r, name) for r in self.rows]) if self.rows \
            else np.zeros(shape)
        self.local = join("local", (0,)).astype(np.int64)
        self.w, self.g = join("w", (0,)), join("gap", (0,))
        self.mu_c_n = join("mu_c_n", (0,))
        self.m_n = np.concatenate([np.full(len(r.w), r.m_n) for r in self.rows]) if self.rows else np.zeros(0)
        normal = join("normal", (0, gdim))
        tangent = np.eye(gdim)[None] - normal[:, :, None] * normal[:, None, :]
        projections = [r.projection for r in self.rows]
        own_blocks = (space.dofmap.index_map.local_range[0] + self.local)[:, None]
        other = (np.concatenate([p.dofs for p in projections]).astype(np.int64) if projections
                 else np.zeros((0, gdim), dtype=np.int64),
                 -np.concatenate([p.bary for p in projections]) if projections else np.zeros((0, gdim)))
        own = (own_blocks.astype(np.int64), np.ones_like(own_blocks, dtype=float))
        self.T = operators.point_operator(space, tangent, [own, other])            # n·gdim rows: Δ(u)_t
        self.N = operators.point_operator(space, normal[:, None, :], [own, other])  # n rows: u_n
        self.T0 = self.N0 = None
        self.work = [self.N.createVecLeft() for _ in range(2)] + [self.T.createVecLeft() for _ in range(2)]
        self.g_vec = self.N.createVecLeft()
        self.g_vec.setArray(self.g)

    def _check_not_on_frictional_foundation(self, fields):
        """σ_t,prev of a vertex on both a frictional Γ_C and a frictional pair's face would be two tractions."""
        if self.law.key == "pairs.friction":
            return
        shared = bool(np.any(on_contact(self.law)[self.local])) if len(self.local) else False
        if self.comm.allreduce(shared, op=MPI.LOR):
            raise InputError("a vertex lies on both Γ_C (mesh.contact, with friction) and the face of a pair with "
                             "friction: give the foundation's and the pair's faces no common vertex")

    # --- the solver's protocol (through PairCoupling) ----------------------------------------------------

    def widen_pattern(self):
        """TᵀT: the sparsity the term adds to K."""
        return self.T.transposeMatMult(self.T)

    def drop_dirichlet_columns(self, keep):
        """T0, N0: T and N without the Dirichlet columns (``keep``: 1, 0 on the held dofs)."""
        self.T0, self.N0 = self.T.copy(), self.N.copy()
        self.T0.diagonalScale(R=keep)
        self.N0.diagonalScale(R=keep)

    def add_residual(self, vector):
        """vector += Tᵀ W (−σ_t) with the bound of the frozen iterate."""
        state = self._state(self.law.frozen)
        self.work[2].setArray((-self.w[:, None] * state.traction).ravel())
        self.T.multTransposeAdd(self.work[2], vector, vector)

    def add_jacobian(self, matrix, kind="frozen"):
        """matrix += T0ᵀ W D T0 (``kind`` "frozen"; "stiffened": D stiffened along the slip), or the consistent
        T0ᵀ W (D T0 + C N0) (``kind`` "consistent": the bound's derivative too)."""
        state = self._state(self.law.frozen)
        D = operators.block_diagonal(self.comm, self.w[:, None, None] * state.hessian(kind == "stiffened"))
        M = D.matMult(self.T0)
        if kind == "consistent":
            C = operators.block_diagonal(self.comm, self.w[:, None, None] * state.bound_derivative()[:, :, None])
            CN = C.matMult(self.N0)
            M.axpy(1.0, CN, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
            C.destroy()
            CN.destroy()
        J = self.T0.transposeMatMult(M)
        matrix.axpy(1.0, J, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        for obj in (D, M, J):
            obj.destroy()

    def energy(self):
        """Σ w F̄ ψ_ε̄(s) over all ranks (the frozen bound's)."""
        return self.comm.allreduce(float(self.w @ self._state(self.law.frozen).dissipation()), op=MPI.SUM)

    # --- the law's state, the memory, the output ------------------------------------------------------

    def write_traction(self, function):
        """σ_t of the law, the bound of u itself (the traction at the end of an increment: the memory's next
        value), written into the P1 vector ``function`` at the frictional faces' vertices (ghosts updated;
        its other values left as they are). Returns ``function``."""
        function.x.array.reshape(-1, self.gdim)[self.local] = self._state(self.u).traction
        function.x.scatter_forward()
        return function

    def vertex_states(self):
        """(rows, slice, in contact, sticking, σ_t) of each face's vertices, the bound of u itself."""
        state = self._state(self.u)
        start = 0
        for rows in self.rows:
            where = slice(start, start + len(rows.w))
            yield rows, where, state.active[where], state.stick[where], state.traction[where]
            start += len(rows.w)

    def _state(self, bound_function):
        """The law at every vertex row for the current u, with the bound of ``bound_function``."""
        values = lambda f: versions.petsc_vec(f)
        e_vec, t_vec, t_prev = self.work[0], self.work[2], self.work[3]
        self.N.mult(values(bound_function), e_vec)
        e_vec.axpy(-1.0, self.g_vec)
        depth = np.maximum(e_vec.getArray(readonly=True), 0.0)
        self.T.mult(values(self.u), t_vec)
        self.T.mult(values(self.law.previous), t_prev)
        slip = (t_vec.getArray(readonly=True) - t_prev.getArray(readonly=True)).reshape(-1, self.gdim)
        memory = self.law.previous_traction.x.array.reshape(-1, self.gdim)[self.local]
        return LawState(depth, slip, memory, self.mu_c_n, self.m_n, float(np.asarray(self.law.epsilon.value)))

    def destroy(self):
        for obj in (self.T, self.N, self.T0, self.N0, self.g_vec, *self.work):
            if obj is not None:
                obj.destroy()


class LawState:
    """The regularised law at n points (the module's formulas), from the penetration (u_n − g_0)_+ of the
    bound, the slip increment Δu_t, the memory σ_t,prev, μ c_n, m_n and ε_r."""

    def __init__(self, depth, slip_increment, memory, mu_c_n, m_n, epsilon_r):
        self.depth, self.mu_c_n, self.m_n, self.epsilon_r, self.memory = depth, mu_c_n, m_n, epsilon_r, memory
        self.bound = mu_c_n * depth ** m_n
        self.length = epsilon_r * depth
        self.active = (depth > 0) & (self.bound > 0)
        safe = np.where(self.active, self.bound, 1.0)
        self.compliance = np.where(self.active, self.length / safe, 0.0)  # ε/F
        self.s = slip_increment - self.compliance[:, None] * memory
        self.size = np.linalg.norm(self.s, axis=1)
        self.stick = self.active & (self.size <= self.length)
        scale = np.where(self.active, self.bound / np.maximum(np.maximum(self.size, self.length), 1e-300), 0.0)
        self.traction = -scale[:, None] * self.s

    def dissipation(self):
        """F ψ_ε(s): |s|²/(2ε) F in stick, F(|s| − ε/2) in slip, 0 out of contact."""
        length = np.where(self.active, self.length, 1.0)
        huber = np.where(self.stick, self.size ** 2 / (2 * length), self.size - 0.5 * length)
        return np.where(self.active, self.bound * huber, 0.0)

    def _slip_direction(self):
        size = np.where(self.size > 0, self.size, 1.0)
        return self.s / size[:, None], np.where(self.active & ~self.stick, self.bound / size, 0.0)

    def hessian(self, stiffened=False):
        """D (n, gdim, gdim): −∂σ_t/∂s, F/ε I in stick, F/|s| (I − ŝŝᵀ) in slip (+ κ F ε/|s|² ŝŝᵀ stiffened)."""
        n, gdim = self.s.shape
        eye = np.broadcast_to(np.eye(gdim), (n, gdim, gdim))
        direction, slip_scale = self._slip_direction()
        outer = direction[:, :, None] * direction[:, None, :]
        stick_scale = np.where(self.stick, self.bound / np.where(self.stick, self.length, 1.0), 0.0)
        D = stick_scale[:, None, None] * eye + slip_scale[:, None, None] * (eye - outer)
        if stiffened:
            size = np.where(self.size > 0, self.size, 1.0)
            extra = np.where(self.active & ~self.stick, SLIP_STIFFENING * self.bound * self.length / size ** 2, 0.0)
            D = D + extra[:, None, None] * outer
        return D

    def bound_derivative(self):
        """c (n, gdim): −∂σ_t/∂(u_n) through the bound at fixed Δu_t (F, ε and the compliance ε/F all depend
        on the penetration): s dS − S dk σ_prev in stick (S = F/ε, k = ε/F), ŝ F' − D dk σ_prev in slip."""
        depth = np.where(self.active, self.depth, 1.0)
        m, k = self.m_n, self.mu_c_n
        dk = np.where(self.active & (m != 1.0), self.epsilon_r / np.where(k > 0, k, 1.0) * (1 - m) * depth ** (-m), 0.0)
        dS = np.where(self.active & (m != 1.0), k * (m - 1) * depth ** (m - 2) / self.epsilon_r, 0.0)
        dF = np.where(self.active, k * m * depth ** (m - 1), 0.0)
        S = np.where(self.stick, self.bound / np.where(self.stick, self.length, 1.0), 0.0)
        direction, slip_scale = self._slip_direction()
        stick = self.s * dS[:, None] - (S * dk)[:, None] * self.memory
        tangent_memory = self.memory - np.einsum("ni,ni->n", direction, self.memory)[:, None] * direction
        slip = direction * dF[:, None] - (slip_scale * dk)[:, None] * tangent_memory
        return np.where(self.stick[:, None], stick, np.where((self.active & ~self.stick)[:, None], slip, 0.0))


def _vertex_rows(comm, space, pair, side, own, other):
    """The rows of ``own``'s owned vertices (:func:`_vertices_and_projection`) with the pair's law."""
    local, x, measure, own_normal, projection = kept(space.mesh, ("vertices", pair.ids, side), partial(
        _vertices_and_projection, comm, space, own, other))
    normal = faces.pair_normal(own_normal, projection.normal)
    gap = np.einsum("ij,ij->i", projection.point - x, normal) + pair.offset
    weight = measure * (0.5 if pair.passes == "two" else 1.0 if side == 0 else 0.0)
    if pair.search_distance is not None:
        weight = np.where(projection.distance > pair.search_distance, 0.0, weight)
    c_n = _values(pair.c_n, x, pair.parameters)
    mu = _values(pair.friction, x, pair.parameters)
    if not np.all(np.isfinite(mu)) or np.any(mu < 0):
        raise InputError(f"pairs[{pair.number}].friction must be finite and >= 0 on '{pair.names[side]}'")
    return VertexRows(pair, side, local, x, measure, weight, normal, gap, mu * c_n, pair.m_n, projection)


def _vertices_and_projection(comm, space, own, other):
    """The owned vertices of ``own`` (local dof blocks, coordinates) with their lumped measures and normals
    (summed over the facets of every rank that has some), and their projections onto ``other``."""
    gdim = own.vertices.shape[2]
    index_map = space.dofmap.index_map
    sums = dolfinx.la.vector(index_map, bs=1 + 2 * gdim)  # m_x, ∫ ν φ_x, m_x x
    table = sums.array.reshape(-1, 1 + 2 * gdim)
    share = own.sizes / own.vertices.shape[1]
    for j in range(own.vertices.shape[1]):
        np.add.at(table, own.local_dofs[:, j], np.column_stack(
            [share, share[:, None] * own.normals, share[:, None] * own.vertices[:, j]]))
    sums.scatter_reverse(versions.SCATTER_ADD)
    owned = table[:index_map.size_local]
    local = np.flatnonzero(owned[:, 0] > 0)
    measure = owned[local, 0]
    normal = owned[local, 1:1 + gdim]
    normal = normal / np.linalg.norm(normal, axis=1)[:, None]
    x = owned[local, 1 + gdim:] / measure[:, None]
    return local, x, measure, normal, search.project(comm, x, other)


def _values(expression, x, parameters):
    return np.broadcast_to(values_at(str(expression), x, parameters), (len(x),)).astype(float) \
        if len(x) else np.zeros(0)
