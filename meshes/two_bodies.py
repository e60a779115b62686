#!/usr/bin/env python3
"""Two-body meshes (issue 47): two deformable bodies in ONE .msh file, a disconnected mesh.

Each body is one connected component and one cell group; the bodies share no node (where they touch, each
has its own nodes, coincident or not). Contact pairs name a facet group on each body. Linear simplices, msh
4.1 (ASCII unless said otherwise), physical groups by name as every mesh here (meshes/gmsh_common.py).
What each mesh is for:

``stacked_blocks_2d`` / ``stacked_blocks_3d``
    The contact patch test (issue 47, item 2): the block [0,1]^d-1 x [0, 0.5] ("lower") under the block
    [0,1]^d-1 x [0.5, 1] ("upper"), their faces coincident on the plane (y, in 3D z) = 0.5 and NON-matching
    there: the interior interface nodes of the two sides never coincide (the upper block's nodes are moved
    along the interface by a smooth monotone map, chosen so that they keep their distance from the lower
    side's; only the corners of the face coincide). Uniform pressure on "top" with "bottom" supported must
    come through the interface uniform.
``mirrored``
    The symmetry identity (issue 47, item 6): any one-body mesh ("upper") with its exact mirror image in the
    plane y = axis_value, in 3D z = axis_value ("lower"), nodes mirrored bitwise. Two mirror bodies pressed
    together equal one body on the foundation there with c_n' = 2^m c_n, g_0' = g_0 / 2.
``two_cylinders_2d``
    2D Hertz and Cattaneo-Mindlin between two cylinders (plane strain): two half-discs touching at the
    origin, graded there, with different chord lengths on the two contact arcs.
``cattaneo_cylinders_2d``
    Cattaneo-Mindlin between two identical cylinders (case cattaneo_cylinders): ``two_cylinders_2d`` with
    R1 = R2 = 1, finer at the contact (chords of 0.00075 and 0.000525 within 0.08 of the origin).
``sphere_on_block_3d``
    3D Hertz, a sphere on an elastic half-space: a quarter ball on a quarter block (symmetry planes x = 0,
    y = 0), touching at the origin, graded there.

Normals: the package takes a facet's outward normal from the cell it bounds (not from the orientation of
the facet elements in the file), so e.g. "lower_face" has outward normal +y (+z in 3D) and "upper_face" -y.
Every generated mesh but ``mirrored`` is jittered (``jitter`` x the smallest size, nodes kept exactly on
their planes, and on their curves and surfaces up to round-off) so that no two edges of a face are equally
long: DOLFINx's Plaza refinement then refines alike on any number of ranks (gmsh_common.jitter_nodes).

Run: ``/usr/bin/python3 meshes/two_bodies.py NAME OUT.msh [--h H] [...]``, NAME one of stacked_blocks_2d,
stacked_blocks_3d, two_cylinders_2d, sphere_on_block_3d, mirrored (with ``--input IN.msh [--axis-value A]
[--axis x|y|z]``), cattaneo_cylinders_2d; ``--help`` lists the options. Python:
``import two_bodies; two_bodies.stacked_blocks_2d("out.msh")``.
"""
import argparse
import math
import sys
from pathlib import Path

import gmsh
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gmsh_common import generate_and_write  # noqa: E402

SNAP = 1e-9  # a node this close to one of a model's planes is on it (set exactly onto it)


# --- shared helpers ------------------------------------------------------------------------------

def _start(model):
    gmsh.initialize()
    gmsh.option.setNumber("General.Terminal", 0)
    gmsh.model.add(model)


def _name_groups(cells, facets, dim):
    """Cell groups {name: [entity tags]} as physical groups 1, 2, … of dimension ``dim``, facet groups as
    physical groups 1, 2, … of dimension dim − 1 (each must be non-empty)."""
    for groups, d in ((facets, dim - 1), (cells, dim)):
        for tag, (name, entities) in enumerate(groups.items(), start=1):
            assert entities, f"group {name} is empty"
            gmsh.model.addPhysicalGroup(d, sorted(set(entities)), tag)
            gmsh.model.setPhysicalName(d, tag, name)


def _sizes_from_field(field_tag):
    field = gmsh.model.mesh.field
    field.setAsBackgroundMesh(field_tag)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def _graded_field(h_near, h_far, distance_field, dist_min, growth):
    """A Threshold field: h_near within dist_min of the distance field's objects, growing with slope
    ``growth`` up to h_far."""
    field = gmsh.model.mesh.field
    threshold = field.add("Threshold")
    field.setNumber(threshold, "InField", distance_field)
    field.setNumber(threshold, "SizeMin", h_near)
    field.setNumber(threshold, "SizeMax", h_far)
    field.setNumber(threshold, "DistMin", dist_min)
    field.setNumber(threshold, "DistMax", dist_min + max(h_far - h_near, 0.0) / growth + 1e-12)
    return threshold


def _body_nodes(dim, volumes):
    """Tags of all nodes of the entities ``volumes`` of dimension ``dim`` (with their boundaries)."""
    tags = [gmsh.model.mesh.getNodes(dim, v, includeBoundary=True)[0] for v in volumes]
    return np.unique(np.concatenate(tags)).astype(np.int64)


def _move_nodes(node_tags, mapping):
    """Every node of ``node_tags`` to ``mapping(x)`` (x of shape (n, 3)); parametric coordinates kept."""
    all_tags, coords, _ = gmsh.model.mesh.getNodes()
    x = np.reshape(coords, (-1, 3))
    where = {int(t): i for i, t in enumerate(all_tags)}
    idx = np.array([where[int(t)] for t in node_tags])
    moved = mapping(x[idx].copy())
    for t, p in zip(node_tags, moved):
        uv = gmsh.model.mesh.getNode(int(t))[1]  # (coord, parametric coord[, dim, tag] in gmsh >= 4.10)
        gmsh.model.mesh.setNode(int(t), list(map(float, p)), list(uv))


def _jitter_and_snap(amplitude, planes, tdim, seed=1):
    """Move each node by a random offset of at most ``amplitude`` per coordinate, within its entity, and set
    every node of an entity lying in one of ``planes`` ({axis: [values]}) exactly onto that plane (also with
    amplitude 0: gmsh leaves round-off on planes; in 2D every node gets z = 0).

    Nodes inside a cell entity move freely; nodes on a curve or surface that lies in axis-aligned planes
    move in the free coordinates only (they stay on it exactly); nodes on a curved entity are projected back
    onto it (gmsh's closest point, to round-off), then their planar coordinates set exactly; corner nodes do
    not move. See gmsh_common.jitter_nodes for why (Plaza refinement's ties)."""
    rng = np.random.default_rng(seed)
    if tdim == 2:
        planes = {**planes, 2: [0.0]}
    for dim in range(tdim + 1):
        for _, tag in gmsh.model.getEntities(dim):
            nodes, coords, uvs = gmsh.model.mesh.getNodes(dim, tag, includeBoundary=False)
            if len(nodes) == 0:
                continue
            x = np.reshape(coords, (-1, 3))
            uvs = np.reshape(uvs, (len(nodes), -1))
            everything = np.reshape(gmsh.model.mesh.getNodes(dim, tag, includeBoundary=True)[1], (-1, 3))
            fixed = {}
            for axis, values in planes.items():
                for value in values:
                    if np.all(np.abs(everything[:, axis] - value) < SNAP):
                        fixed[axis] = value
            moved = x.copy()
            parametric = None
            if amplitude > 0 and dim > 0:
                moved = x + rng.uniform(-amplitude, amplitude, x.shape)
                if dim < tdim and len(fixed) < 3 - dim:  # a curved curve or surface: project onto it
                    moved, parametric = gmsh.model.getClosestPoint(dim, tag, moved.ravel())
                    moved = np.reshape(moved, (-1, 3))
                    parametric = np.reshape(parametric, (len(nodes), dim))
            for axis, value in fixed.items():
                moved[:, axis] = value
            for i, (node, p) in enumerate(zip(nodes, moved)):
                uv = parametric[i] if parametric is not None else uvs[i]
                gmsh.model.mesh.setNode(int(node), list(map(float, p)), list(map(float, uv)))


def _separation(a, b):
    """The smallest distance between a number of ``a`` and one of ``b`` (inf if either is empty)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.abs(a[:, None] - b[None, :]).min()) if len(a) and len(b) else np.inf


def _phi(t, alpha):
    """A smooth increasing map of [0, 1] onto itself (|alpha| < 1), identity at 0 and 1."""
    return t + alpha * np.sin(np.pi * t) / np.pi


def _shift_for_separation(n_lower, n_upper):
    """alpha of :func:`_phi` for which the interior nodes phi(j / n_upper) of the upper side are furthest
    from the lower side's k / n_lower (the smallest such alpha within 2 % of the best, over [0, 0.4])."""
    lower = np.arange(1, n_lower) / n_lower
    upper = np.arange(1, n_upper) / n_upper
    alphas = np.linspace(0.0, 0.4, 401)
    seps = np.array([_separation(_phi(upper, a), lower) for a in alphas])
    best = seps.max()
    alpha = float(alphas[np.flatnonzero(seps >= 0.98 * best)[0]])
    return alpha, float(_separation(_phi(upper, alpha), lower))


def _count(h, length=1.0):
    return max(1, int(round(length / h)))


def _report(path, tdim, cells):
    counts = {name: sum(len(gmsh.model.mesh.getElements(tdim, e)[1][0]) for e in entities)
              for name, entities in cells.items()}
    print(f"{path}: " + ", ".join(f"{name} {n} {'triangles' if tdim == 2 else 'tetrahedra'}"
                                  for name, n in counts.items()))


# --- 1. stacked blocks (the contact patch test) -------------------------------------------------------

def stacked_blocks_2d(path, h_lower=1 / 6, h_upper=1 / 9, jitter=0.01):
    """Write the lower block [0,1] x [0,0.5] and the upper block [0,1] x [0.5,1] (separate surfaces, no
    shared node) to ``path``; returns the smallest distance between an interior interface node of one side
    and one of the other (before the jitter).

    Cell groups ``lower``, ``upper``. Facet groups ``bottom`` (y = 0), ``top`` (y = 1), ``lower_left``,
    ``lower_right``, ``upper_left``, ``upper_right`` (x = 0, x = 1), ``lower_face`` (the lower block's side
    y = 0.5, outward normal +y), ``upper_face`` (the upper block's side y = 0.5, outward normal -y).

    Unstructured triangles of size h_lower and h_upper. The interface edges have round(1/h_lower) and
    round(1/h_upper) equal segments, then the whole upper block is mapped by x -> phi(x) = x + alpha
    sin(pi x)/pi (a smooth increasing map of the block onto itself), alpha chosen so that the upper side's
    interface nodes keep their distance from the lower side's (with 1/6 and 1/9 the uniform nodes would
    meet at x = 1/3 and 2/3). Then jittered (``jitter`` x min(h))."""
    return _stacked_blocks(path, 2, h_lower, h_upper, jitter)


def stacked_blocks_3d(path, h_lower=1 / 6, h_upper=1 / 9, jitter=0.01):
    """Write the lower block [0,1]^2 x [0,0.5] and the upper block [0,1]^2 x [0.5,1] (separate volumes, no
    shared node) to ``path``; returns the smallest distance, in x or in y, between an interface node of one
    side and one of the other, the face's four corners aside (before the jitter).

    Cell groups ``lower``, ``upper``. Facet groups ``bottom`` (z = 0), ``top`` (z = 1), ``lower_face`` (the
    lower block's side z = 0.5, outward normal +z), ``upper_face`` (the upper block's z = 0.5, normal -z),
    and per body and side ``lower_x0``, ``lower_x1``, ``lower_y0``, ``lower_y1``, ``upper_x0``, …
    (``x0``: the plane x = 0, ``x1``: x = 1, likewise y).

    The interface faces are structured (transfinite, round(1/h) x round(1/h) squares, each cut in two
    triangles), the rest unstructured; the upper block is then mapped by (x, y) -> (phi(x), phi(y)) as in
    :func:`stacked_blocks_2d`, and all jittered (``jitter`` x min(h))."""
    return _stacked_blocks(path, 3, h_lower, h_upper, jitter)


def _stacked_blocks(path, tdim, h_lower, h_upper, jitter):
    n_lower, n_upper = _count(h_lower), _count(h_upper)
    alpha, separation = _shift_for_separation(n_lower, n_upper)
    vertical = tdim - 1
    sides = {2: {(0, 0): "left", (0, 1): "right"},
             3: {(axis, end): f"{'xy'[axis]}{end}" for axis in (0, 1) for end in (0, 1)}}[tdim]
    _start(f"stacked_blocks_{tdim}d")
    try:
        occ = gmsh.model.occ
        if tdim == 2:
            lower, upper = occ.addRectangle(0, 0, 0, 1, 0.5), occ.addRectangle(0, 0.5, 0, 1, 0.5)
        else:
            lower, upper = occ.addBox(0, 0, 0, 1, 1, 0.5), occ.addBox(0, 0, 0.5, 1, 1, 0.5)
        occ.synchronize()
        facets = {"bottom": [], "top": [], "lower_face": [], "upper_face": []}
        facets.update({f"{body}_{side}": [] for body in ("lower", "upper") for side in sides.values()})
        for body, entity, n, h in (("lower", lower, n_lower, h_lower), ("upper", upper, n_upper, h_upper)):
            for _, facet in gmsh.model.getBoundary([(tdim, entity)], oriented=False):
                centre = occ.getCenterOfMass(tdim - 1, facet)
                if abs(centre[vertical] - 0.5) < 1e-9:  # the interface: n equal segments along each edge
                    facets[f"{body}_face"].append(facet)
                    edges = [facet] if tdim == 2 else [
                        c for _, c in gmsh.model.getBoundary([(2, facet)], oriented=False)]
                    for edge in edges:
                        gmsh.model.mesh.setTransfiniteCurve(edge, n + 1)
                    if tdim == 3:
                        gmsh.model.mesh.setTransfiniteSurface(facet)
                elif abs(centre[vertical]) < 1e-9:
                    facets["bottom"].append(facet)
                elif abs(centre[vertical] - 1) < 1e-9:
                    facets["top"].append(facet)
                else:
                    axis = 0 if abs(centre[0] - 0.5) > 0.25 else 1
                    facets[f"{body}_{sides[axis, int(centre[axis] > 0.5)]}"].append(facet)
            gmsh.model.mesh.setSize(gmsh.model.getBoundary([(tdim, entity)], recursive=True), h)
        cells = {"lower": [lower], "upper": [upper]}
        _name_groups(cells, facets, tdim)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)

        def along_interface(x):
            x[:, :vertical] = _phi(x[:, :vertical], alpha)
            return x

        def finish():
            _move_nodes(_body_nodes(tdim, [upper]), along_interface)
            planes = {axis: [0.0, 1.0] for axis in range(vertical)}
            planes[vertical] = [0.0, 0.5, 1.0]
            _jitter_and_snap(jitter * min(h_lower, h_upper), planes, tdim)
            _report(path, tdim, cells)
        generate_and_write(path, dim=tdim, before_writing=finish)
    finally:
        gmsh.finalize()
    return separation


# --- 2. a body and its mirror image ----------------------------------------------------------------

def mirrored(path_in, path_out, axis_value=0.0, binary=None, axis=None):
    """Write to ``path_out`` the one-body mesh ``path_in`` (2D or 3D .msh with physical groups) and its
    mirror image in the plane y = axis_value in 2D, z = axis_value in 3D (the foundation's normal axis;
    ``axis`` 0, 1 or 2 picks another), as two bodies.

    The input's cells (all its cell groups) become cell group ``upper``, their mirror images ``lower``;
    every facet group NAME of the input becomes ``upper_NAME`` and ``lower_NAME``. Node i of the input keeps
    its coordinates (tag i after renumbering 1..N); its mirror, tag N + i, has y' = 2 * axis_value - y
    (z' in 3D) computed in float64, the other coordinates unchanged: bitwise, as read back. Mirrored cells
    and facets list their nodes with the first two swapped, so that every cell keeps the sign of its
    orientation. The outward normal of a mirrored facet is the mirror image of the original's.

    ``binary``: None writes ASCII msh 4.1 when that reads back bitwise (it does for axis_value = 0 and an
    input that gmsh wrote in ASCII: y and -y print alike), else binary msh 4.1 (exact); True/False forces
    it. Returns (number of nodes per body, whether the file is binary). The mirror is checked by reading the
    file back; a mismatch raises."""
    _start("mirrored_input")
    try:
        gmsh.open(str(path_in))
        tdim = gmsh.model.getDimension()
        tags, coords, _ = gmsh.model.mesh.getNodes()
        order = np.argsort(tags)
        tags = np.asarray(tags, np.int64)[order]
        x = np.reshape(coords, (-1, 3))[order]
        renumber = np.zeros(tags.max() + 1, np.int64)
        renumber[tags] = np.arange(1, len(tags) + 1)
        groups = {}  # (dim, name) -> list of (element type, node tags (n, k))
        for dim, ptag in gmsh.model.getPhysicalGroups():
            if dim not in (tdim, tdim - 1):
                continue
            name = gmsh.model.getPhysicalName(dim, ptag) or str(ptag)
            blocks = []
            for entity in gmsh.model.getEntitiesForPhysicalGroup(dim, ptag):
                types, _, nodes = gmsh.model.mesh.getElements(dim, entity)
                for t, n in zip(types, nodes):
                    k = gmsh.model.mesh.getElementProperties(t)[3]
                    blocks.append((int(t), renumber[np.reshape(np.asarray(n, np.int64), (-1, k))]))
            groups[(dim, name)] = blocks
    finally:
        gmsh.finalize()
    if not any(dim == tdim for dim, _ in groups):
        raise ValueError(f"{path_in} has no cell group")
    n = len(x)
    axis = tdim - 1 if axis is None else axis
    x_mirror = x.copy()
    x_mirror[:, axis] = 2.0 * axis_value - x[:, axis]
    if binary is None:
        binary = not _prints_alike(x, x_mirror)
    _start("mirrored")
    try:
        model = gmsh.model
        bodies = {}
        for body, offset, xs in (("upper", 0, x), ("lower", n, x_mirror)):
            cell_entity = model.addDiscreteEntity(tdim)
            model.mesh.addNodes(tdim, cell_entity, list(range(offset + 1, offset + n + 1)), xs.ravel().tolist())
            bodies[body] = (cell_entity, offset)
        element_tag = 1
        physical = {tdim: 1, tdim - 1: 1}
        for body in ("upper", "lower"):
            cell_entity, offset = bodies[body]
            for (dim, name), blocks in sorted(groups.items(), key=lambda g: (-g[0][0], g[0][1])):
                entity = cell_entity if dim == tdim else model.addDiscreteEntity(dim)
                for element_type, nodes in blocks:
                    nodes = nodes + offset
                    if body == "lower":  # a mirror turns orientation: swap two nodes
                        nodes = nodes[:, [1, 0] + list(range(2, nodes.shape[1]))]
                    tags_e = list(range(element_tag, element_tag + len(nodes)))
                    element_tag += len(nodes)
                    model.mesh.addElementsByType(entity, element_type, tags_e, nodes.ravel().tolist())
                if dim == tdim - 1:
                    model.addPhysicalGroup(dim, [entity], physical[dim])
                    model.setPhysicalName(dim, physical[dim], f"{body}_{name}")
                    physical[dim] += 1
            model.addPhysicalGroup(tdim, [cell_entity], physical[tdim])
            model.setPhysicalName(tdim, physical[tdim], body)
            physical[tdim] += 1
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", int(bool(binary)))
        gmsh.write(str(path_out))
    finally:
        gmsh.finalize()
    _check_mirror(path_out, x, x_mirror)
    kind = "binary" if binary else "ASCII"
    print(f"wrote {path_out}: {n} nodes per body, {kind}, mirror plane {'xyz'[axis]} = {axis_value}")
    return n, bool(binary)


def _prints_alike(x, x_mirror):
    """Whether gmsh's ASCII output (%.16g) reads back as x and x_mirror exactly."""
    for values in (x, x_mirror):
        back = np.array([float(f"{v:.16g}") for v in values.ravel()])
        if not np.array_equal(back, values.ravel()):
            return False
    return True


def _check_mirror(path, x, x_mirror):
    _start("check")
    try:
        gmsh.open(str(path))
        tags, coords, _ = gmsh.model.mesh.getNodes()
        back = np.reshape(coords, (-1, 3))[np.argsort(tags)]
    finally:
        gmsh.finalize()
    if not (np.array_equal(back[:len(x)], x) and np.array_equal(back[len(x):], x_mirror)):
        raise RuntimeError(f"{path}: the nodes read back are not the exact mirror images")


# --- 3. two cylinders (2D Hertz) ------------------------------------------------------------------

def _half_disc(geo, centre_y, radius, sign):
    """A half-disc with its flat side at y = centre_y and its arc through (0, 0): sign = +1 the upper one
    (centre (0, R), region y <= R), -1 the lower one (centre (0, -R), y >= -R). Returns the surface, the
    flat edge, the contact arcs (|x| <= R/2), the free arcs and the point at the origin."""
    x_c = 0.5 * radius
    y_c = sign * (radius - math.sqrt(radius ** 2 - x_c ** 2))
    centre = geo.addPoint(0, centre_y, 0)
    left, right = geo.addPoint(-radius, centre_y, 0), geo.addPoint(radius, centre_y, 0)
    c_left, c_right = geo.addPoint(-x_c, y_c, 0), geo.addPoint(x_c, y_c, 0)
    origin = geo.addPoint(0, 0, 0)
    flat = geo.addLine(right, left) if sign > 0 else geo.addLine(left, right)
    arcs = [geo.addCircleArc(left, centre, c_left), geo.addCircleArc(c_left, centre, origin),
            geo.addCircleArc(origin, centre, c_right), geo.addCircleArc(c_right, centre, right)]
    loop = [flat, *arcs] if sign > 0 else [flat, -arcs[3], -arcs[2], -arcs[1], -arcs[0]]
    surface = geo.addPlaneSurface([geo.addCurveLoop(loop)])
    return surface, flat, arcs[1:3], [arcs[0], arcs[3]], origin


def two_cylinders_2d(path, R1=1.0, R2=1.0, h=None, h_contact=None, lower_ratio=0.7, x_fine=0.12,
                     growth=0.2, jitter=0.01):
    """Write two half-discs (plane strain cylinders) touching at the origin to ``path``.

    Upper body: disc of radius R1 centred at (0, R1), its part y <= R1; lower body: radius R2 centred at
    (0, -R2), its part y >= -R2. Each has a vertex at (0, 0) (two distinct nodes there). Cell groups
    ``upper``, ``lower``; facet groups ``upper_top`` (y = R1), ``lower_bottom`` (y = -R2), ``upper_contact``
    and ``lower_contact`` (the arcs with |x| <= R_i/2; outward normals about -y and +y), ``upper_free``,
    ``lower_free`` (the rest of the arcs).

    Sizes: h (default min(R1, R2)/8) far away, h_contact (default min(R1, R2)/100) on the upper body near the
    origin, lower_ratio x h_contact on the lower one (different chords: non-matching), within
    x_fine x min(R1, R2) of the origin along the contact arcs, growing with slope ``growth`` (as
    meshes/hertz.py). Then jittered (``jitter`` x the smallest size; arc nodes projected back on the circle).

    Returns the smallest distance in x between a node of one contact arc and one of the other within
    x_fine x min(R1, R2) of the origin, the origin aside (before the jitter). The two arcs' nodes never
    coincide, but as both start at the origin with nearly uniform chords, some come within a few per cent
    of h_contact of each other in x (0.03 h_contact at the defaults): a non-matching interface, not a
    staggered one."""
    r_min = min(R1, R2)
    h = r_min / 8 if h is None else h
    h_contact = r_min / 100 if h_contact is None else h_contact
    _start("two_cylinders_2d")
    try:
        gmsh.option.setNumber("Geometry.AutoCoherence", 0)  # the two points at the origin stay two
        geo = gmsh.model.geo
        up = _half_disc(geo, R1, R1, +1)
        low = _half_disc(geo, -R2, R2, -1)
        geo.synchronize()
        field = gmsh.model.mesh.field
        sizes = []
        for (surface, flat, contact, free, origin), h_near in ((up, h_contact), (low, h_contact * lower_ratio)):
            near_origin = field.add("Distance")
            field.setNumbers(near_origin, "PointsList", [origin])
            near_arc = field.add("Distance")
            field.setNumbers(near_arc, "CurvesList", contact)
            field.setNumber(near_arc, "NumPointsPerCurve", 2000)
            both = field.add("Max")
            field.setNumbers(both, "FieldsList", [_graded_field(h_near, h, near_origin, x_fine * r_min, growth),
                                                  _graded_field(h_near, h, near_arc, 0.0, growth)])
            restrict = field.add("Restrict")  # this body's size in this body only
            field.setNumber(restrict, "InField", both)
            _restrict_to(restrict, surface, [flat, *contact, *free])
            sizes.append(restrict)
        size = field.add("Min")
        field.setNumbers(size, "FieldsList", sizes)
        _sizes_from_field(size)
        cells = {"upper": [up[0]], "lower": [low[0]]}
        facets = {"upper_top": [up[1]], "upper_contact": up[2], "upper_free": up[3],
                  "lower_bottom": [low[1]], "lower_contact": low[2], "lower_free": low[3]}
        _name_groups(cells, facets, 2)

        separation = []

        def finish():
            separation.append(_arc_separation(up, low, x_fine * r_min))
            _jitter_and_snap(jitter * h_contact * min(lower_ratio, 1.0),
                             {0: [0.0], 1: [R1, -R2, 0.0]}, 2)
            _report(path, 2, cells)
        generate_and_write(path, dim=2, before_writing=finish)
    finally:
        gmsh.finalize()
    return separation[0]


def _arc_separation(up, low, x_fine):
    """The smallest distance in x between a node of the upper contact arc and one of the lower contact arc
    within x_fine of the origin (the origin, a node of both, aside)."""
    def arc_x(curves):
        nodes = np.concatenate([gmsh.model.mesh.getNodes(1, c, includeBoundary=True)[1] for c in curves])
        x = np.reshape(nodes, (-1, 3))[:, 0]
        return x[(x != 0) & (np.abs(x) < x_fine)]
    return _separation(arc_x(up[2]), arc_x(low[2]))


def _restrict_to(field_tag, surface, curves):
    """Restrict field ``field_tag`` to one surface and its curves (option names of gmsh 4.8 and later)."""
    field = gmsh.model.mesh.field
    field.setNumbers(field_tag, "SurfacesList", [surface])
    field.setNumbers(field_tag, "CurvesList", curves)


def cattaneo_cylinders_2d(path, h=None, h_contact=0.00075, x_fine=0.08, jitter=0.01):
    """Write the mesh of the case cattaneo_cylinders to ``path``: :func:`two_cylinders_2d` with two identical
    radii R1 = R2 = 1 (with one material: Dundurs' β = 0), finer at the contact than two_cylinders.msh.

    The case presses the cylinders to a Hertz half-width a ≈ 0.052 and then locates the stick zone
    |x| < c, c/a = (1 − Q/(μP))^{1/2}, on these chords: h_contact = 0.00075 on the upper arc (a/70), 0.7 x that
    on the lower one (a/100; non-matching), within x_fine = 0.08 ≈ 1.5 a of the origin, growing with slope 0.2
    to h (default 1/8) away from it. The stick-zone edge is found to within about a chord, h_contact/a ≈ 0.014
    in c/a (the tolerance of tests/test_two_body_friction.py rests on it; twice these chords gave up to one
    chord's error, 0.028). Returns what two_cylinders_2d returns (the smallest x-distance between the two
    arcs' nodes near the origin, before the jitter)."""
    return two_cylinders_2d(path, 1.0, 1.0, h=h, h_contact=h_contact, x_fine=x_fine, jitter=jitter)


# --- 4. a sphere on a block (3D Hertz) -------------------------------------------------------------

def sphere_on_block_3d(path, R=1.0, h=None, h_contact=None, L=None, H=None, x_fine=0.15, growth=0.35,
                       jitter=0.01):
    """Write a quarter ball on a quarter block, touching at the origin, to ``path``.

    Ball ("ball"): the part x >= 0, y >= 0, z <= R of the ball of radius R centred at (0, 0, R) (a quarter
    of its lower half; its lowest point (0, 0, 0) a vertex), two volumes split by the plane of the cap's
    rim. Block ("block"): [0, L] x [0, L] x [-H, 0] (default L = H = R), its corner at the origin (a vertex
    of both bodies: two nodes there). Facet groups: ``ball_top`` (z = R),
    ``ball_contact`` (the spherical cap within R/2 of the z-axis, outward normal about -z), ``ball_free``
    (the rest of the sphere), ``ball_sym_x`` (x = 0), ``ball_sym_y`` (y = 0); ``block_face`` (z = 0, outward
    normal +z), ``block_bottom`` (z = -H), ``block_sym_x``, ``block_sym_y`` (x = 0, y = 0), ``block_sides``
    (x = L and y = L).

    Sizes: h (default R/5) far away, h_contact (default R/40) within x_fine x R of the origin, growing with
    slope ``growth``; the ball's sphere is built with its poles on the x-axis through its centre (as
    gmsh_common.lower_ball: no pole at the contact). The two surfaces at the contact are meshed
    independently (non-matching). Jittered (``jitter`` x h_contact)."""
    h = R / 5 if h is None else h
    h_contact = R / 40 if h_contact is None else h_contact
    L = R if L is None else L
    H = R if H is None else H
    x_c = 0.5 * R
    z_c = R - math.sqrt(R ** 2 - x_c ** 2)
    _start("sphere_on_block_3d")
    try:
        occ = gmsh.model.occ
        ball = occ.addSphere(0, 0, R, R)
        occ.rotate([(3, ball)], 0, 0, R, 0, 1, 0, np.pi / 2)  # poles onto the x-axis through the centre
        part = occ.addBox(0, 0, 0, R, R, R)
        (ball_body,), _ = occ.intersect([(3, ball)], [(3, part)])
        cut = occ.addRectangle(0, 0, z_c, R, R)
        pieces, _ = occ.fragment([ball_body], [(2, cut)])
        block = occ.addBox(0, 0, -H, L, L, H)
        occ.synchronize()
        ball_volumes = [tag for dim, tag in pieces if dim == 3]
        facets = {name: [] for name in ("ball_top", "ball_contact", "ball_free", "ball_sym_x", "ball_sym_y",
                                        "block_face", "block_bottom", "block_sym_x", "block_sym_y",
                                        "block_sides")}
        for dim, tag in gmsh.model.getBoundary([(3, v) for v in ball_volumes], oriented=False):
            centre = occ.getCenterOfMass(dim, tag)
            if abs(centre[0]) < 1e-9:
                facets["ball_sym_x"].append(tag)
            elif abs(centre[1]) < 1e-9:
                facets["ball_sym_y"].append(tag)
            elif abs(centre[2] - R) < 1e-9:
                facets["ball_top"].append(tag)
            else:
                facets["ball_contact" if centre[2] < z_c else "ball_free"].append(tag)
        for dim, tag in gmsh.model.getBoundary([(3, block)], oriented=False):
            cx, cy, cz = occ.getCenterOfMass(dim, tag)
            if abs(cx) < 1e-9:
                facets["block_sym_x"].append(tag)
            elif abs(cy) < 1e-9:
                facets["block_sym_y"].append(tag)
            elif abs(cz) < 1e-9:
                facets["block_face"].append(tag)
            elif abs(cz + H) < 1e-9:
                facets["block_bottom"].append(tag)
            else:
                facets["block_sides"].append(tag)
        cells = {"ball": ball_volumes, "block": [block]}
        _name_groups(cells, facets, 3)
        field = gmsh.model.mesh.field
        size = field.add("MathEval")
        field.setString(size, "F", f"Min({h}, {h_contact} + {growth} * Max(0, Sqrt(x*x + y*y + z*z) - {x_fine * R}))")
        _sizes_from_field(size)

        def finish():
            _jitter_and_snap(jitter * h_contact, {0: [0.0, L], 1: [0.0, L], 2: [-H, 0.0, z_c, R]}, 3)
            _report(path, 3, cells)
        generate_and_write(path, dim=3, before_writing=finish)
    finally:
        gmsh.finalize()


# --- command line -----------------------------------------------------------------------------------

def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("name", choices=["stacked_blocks_2d", "stacked_blocks_3d", "mirrored", "two_cylinders_2d",
                                         "sphere_on_block_3d", "cattaneo_cylinders_2d"])
    parser.add_argument("out", help="the .msh file to write")
    parser.add_argument("--h", type=float, help="size far from the contact (two_cylinders_2d, sphere_on_block_3d); "
                        "stacked blocks: the lower block's, the upper's 2/3 of it (default 1/6)")
    parser.add_argument("--h-contact", type=float, help="size near the contact point")
    parser.add_argument("--h-lower", type=float, help="stacked blocks: the lower block's size (default --h)")
    parser.add_argument("--h-upper", type=float, help="stacked blocks: the upper block's size (default 2/3 --h)")
    parser.add_argument("--R1", type=float, default=1.0, help="two_cylinders_2d: the upper radius")
    parser.add_argument("--R2", type=float, default=1.0, help="two_cylinders_2d: the lower radius")
    parser.add_argument("--R", type=float, default=1.0, help="sphere_on_block_3d: the ball's radius")
    parser.add_argument("--input", help="mirrored: the one-body .msh")
    parser.add_argument("--axis-value", type=float, default=0.0,
                        help="mirrored: the mirror plane y = A in 2D, z = A in 3D (or --axis = A)")
    parser.add_argument("--axis", choices=["x", "y", "z"], help="mirrored: the mirror plane's normal axis")
    parser.add_argument("--jitter", type=float, default=0.01, help="node jitter, times the smallest size")
    args = parser.parse_args(argv)
    if args.name.startswith("stacked_blocks"):
        h = 1 / 6 if args.h is None else args.h
        h_lower = h if args.h_lower is None else args.h_lower
        h_upper = 2 * h / 3 if args.h_upper is None else args.h_upper
        write = stacked_blocks_2d if args.name.endswith("2d") else stacked_blocks_3d
        write(args.out, h_lower, h_upper, jitter=args.jitter)
    elif args.name == "mirrored":
        if not args.input:
            parser.error("mirrored needs --input IN.msh")
        mirrored(args.input, args.out, args.axis_value, axis=None if args.axis is None else "xyz".index(args.axis))
    elif args.name == "two_cylinders_2d":
        two_cylinders_2d(args.out, args.R1, args.R2, args.h, args.h_contact, jitter=args.jitter)
    elif args.name == "cattaneo_cylinders_2d":
        cattaneo_cylinders_2d(args.out, args.h, 0.00075 if args.h_contact is None else args.h_contact,
                              jitter=args.jitter)
    else:
        sphere_on_block_3d(args.out, args.R, args.h, args.h_contact, jitter=args.jitter)


if __name__ == "__main__":
    main()
