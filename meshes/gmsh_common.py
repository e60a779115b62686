"""What every mesh script here does: name the physical groups, mesh with linear simplices, write .msh 4.1."""
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
