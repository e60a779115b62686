"""What every mesh script here does: name the physical groups, mesh with linear triangles, write .msh 4.1."""
import gmsh


def name_groups(curves_by_name, surface, body="body"):
    """Physical groups 1, 2, … on the boundary curves (by name) and group 1 on the cells."""
    for tag, (name, curves) in enumerate(curves_by_name.items(), start=1):
        gmsh.model.addPhysicalGroup(1, curves, tag)
        gmsh.model.setPhysicalName(1, tag, name)
    gmsh.model.addPhysicalGroup(2, [surface], 1)
    gmsh.model.setPhysicalName(2, 1, body)


def generate_and_write(out):
    """Linear triangles (Frontal-Delaunay), written as ASCII msh 4.1 (what nc_dolfinx reads)."""
    gmsh.option.setNumber("Mesh.ElementOrder", 1)
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
    gmsh.model.mesh.generate(2)
    gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
    gmsh.option.setNumber("Mesh.Binary", 0)
    gmsh.write(str(out))
    print(f"wrote {out}: {len(gmsh.model.mesh.getElementsByType(2)[0])} triangles")
