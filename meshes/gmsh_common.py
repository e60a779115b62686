"""What every mesh script here does: name the physical groups, mesh with linear simplices, write .msh 4.1;
and the lower half ball that meshes/hertz3d.py and meshes/hertz3d_half.py cut differently."""
import gmsh
import numpy as np


def name_groups(boundary_by_name, domain, body="body", dim=2):
    """Physical groups 1, 2, … on the boundary entities of dimension dim − 1 (curves in 2D, surfaces in
    3D), by name, and group 1 on the cells (``domain``: one entity tag or a list of them)."""
    for tag, (name, entities) in enumerate(boundary_by_name.items(), start=1):
        gmsh.model.addPhysicalGroup(dim - 1, entities, tag)
        gmsh.model.setPhysicalName(dim - 1, tag, name)
    gmsh.model.addPhysicalGroup(dim, domain if isinstance(domain, list) else [domain], 1)
    gmsh.model.setPhysicalName(dim, 1, body)


def generate_and_write(out, dim=2, before_writing=None):
    """Linear triangles (2D) or tetrahedra (3D; surfaces Frontal-Delaunay, volumes Delaunay with gmsh's
    default optimisation), ``before_writing()`` if given, then ASCII msh 4.1 (what nc_dolfinx reads)."""
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
    gmsh.model.mesh.generate(dim)
    if before_writing:
        before_writing()
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(str(out))
    cell = {2: 2, 3: 4}[dim]  # gmsh element types: 3-node triangle, 4-node tetrahedron
    print(f"wrote {out}: {len(gmsh.model.mesh.getElementsByType(cell)[0])} {['triangles', 'tetrahedra'][dim - 2]}")


def jitter_nodes(amplitude, seed=1):
    """Move every node by a random offset of at most ``amplitude`` per coordinate and project it back onto
    its geometric entity (gmsh's orthogonal projection): nodes inside a volume move freely, nodes on a
    surface stay on it, nodes on a curve on it, corner nodes do not move.

    Why: DOLFINx's Plaza refinement breaks a tie between equally long edges of a face by global vertex
    numbers, which depend on the partition. A mesh with many exactly equal edge lengths (a uniform size on a
    box, or the regular patterns gmsh makes on planes) is then refined differently on 1, 2 and 3 ranks;
    after the jitter no two edges of a face have the same length (nor, therefore, do those of the refined
    faces, whose edges are halves of parent edges and new edges in general position)."""
    rng = np.random.default_rng(seed)
    for dim in (1, 2, 3):
        for _, tag in gmsh.model.getEntities(dim):
            nodes, coords, _ = gmsh.model.mesh.getNodes(dim, tag, includeBoundary=False)
            if len(nodes) == 0:
                continue
            moved = coords + rng.uniform(-amplitude, amplitude, coords.shape)
            if dim < 3:
                moved, parametric = gmsh.model.getClosestPoint(dim, tag, moved)
                parametric = np.reshape(parametric, (len(nodes), dim))
            else:
                parametric = np.zeros((len(nodes), 0))
            for node, x, uv in zip(nodes, np.reshape(moved, (-1, 3)), parametric):
                gmsh.model.mesh.setNode(int(node), list(x), list(uv))


def lower_ball(out, model, *, radius, x_min, symmetry_planes, z_contact, h_min, h_max, x_fine, growth, jitter,
               cad=None):
    """Write ``out``: the part x >= x_min, y >= 0, z <= radius of the ball of radius ``radius`` centred at
    (0, 0, radius), in two volumes split by the plane z = z_contact (group ``body``), its lowest point
    (0, 0, 0) a mesh vertex. Boundary groups, in this order: ``top`` (the flat face z = radius), one per
    entry of ``symmetry_planes`` ({name: axis}, the plane x = 0 for axis 0, y = 0 for axis 1, tested in
    that order), ``contact`` (the spherical cap z <= z_contact) and ``free`` (the rest of the sphere).

    gmsh's OCC sphere has a pole on its axis, a vertex with a fan of thin triangles (and slivers under
    them); the sphere is therefore built with its axis along x, its poles (±radius, 0, radius) on the
    clamped edge or outside the part, far from the contact point. The size is h_min within x_fine of the
    contact point, growing with slope ``growth`` up to h_max; ``jitter_nodes(jitter)`` before writing.
    ``cad``: also write the geometry there (a .brep: the CAD the mesh was made from, for mesh.cad)."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(model)
        occ = gmsh.model.occ
        ball = occ.addSphere(0, 0, radius, radius)
        occ.rotate([(3, ball)], 0, 0, radius, 0, 1, 0, np.pi / 2)  # poles onto the x-axis through the centre
        part = occ.addBox(x_min, 0, 0, radius - x_min, radius, radius)
        (body,), _ = occ.intersect([(3, ball)], [(3, part)])
        cut = occ.addRectangle(x_min, 0, z_contact, radius - x_min, radius)
        pieces, _ = occ.fragment([body], [(2, cut)])
        occ.synchronize()
        volumes = [tag for dim, tag in pieces if dim == 3]
        groups = {"top": [], **{name: [] for name in symmetry_planes}, "contact": [], "free": []}
        for dim, tag in gmsh.model.getBoundary([(3, v) for v in volumes], oriented=False):
            centre = occ.getCenterOfMass(dim, tag)  # (OCC bounding boxes are loose)
            plane = next((name for name, axis in symmetry_planes.items() if abs(centre[axis]) < 1e-9), None)
            if plane:
                groups[plane].append(tag)
            elif abs(centre[2] - radius) < 1e-9:
                groups["top"].append(tag)
            else:
                groups["contact" if centre[2] < z_contact else "free"].append(tag)
        assert all(groups.values()), groups
        name_groups(groups, volumes, dim=3)

        field = gmsh.model.mesh.field
        size = field.add("MathEval")
        field.setString(size, "F", f"Min({h_max}, {h_min} + {growth} * Max(0, Sqrt(x*x + y*y + z*z) - {x_fine}))")
        field.setAsBackgroundMesh(size)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        generate_and_write(out, dim=3, before_writing=lambda: jitter_nodes(jitter))
        if cad:
            gmsh.write(str(cad))
    finally:
        gmsh.finalize()
