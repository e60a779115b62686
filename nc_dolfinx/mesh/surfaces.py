"""The true shape of a boundary group: surfaces given by a level-set function φ with φ = 0 on the surface,
and the projection of points onto one surface or onto the intersection of several.

Every surface gives φ(x) and its gradient ∇φ(x) for points x (n, gdim):

- :class:`Plane` (a point, a normal), :class:`Sphere` (a centre, a radius; a circle in 2D) and
  :class:`Cylinder` (a point of the axis, its direction, a radius; 3D): φ is the signed distance,
  |∇φ| = 1;
- :class:`Implicit`: φ is an expression of the coordinates and the problem's parameters, written in the
  problem file; its gradient is derived symbolically (sympy, from the same checked syntax tree as every
  other expression: :func:`nc_dolfinx.problem.expressions.to_sympy`), never typed by the user;
- :class:`~nc_dolfinx.mesh.cad.CadSurface` (in :mod:`.cad`): gmsh's closest point on CAD entities.

:func:`project` finds the closest points on the intersection of surfaces: Gauss–Newton steps of minimal
norm, x ← x − ∇Φᵀ(∇Φ ∇Φᵀ)⁺ Φ(x) (Φ the surfaces' φ stacked), reach it (quadratically for any smooth φ with
∇φ ≠ 0 there), then the move's tangential part is taken out until it is normal to them: onto the common
curve where a vertex lies on two groups (a sphere and a symmetry plane), the common point on three.
"""
import numpy as np

from ..errors import InputError

PROJECTION_STEPS = 40        # Gauss–Newton steps (and closest-point passes) at most
PROJECTION_TOLERANCE = 1e-14  # |φ|/|∇φ| at the end, relative to the size of the body


class Surface:
    """A smooth surface {φ = 0}: ``phi(x)`` (n,), ``gradient(x)`` (n, gdim); ``name`` for messages."""
    name = "surface"
    analytic = True  # φ is a distance (|∇φ| = 1): |φ| is the distance of a point from the surface

    def phi(self, x):
        raise NotImplementedError

    def gradient(self, x):
        raise NotImplementedError

    def distance(self, x):
        """The distance of points x (n, gdim) from the surface (to second order for an implicit φ)."""
        if self.analytic:
            return np.abs(self.phi(x))
        return np.linalg.norm(x - project(x, [self]), axis=1)

    def closest(self, x):
        """The closest points of the surface to x (n, gdim)."""
        return project(x, [self])


class Plane(Surface):
    """The plane through ``point`` normal to ``normal``: φ = (x − point)·n, n = normal/|normal|."""
    name = "plane"

    def __init__(self, point, normal):
        self.point = np.asarray(point, float)
        self.normal = _unit(normal, "the normal")

    def phi(self, x):
        return (x - self.point) @ self.normal

    def gradient(self, x):
        return np.broadcast_to(self.normal, x.shape).copy()


class Sphere(Surface):
    """The sphere (a circle in 2D) of ``centre`` and ``radius``: φ = |x − centre| − radius."""

    def __init__(self, centre, radius):
        self.centre, self.radius = np.asarray(centre, float), float(radius)
        self.name = "circle" if len(self.centre) == 2 else "sphere"

    def phi(self, x):
        return np.linalg.norm(x - self.centre, axis=1) - self.radius

    def gradient(self, x):
        return _radial(x - self.centre)


class Cylinder(Surface):
    """The circular cylinder of ``radius`` around the axis through ``centre`` along ``axis`` (3D):
    φ = |P(x − centre)| − radius, P the projection normal to the axis."""
    name = "cylinder"

    def __init__(self, centre, axis, radius):
        self.centre, self.axis, self.radius = np.asarray(centre, float), _unit(axis, "the axis"), float(radius)

    def _off_axis(self, x):
        d = x - self.centre
        return d - np.outer(d @ self.axis, self.axis)

    def phi(self, x):
        return np.linalg.norm(self._off_axis(x), axis=1) - self.radius

    def gradient(self, x):
        return _radial(self._off_axis(x))


class Implicit(Surface):
    """{φ = 0} for φ an expression of the coordinates (and the problem's parameters), e.g.
    ``"x**2/4 + (y - 1)**2 - 1"`` (an ellipse); ∇φ is derived symbolically (sympy)."""
    name = "implicit"
    analytic = False

    def __init__(self, text, parameters, gdim):
        import sympy  # on first use: it costs an import of 0.3 s
        from ..problem.expressions import COORDINATES, to_sympy
        symbols = sympy.symbols(COORDINATES[:gdim])
        expression = to_sympy(text, dict(zip(COORDINATES, symbols)), parameters)
        self.text = text
        self._phi = sympy.lambdify(symbols, expression, "numpy")
        self._gradient = [sympy.lambdify(symbols, sympy.diff(expression, s), "numpy") for s in symbols]

    def phi(self, x):
        with np.errstate(all="ignore"):
            return np.broadcast_to(np.asarray(self._phi(*x.T), float), (len(x),)).copy()

    def gradient(self, x):
        with np.errstate(all="ignore"):
            return np.column_stack([np.broadcast_to(np.asarray(g(*x.T), float), (len(x),)) for g in self._gradient])


def _unit(vector, what):
    vector = np.asarray(vector, float)
    length = np.linalg.norm(vector)
    if not length > 0:
        raise InputError(f"{what} must not be the zero vector")
    return vector / length


def _radial(d):
    """d/|d|, and an arbitrary unit vector where d = 0 (the centre: every direction is as near)."""
    length = np.linalg.norm(d, axis=1)
    out = np.zeros_like(d)
    out[:, 0] = 1.0
    nonzero = length > 0
    out[nonzero] = d[nonzero] / length[nonzero, None]
    return out


def project(x, surfaces, scale=1.0):
    """The closest points to x (n, gdim) on the intersection of ``surfaces`` (the same for every point).
    Gauss–Newton steps of minimal norm reach the intersection (:func:`_onto`); where φ is not a distance
    the point they reach is not the closest, so the distance's tangential part is then taken out and the
    surfaces reached again, until the move from x is normal to them (the closest point's condition; linear
    convergence at the rate distance × curvature, one pass for a plane or a sphere).
    ``scale``: the body's size, for the tolerances. Raises InputError where a point does not reach its
    surfaces (φ without a zero near it, ∇φ = 0)."""
    start = np.array(x, dtype=float)
    on = _onto(start.copy(), surfaces, scale)
    for _ in range(PROJECTION_STEPS):
        gradients = np.stack([s.gradient(on) for s in surfaces], axis=1)  # (n, k, gdim)
        offset = start - on
        tangential = offset - np.einsum("nkg,nk->ng", gradients, _solve_normal_equations(
            gradients, np.einsum("nkg,ng->nk", gradients, offset)))
        if np.all(np.linalg.norm(tangential, axis=1) <= PROJECTION_TOLERANCE * scale):
            return on
        on = _onto(on + tangential, surfaces, scale)
    return on


def _onto(x, surfaces, scale):
    """x moved onto the intersection of ``surfaces`` by Gauss–Newton steps of minimal norm (in place)."""
    if len(x) == 0:
        return x
    tolerance = PROJECTION_TOLERANCE * scale
    active = np.arange(len(x))
    for _ in range(PROJECTION_STEPS):
        values = np.column_stack([s.phi(x[active]) for s in surfaces])            # (m, k)
        gradients = np.stack([s.gradient(x[active]) for s in surfaces], axis=1)  # (m, k, gdim)
        lengths = np.linalg.norm(gradients, axis=2)
        done = np.all(np.abs(values) <= tolerance * np.maximum(lengths, 1e-300), axis=1) \
            & np.all(np.isfinite(values), axis=1)
        active = active[~done]
        if not len(active):
            return x
        values, gradients = values[~done], gradients[~done]
        x[active] -= np.einsum("mkg,mk->mg", gradients, _solve_normal_equations(gradients, values))
    raise InputError(f"the {surfaces[0].name} surface: {len(active)} point(s), e.g. "
                     f"({', '.join(f'{c:.6g}' for c in x[active[0]])}), do not reach it in {PROJECTION_STEPS} "
                     "Newton steps (no zero of φ near them, or ∇φ = 0 there)")


def _solve_normal_equations(gradients, values):
    """(G Gᵀ)⁺ φ for each point: the multipliers of the minimal-norm step (a pseudo-inverse, since two
    groups may share one surface and give equal rows)."""
    gram = np.einsum("mkg,mlg->mkl", gradients, gradients)
    return np.einsum("mkl,ml->mk", np.linalg.pinv(gram, rcond=1e-10), values)
