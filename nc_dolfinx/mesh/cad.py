"""The true shape from CAD: a boundary group's surface as gmsh sees the CAD it was meshed from.

Two sources, one mechanism:
- a gmsh model built through the API (:func:`nc_dolfinx.from_gmsh_model`, OpenCASCADE kernel): its CAD is
  written as BREP on the rank that built it and sent to every rank with the mesh;
- a ``.msh`` with the CAD file it was meshed from, ``mesh.cad`` in the problem file: BREP, STEP or IGES,
  which gmsh reads without running anything (a ``.geo`` script is refused).

Which CAD entities hold a group is found geometrically, not by tags: the entities of the group's dimension
that hold whole level-0 facets of it (:func:`entities_under`; a symmetry plane that meets a spherical cap
along its rim holds none of the cap's facets). A :class:`CadSurface` then answers what
:mod:`.surfaces` asks of a surface: φ(x) = (x − c(x))·n(c(x)) and ∇φ = n, with c(x) gmsh's closest point on
the nearest of the group's entities and n its normal there (from the closest points of nearby points) — the
signed distance to the tangent plane, so
that the projections of :func:`~nc_dolfinx.mesh.surfaces.project` land on the CAD. Each rank reads the CAD
into a gmsh model of its own for each query (what it snaps is its own vertices).
"""
import contextlib
import os
import tempfile

import numpy as np

from ..errors import InputError, brief_text
from . import gmsh_io
from .gmsh_io import gmsh_session, import_gmsh
from .surfaces import Surface

SUFFIXES = (".brep", ".step", ".stp", ".iges", ".igs")
NORMAL_STEP = 1e-5  # × the coordinates' size: the offsets whose closest points give the normal


class Cad:
    """A CAD file's contents (``data``: bytes) and its kind (``suffix``), as gmsh reads it."""

    def __init__(self, data, suffix):
        self.data, self.suffix = data, suffix

    @classmethod
    def read(cls, path):
        """The CAD file at ``path``; one clear error for a kind gmsh would have to run, or a missing file."""
        suffix = os.path.splitext(str(path))[1].lower()
        if suffix not in SUFFIXES:
            raise InputError(f"mesh.cad = '{brief_text(path)}': a CAD file must be BREP, STEP or IGES "
                             f"({', '.join(SUFFIXES)}); a .geo script is never run")
        try:
            with open(path, "rb") as file:
                return cls(file.read(), suffix)
        except OSError as err:
            raise InputError(f"mesh.cad: cannot read '{brief_text(path)}': {err.strerror}") from None

    @contextlib.contextmanager
    def opened(self):
        """gmsh with this CAD in a model of its own (the caller's gmsh session and model, if any, kept)."""
        gmsh = import_gmsh()
        with _session(gmsh):
            previous = _current_model(gmsh)
            with tempfile.NamedTemporaryFile(suffix=self.suffix) as file:
                file.write(self.data)
                file.flush()
                gmsh.model.add("nc_dolfinx_cad")
                gmsh.merge(file.name)
            try:
                yield gmsh
            finally:
                gmsh.model.remove()
                if previous:
                    gmsh.model.setCurrent(previous)


@contextlib.contextmanager
def _session(gmsh):
    """A gmsh session: the caller's if gmsh is initialised already (gmsh ≥ 4.9 says so; 4.8, bookworm's, has
    no isInitialized: there only a session of ours counts, and a caller's own session should be finalised
    before refining), else one of its own."""
    if gmsh_io.in_session() or (hasattr(gmsh, "isInitialized") and gmsh.isInitialized()):
        yield
        return
    with gmsh_session():
        gmsh.option.setNumber("General.Terminal", 0)
        yield


def _current_model(gmsh):
    try:
        return gmsh.model.getCurrent()
    except Exception:
        return None


def entities_under(cad, facets, dim, tolerance):
    """The tags of the CAD entities of dimension ``dim`` that hold a whole facet of ``facets`` (their vertices,
    (n, k, 3): an entity that only meets the group along its rim, a symmetry plane say, holds none), and each
    vertex's distance from the nearest of them (n, k)."""
    if len(facets) == 0:
        return [], np.zeros(facets.shape[:2])
    points = facets.reshape(-1, 3)
    with cad.opened() as gmsh:
        tags = [tag for _, tag in gmsh.model.getEntities(dim)]
        distances = np.array([_closest(gmsh, dim, tag, points)[1].reshape(facets.shape[:2]) for tag in tags])
    holds = [bool(np.any(np.all(d <= tolerance, axis=1))) for d in distances]
    near = [tag for tag, held in zip(tags, holds) if held]
    if not near:
        return [], np.full(facets.shape[:2], np.inf)
    return near, distances[np.array(holds)].min(axis=0)


def _closest(gmsh, dim, tag, points):
    """gmsh's closest points of entity ``tag`` to ``points`` (n, 3) and their distances."""
    closest, _ = gmsh.model.getClosestPoint(dim, tag, np.ascontiguousarray(points, float).ravel())
    closest = np.asarray(closest).reshape(-1, 3)
    return closest, np.linalg.norm(closest - points, axis=1)


class CadSurface(Surface):
    """The surface of a boundary group on the CAD: the entities ``tags`` of dimension ``dim`` (2 in 3D, 1
    in 2D) of ``cad``. φ and ∇φ as the module says; one gmsh query serves φ and ∇φ at the same points."""
    name = "CAD surface"

    def __init__(self, cad, dim, tags):
        self.cad, self.dim, self.tags = cad, dim, list(tags)
        self._last = (None, None, None)

    def _closest_and_normal(self, x):
        key = x.tobytes()
        if self._last[0] != key:
            points = np.zeros((len(x), 3))
            points[:, :x.shape[1]] = x
            with self.cad.opened() as gmsh:
                closest, normal = self._query(gmsh, points)
            self._last = (key, closest[:, :x.shape[1]], normal[:, :x.shape[1]])
        return self._last[1], self._last[2]

    def _query(self, gmsh, points):
        """The closest points on the nearest entity and the unit normals there. The normal comes from the
        closest points of nearby points x ± δ e_i (their moves span the tangent space): gmsh's inverse surface
        mapping (getParametrization, which getNormal needs) fails near a sphere's poles and seams."""
        gdim = 3 if self.dim == 2 else 2
        if len(points) == 0:
            return points.copy(), points.copy()
        delta = NORMAL_STEP * max(1.0, float(np.abs(points).max()))
        found = [_closest(gmsh, self.dim, tag, points) for tag in self.tags]
        nearest = np.argmin([d for _, d in found], axis=0)
        pick = lambda candidates: np.stack([candidates[k][i] for i, k in enumerate(nearest)])  # noqa: E731
        closest = pick([c for c, _ in found])
        moves = []
        for axis in range(gdim):  # central differences: the normal to O(δ² κ²)
            ahead, behind = points.copy(), points.copy()
            ahead[:, axis] += delta
            behind[:, axis] -= delta
            moves.append(pick([_closest(gmsh, self.dim, tag, ahead)[0] for tag in self.tags])
                         - pick([_closest(gmsh, self.dim, tag, behind)[0] for tag in self.tags]))
        moves = np.stack(moves, axis=1)[:, :, :gdim]  # (n, gdim, gdim): its rows span the tangent space
        normal = np.zeros_like(points)
        normal[:, :gdim] = np.linalg.svd(moves)[2][:, -1]  # the direction the moves do not take
        return closest, normal

    def phi(self, x):
        closest, normal = self._closest_and_normal(x)
        return np.sum((x - closest) * normal, axis=1)

    def gradient(self, x):
        return self._closest_and_normal(x)[1].copy()

    def distance(self, x):
        closest, _ = self._closest_and_normal(x)
        return np.linalg.norm(x - closest, axis=1)
