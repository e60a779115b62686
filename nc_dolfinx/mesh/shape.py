"""The true shape of the boundary, beside refinement: which surface each boundary group lies on, and the
new vertices of a refined mesh placed on it.

Refinement bisects edges: a new vertex lies at the midpoint of its parent edge, so without more the body's
boundary stays the level-0 polygon (polyhedron) however far the adaptive loop goes, and on a curved Γ_C
(a ball, a roller) the loop converges, η falling all the way, to the contact of a *faceted* body. Here:

- :func:`resolve` gives each boundary group of a level-0 :class:`~nc_dolfinx.mesh.domain.Domain` its
  :class:`Shapes` entry: the surface of ``[mesh.shapes]`` (:mod:`.surfaces`: plane, circle, sphere,
  cylinder, an implicit φ(x) = 0); else a plane where the group's level-0 facets are coplanar (found, not
  asked for); else the CAD's surfaces under its vertices (:mod:`.cad`: ``mesh.cad``, or a gmsh model's);
  else nothing, and the group is *faceted*: its level-0 sag
  (how far its facets depart from the smooth surface through their vertices, :func:`facet_sag`) is kept
  for the warning and for the estimator's geometric term. Level-0 vertices must lie on their given
  surface (``mesh.shape_tolerance`` × the body's size), else an error names the group and the distance.
- :func:`snap`, after every refinement, moves each boundary vertex onto the intersection of the surfaces of
  all the groups whose facets meet there (a vertex on the rim of a spherical cap and a symmetry plane stays
  in the plane) — unless one of them is faceted, then it stays where refinement put it. Each rank moves its
  own (owned and ghost) vertices by the same function of the coordinates and of the groups around the vertex
  (gathered across ranks by one reverse scatter): nothing of global size is gathered, and the result does
  not depend on the rank count. If a moved cell inverts or loses more than half its quality, the boundary's
  move is extended into the interior harmonically (one Laplace solve; measured rarely needed, since the move
  is the sagitta h²/8R); a cell that still inverts is an error.

Transfer between levels is untouched: a child vertex keeps its place *in the parent's cells* (a midpoint
of a parent edge), so the values carried to it (the displacement, the friction law's memory) are those at
the midpoint — the reference-cell transfer of deal.II's manifolds; :func:`snap` returns the coordinates
before the move for :func:`nc_dolfinx.mesh.refinement.transfer`.
"""
from dataclasses import dataclass, field

import dolfinx
import numpy as np
import ufl
from mpi4py import MPI

from dolfinx import fem

from .. import dolfinx_versions as versions
from ..errors import InputError, brief_text
from .domain import UNTAGGED, cells_of_facets, dof_of_node, global_bounds
from .surfaces import Cylinder, Implicit, Plane, Sphere, project


KINDS = ("plane", "circle", "sphere", "cylinder", "implicit")
FLAT_TOLERANCE = 1e-10    # × the body's size: a group whose level-0 facets are this close to one plane is flat
ON_SURFACE = 1e-12        # × the body's size: a vertex this close to its surfaces is not moved
CORNER_ANGLE = np.radians(30)  # a normal turning more than this at a vertex is an edge of the body, not a curve
VISIBLE_ANGLE = np.radians(0.5)  # a faceted group whose normals turn more than this gets a warning
FACETED_FRACTION = 0.1    # ... and a second one after level 0 where its sag exceeds this part of the penetration
QUALITY_KEPT = 0.5        # a snapped cell keeping less than this of its quality moves the interior too
QUALITY_FLOOR = 0.05      # ... and after that, less than this is an error


@dataclass
class Shapes:
    """The shape of each boundary group of a mesh: ``surfaces`` (group id → Surface: given, or the plane
    of a flat group), ``given`` (the ids whose surface the problem or the CAD gave), ``sag`` (group id → the
    largest sag of its level-0 facets, for the faceted groups: no surface), ``angle`` (their largest turn
    of the normal between neighbouring facets, radians), ``scale`` (the body's size)."""
    surfaces: dict
    given: frozenset
    sag: dict = field(default_factory=dict)
    angle: dict = field(default_factory=dict)
    scale: float = 1.0

    @property
    def curved(self):
        """Whether any group has a given surface that is not a plane (else refinement moves nothing)."""
        return any(not isinstance(self.surfaces[i], Plane) for i in self.given)


# --- level 0 ---------------------------------------------------------------------------------------

def resolve(domain, problem=None, extra=None):
    """The true shape of each boundary group of a level-0 ``domain``, on which Plaza refinement
    (:func:`nc_dolfinx.refine`) then places the new boundary vertices: from ``problem``'s ``[mesh.shapes]``
    (and ``extra``: group id → Surface, e.g. ``nc_dolfinx.mesh.surfaces.Sphere``), else a plane where a
    group is flat, else the CAD's (``mesh.cad``, or a gmsh model's). Set as ``domain.shapes`` (a
    :class:`Shapes`) and returned; checks that the level-0 vertices lie on their surfaces (InputError naming
    the group and the distance). A domain that has its shapes keeps them; :func:`nc_dolfinx.bind` calls this."""
    if domain.shapes is not None:
        return domain.shapes
    msh = domain.mesh
    gdim = msh.geometry.dim
    low, high = global_bounds(domain.comm, msh.geometry.x[:, :gdim])
    scale = float(np.max(high - low)) if np.all(np.isfinite(low)) else 1.0
    given = dict(extra or {})
    if problem is not None:
        spec = problem.values["mesh"].get("shapes") or {}
        given.update({_group_id(domain, name): surface_of(spec[name], gdim, problem.parameters,
                                                           f"mesh.shapes.{name}") for name in spec})
        tolerance = problem.values["mesh"]["shape_tolerance"] * scale
    else:
        tolerance = DEFAULT_TOLERANCE * scale
    facets = _facets_by_group(domain)
    none = np.zeros(0, np.int32)
    for group_id, surface in given.items():
        _check_on_surface(domain, group_id, surface, facets.get(group_id, none), tolerance)
    cad = _cad_of(domain, problem)
    found = {}
    for group_id in _all_groups(domain):
        if group_id in given:
            continue
        plane = _plane_of(domain, facets.get(group_id, none), scale)
        surface = plane if plane is not None or cad is None else \
            _cad_surface(domain, cad, group_id, facets.get(group_id, none), tolerance)
        if surface is not None:
            found[group_id] = surface
    curved_found = {i for i, s in found.items() if not isinstance(s, Plane)}
    shapes = Shapes({**given, **found}, frozenset(given) | frozenset(curved_found), scale=scale)
    for group_id in _all_groups(domain):
        if group_id not in shapes.surfaces:
            shapes.sag[group_id], shapes.angle[group_id] = _level0_sag(domain, facets.get(group_id, none))
    domain.shapes = shapes
    return shapes


def _cad_of(domain, problem):
    """The problem's ``mesh.cad`` (read on every rank), else the CAD the domain came with, else None."""
    path = problem.values["mesh"].get("cad") if problem is not None else None
    if path is None:
        return domain.cad
    from .cad import Cad
    return Cad.read(path)


def _cad_surface(domain, cad, group_id, facets, tolerance):
    """The CAD entities that hold whole level-0 facets of a group as its surface (None if there are none); a
    vertex on none of them is an error naming the group."""
    from .cad import CadSurface, entities_under
    msh = domain.mesh
    points = msh.geometry.x[versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)]  # (n, tdim, 3)
    tags, distance = entities_under(cad, points, msh.topology.dim - 1, tolerance)
    tags = sorted(set().union(*domain.comm.allgather(tags)))
    worst = domain.comm.allreduce(float(distance.max()) if len(distance) else 0.0, MPI.MAX)
    if not tags:
        return None
    if not worst <= tolerance:
        name = _name(domain, group_id)
        raise InputError(f"mesh.cad: a level-0 vertex of group '{name}' lies {worst:.3g} from every surface of the "
                         f"CAD (tolerance {tolerance:.3g}): the mesh was not made from this CAD")
    return CadSurface(cad, msh.topology.dim - 1, tags)


DEFAULT_TOLERANCE = 1e-6


def surface_of(spec, gdim, parameters, where):
    """The Surface of one group's ``[mesh.shapes.GROUP]`` table (exactly one kind in it)."""
    kinds = [kind for kind in KINDS if spec.get(kind) is not None]
    if len(kinds) != 1:
        raise InputError(f"{where} must give exactly one of {', '.join(KINDS)}, got "
                         f"{', '.join(kinds) if kinds else 'none'}")
    kind, value = kinds[0], spec[kinds[0]]
    wanted = {"circle": 2, "sphere": 3, "cylinder": 3}.get(kind)
    if wanted is not None and wanted != gdim:
        other = {"circle": "sphere", "sphere": "circle", "cylinder": "circle"}[kind]
        raise InputError(f"{where}.{kind}: the mesh is {gdim}D, a {kind} is a {wanted}D shape (use {other})")
    for key in ("centre", "point", "normal", "axis"):
        if key in value and len(value[key]) != gdim:
            raise InputError(f"{where}.{kind}.{key} has {len(value[key])} components but the mesh is {gdim}D")
    try:
        return _SURFACES[kind](value, parameters, gdim)
    except InputError as err:
        raise InputError(f"{where}.{kind}: {err}") from None


_SURFACES = {
    "plane": lambda v, parameters, gdim: Plane(v["point"], v["normal"]),
    "circle": lambda v, parameters, gdim: Sphere(v["centre"], v["radius"]),
    "sphere": lambda v, parameters, gdim: Sphere(v["centre"], v["radius"]),
    "cylinder": lambda v, parameters, gdim: Cylinder(v["centre"], v["axis"], v["radius"]),
    "implicit": Implicit,
}


def _group_id(domain, name):
    if name in domain.facet_groups:
        return domain.facet_groups[name]
    if name.isdigit() and int(name) in domain.facet_groups.values():
        return int(name)
    raise InputError(f"mesh.shapes.{brief_text(name)}: no boundary group of that name in the mesh (groups: "
                     f"{', '.join(sorted(domain.facet_groups))})")


def _all_groups(domain):
    return sorted({UNTAGGED, *domain.facet_groups.values()})


def _facets_by_group(domain):
    tags = domain.facet_tags
    return {int(g): tags.indices[tags.values == g] for g in np.unique(tags.values)}


def facet_points(msh, facets):
    """The vertices of local facets, (n, tdim, gdim)."""
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)
    return msh.geometry.x[nodes.reshape(-1), :msh.geometry.dim].reshape(len(facets), msh.topology.dim,
                                                                        msh.geometry.dim)


def _check_on_surface(domain, group_id, surface, facets, tolerance):
    points = facet_points(domain.mesh, facets).reshape(-1, domain.mesh.geometry.dim)
    distance = surface.distance(points) if len(points) else np.zeros(0)
    worst = float(distance.max()) if len(distance) else 0.0
    worst_everywhere = domain.comm.allreduce(worst, MPI.MAX)
    if not worst_everywhere <= tolerance:  # (NaN too)
        name = _name(domain, group_id)
        raise InputError(f"mesh.shapes.{name}: a level-0 vertex of group '{name}' lies {worst_everywhere:.3g} "
                         f"from its {surface.name} (tolerance {tolerance:.3g}, mesh.shape_tolerance × the body's "
                         "size): the shape does not describe this boundary")


def _name(domain, group_id):
    names = {i: name for name, i in domain.facet_groups.items()}
    return names.get(group_id, "(untagged)" if group_id == UNTAGGED else str(group_id))


def facet_normals(msh, facets):
    """Unit normals of local boundary facets, pointing out of their cell."""
    points = facet_points(msh, facets)
    gdim = msh.geometry.dim
    if gdim == 2:
        t = points[:, 1] - points[:, 0]
        n = np.column_stack([t[:, 1], -t[:, 0]])
    else:
        n = np.cross(points[:, 1] - points[:, 0], points[:, 2] - points[:, 0])
    n /= np.linalg.norm(n, axis=1)[:, None]
    _, cells, _ = cells_of_facets(msh, facets)
    cell_nodes = versions.geometry_nodes(msh)[cells]
    inside = msh.geometry.x[cell_nodes.reshape(-1), :gdim].reshape(len(cells), -1, gdim).mean(axis=1)
    outward = np.sign(np.sum((points.mean(axis=1) - inside) * n, axis=1))
    return n * outward[:, None]


def _plane_of(domain, facets, scale):
    """The plane of a group whose level-0 facets all lie in one plane (the same on every rank), else None."""
    msh, comm = domain.mesh, domain.comm
    local = None
    if len(facets):
        local = (facet_points(msh, facets[:1])[0, 0], facet_normals(msh, facets[:1])[0])
    candidates = [c for c in comm.allgather(local) if c is not None]
    if not candidates:
        return None
    plane = Plane(*candidates[0])
    points = facet_points(msh, facets).reshape(-1, msh.geometry.dim)
    flat = bool(np.all(np.abs(plane.phi(points)) <= FLAT_TOLERANCE * scale)) if len(points) else True
    return plane if comm.allreduce(flat, MPI.LAND) else None


def _level0_sag(domain, facets):
    """(sag, angle) of a faceted group: each facet's normal against the mean normal at its vertices (the
    group's facets around each vertex, gathered across ranks) turns by an angle α; on a circle of radius R
    with chords h, α = h/2R and the chord's sag is h²/8R = h α/4. A vertex where some facet turns beyond
    CORNER_ANGLE lies on an edge of the body (two faces of an L-shaped group, say) and is left out for all
    its facets. The largest of each, the same on every rank."""
    msh = domain.mesh
    gdim, k = msh.geometry.dim, msh.topology.dim
    if not domain.comm.allreduce(len(facets), MPI.SUM):
        return 0.0, 0.0
    normals = facet_normals(msh, facets) if len(facets) else np.zeros((0, gdim))
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, facets)
    mean = _sum_at_nodes(msh, nodes, np.repeat(normals[:, None], k, axis=1))[nodes]  # (n, k, gdim)
    mean /= np.maximum(np.linalg.norm(mean, axis=2), 1e-300)[..., None]
    turns = np.arccos(np.clip(np.einsum("ng,nkg->nk", normals, mean), -1.0, 1.0))  # (n, k)
    on_edge = _sum_at_nodes(msh, nodes, (turns > CORNER_ANGLE)[..., None].astype(float))[nodes][..., 0] > 0
    turn = np.where(on_edge, 0.0, turns).max(axis=1) if len(facets) else np.zeros(0)
    sizes = versions.diameters(msh, msh.topology.dim - 1, facets) if len(facets) else np.zeros(0)
    sag = float(np.max(sizes * turn / 4)) if len(facets) else 0.0
    angle = float(2 * turn.max()) if len(facets) else 0.0
    return domain.comm.allreduce(sag, MPI.MAX), domain.comm.allreduce(angle, MPI.MAX)


def _sum_at_nodes(msh, nodes, values):
    """Σ over the entities around each local geometry node of their ``values`` at it (``nodes`` (n, k) the
    entities' nodes, ``values`` (n, k, bs)), summed over every rank's entities: (n_nodes, bs), ghosts too."""
    bs = values.shape[2]
    total = dolfinx.la.vector(msh.geometry.index_map(), bs)
    array = total.array.reshape(-1, bs)
    for c in range(bs):  # (np.bincount: an order of magnitude faster than np.add.at)
        array[:, c] += np.bincount(nodes.ravel(), values[..., c].ravel(), minlength=len(array))
    total.scatter_reverse(versions.SCATTER_ADD)
    total.scatter_forward()
    return array


def faceted_warning(domain, group_id, role):
    """The warning for a faceted group in a role whose facets visibly turn (None if they do not)."""
    shapes = domain.shapes
    if shapes is None or group_id not in shapes.sag or shapes.angle[group_id] <= VISIBLE_ANGLE:
        return None
    name = _name(domain, group_id)
    return (f"boundary group '{name}' ({role}) is given no shape and its level-0 facets are not flat: their normals "
            f"turn by up to {np.degrees(shapes.angle[group_id]):.2g}° between neighbours, a sag of up to "
            f"{shapes.sag[group_id]:.3g}; refinement keeps these facets, so the run converges to the faceted body, "
            f"not to a smooth one — give the true shape in [mesh.shapes.{name}] (plane, circle, sphere, cylinder "
            "or implicit) or the CAD file (mesh.cad); the column geometry_sag reports it")


def faceted_contact_warnings(domain, contact_ids, penetration):
    """After level 0: a warning if a visibly faceted Γ_C group sags by more than FACETED_FRACTION of the
    largest penetration — its facets, not the body, then shape the contact zone (:func:`faceted_warning`
    says how to give the shape). A list of 0 or 1 text."""
    shapes = domain.shapes
    sag = 0.0 if shapes is None else max(
        [shapes.sag[i] for i in contact_ids if i in shapes.sag and shapes.angle[i] > VISIBLE_ANGLE], default=0.0)
    if sag == 0.0 or sag <= FACETED_FRACTION * penetration:
        return []
    against = f"{sag / penetration:.2g} × the largest penetration ({penetration:.3g})" if penetration > 0 else \
        "and nothing penetrates"
    return [f"the level-0 facets of Γ_C depart from a smooth surface by up to {sag:.3g}, {against}: the contact "
            "zone is shaped by the facets, not by the body (give the shape: [mesh.shapes] or mesh.cad)"]


# --- after a refinement ----------------------------------------------------------------------------

def snap(domain):
    """Move the boundary vertices of a Plaza-refined ``domain`` onto their groups' surfaces (``domain.shapes``,
    :func:`resolve`): each onto the intersection of the surfaces of the groups around it, the interior moved
    harmonically only where a cell would lose half its quality. :func:`nc_dolfinx.refine` calls it; returns
    the coordinates before the move if any vertex moved on any rank, else None. Collective."""
    shapes = domain.shapes
    if shapes is None or not shapes.curved:
        return None
    msh = domain.mesh
    gdim = msh.geometry.dim
    groups = _all_groups(domain)
    around = _groups_around_nodes(domain, groups)  # (n_nodes, n_groups) bool
    before = msh.geometry.x.copy()
    boundary = np.flatnonzero(around.any(axis=1))  # only boundary nodes can move (O(n^((d-1)/d)) of them)
    code = around[boundary] @ (1 << np.arange(len(groups), dtype=np.int64))  # each node's groups as one integer
    moved = np.zeros(len(before), dtype=bool)
    for value in np.unique(code):
        here = code == value
        ids = [g for g, present in zip(groups, around[boundary[np.argmax(here)]]) if present]
        if any(g not in shapes.surfaces for g in ids):  # by a faceted group
            continue
        surfaces = list({id(shapes.surfaces[g]): shapes.surfaces[g] for g in ids}.values())
        if all(isinstance(s, Plane) for s in surfaces):  # midpoints of flat facets are on them already
            continue
        nodes = boundary[here]
        x = before[nodes, :gdim]
        off = np.max([np.abs(s.phi(x)) / np.maximum(np.linalg.norm(s.gradient(x), axis=1), 1e-300)
                      for s in surfaces], axis=0) > ON_SURFACE * shapes.scale
        if np.any(off):
            msh.geometry.x[nodes[off], :gdim] = project(x[off], surfaces, shapes.scale)
            moved[nodes[off]] = True
    if not domain.comm.allreduce(bool(moved.any()), MPI.LOR):
        return None
    _keep_cells_valid(domain, before, moved)
    return before


def _groups_around_nodes(domain, groups):
    """For every local geometry node, whether a boundary facet of each group touches it (any rank's)."""
    msh, tags = domain.mesh, domain.facet_tags
    nodes = versions.entities_to_geometry(msh, msh.topology.dim - 1, tags.indices)
    member = np.zeros((len(tags.indices), len(groups)))
    member[np.arange(len(tags.indices)), np.searchsorted(groups, tags.values)] = 1.0
    return _sum_at_nodes(msh, nodes, np.repeat(member[:, None], nodes.shape[1], axis=1)) > 0


def cell_quality(msh, x=None, cells=None):
    """Signed quality of every local cell (or of ``cells``): its volume over that of the regular simplex with
    the same root-mean-square edge (1 for a regular simplex, ≤ 0 for an inverted or flat one)."""
    x = msh.geometry.x if x is None else x
    tdim = msh.topology.dim
    nodes = versions.geometry_nodes(msh)
    points = x[nodes if cells is None else nodes[cells]][:, :, :tdim]  # (n, tdim + 1, tdim): the cells' vertices
    edges = points[:, 1:] - points[:, :1]
    volume = np.linalg.det(edges)
    pairs = [(i, j) for i in range(tdim + 1) for j in range(i + 1, tdim + 1)]
    rms = np.sqrt(np.mean([np.sum((points[:, i] - points[:, j]) ** 2, axis=1) for i, j in pairs], axis=0))
    regular = {2: np.sqrt(3) / 2, 3: 1 / np.sqrt(2)}[tdim]  # det of the regular simplex of unit edge
    return volume / (regular * rms ** tdim)


def _keep_cells_valid(domain, before, moved):
    """After the boundary moved (``moved``: which local nodes): if a cell inverted or lost more than half its
    quality (cells keep their orientation: the sign of det J is compared), extend the boundary's move
    harmonically into the interior; a cell still inverted or below QUALITY_FLOOR of its quality is an error,
    on every rank. Only the cells with a moved node are measured first (the others keep their quality)."""
    msh = domain.mesh
    cells = np.flatnonzero(moved[versions.geometry_nodes(msh)].any(axis=1))
    q_before, q_after = cell_quality(msh, before, cells), cell_quality(msh, cells=cells)
    ratio = q_after / np.where(q_before != 0, q_before, 1.0)
    if not domain.comm.allreduce(bool(np.any(ratio < QUALITY_KEPT)), MPI.LOR):
        return
    q_before = cell_quality(msh, before)
    _extend_harmonically(domain, before)
    ratio = cell_quality(msh) / np.where(q_before != 0, q_before, 1.0)
    worst = domain.comm.allreduce(float(ratio.min()) if len(ratio) else 1.0, MPI.MIN)
    if worst < QUALITY_FLOOR:
        names = ", ".join(f"'{_name(domain, g)}'" for g in sorted(domain.shapes.given))
        raise InputError(f"refinement onto the shape of {names}: a cell keeps {worst:.2g} of its quality even "
                         "with the interior moved along (inverted if ≤ 0): the level-0 mesh is too coarse for the "
                         "surface's curvature there; mesh it finer")


def _extend_harmonically(domain, before):
    """Move the interior nodes by the harmonic extension of the boundary nodes' move (−Δd = 0, d given on
    the whole boundary): one Laplace solve, CG + BoomerAMG to 1e-12."""
    msh = domain.mesh
    gdim = msh.geometry.dim
    V = versions.p1_space(msh, (gdim,))
    at_node = dof_of_node(V)
    move = fem.Function(V)
    move.x.array.reshape(-1, gdim)[at_node] = (msh.geometry.x - before)[:, :gdim]
    msh.geometry.x[:] = before  # the Laplace problem on the mesh before the move (valid cells)
    boundary = fem.locate_dofs_topological(V, msh.topology.dim - 1, domain.facet_tags.indices)
    d, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    zero = fem.Constant(msh, np.zeros(gdim))
    extension = versions.solve_linear_problem(
        ufl.inner(ufl.grad(d), ufl.grad(v)) * ufl.dx, ufl.inner(zero, v) * ufl.dx, [fem.dirichletbc(move, boundary)],
        {"ksp_type": "cg", "pc_type": "hypre", "ksp_rtol": 1e-12, "ksp_atol": 1e-300})
    msh.geometry.x[:, :gdim] += extension.x.array.reshape(-1, gdim)[at_node]


# --- the estimator's geometric term -----------------------------------------------------------------

def facet_sag(domain, facets, groups):
    """δ_F for local boundary ``facets`` of ``groups``: the distance of the facet from its group's surface,
    taken at its centroid and edge midpoints (where a chord with its vertices on the surface departs most);
    0 on a plane; the level-0 sag for a faceted group (refinement does not reduce it)."""
    shapes, msh = domain.shapes, domain.mesh
    out = np.zeros(len(facets))
    if shapes is None:
        return out
    points = facet_points(msh, facets)
    k = points.shape[1]
    probes = [points.mean(axis=1)] + [0.5 * (points[:, i] + points[:, j]) for i in range(k) for j in range(i + 1, k)]
    for group in np.unique(groups):
        here = groups == group
        surface = shapes.surfaces.get(int(group))
        if surface is None:
            out[here] = shapes.sag.get(int(group), 0.0)
        elif not isinstance(surface, Plane):
            out[here] = np.max([surface.distance(p[here]) for p in probes], axis=0)
    return out
