#!/usr/bin/env python3
"""Generate ``nc_dolfinx/cases/hertz3d.msh``: a quarter of the lower half of a ball, for the ``hertz3d`` case.

Ball of radius R = 1 centred at (0, 0, R); the part x >= 0, y >= 0, z <= R. Its lowest point (0, 0, 0)
is a mesh vertex. Linear tetrahedra, msh 4.1 ASCII. Physical groups (names become boundary groups):

    top       the flat quarter disc z = R                 (Γ_D, clamped, in the case)
    symm_x    the plane x = 0                             (symmetry: u_x = 0)
    symm_y    the plane y = 0                             (symmetry: u_y = 0)
    contact   the spherical cap z <= Z_C (radius X_C = R/2 around the z-axis)   (Γ_C)
    free      the rest of the sphere                      (traction free)
    body      the cells (two volumes, split by the plane z = Z_C)

gmsh's OCC sphere has its poles on its axis, and a pole is a vertex with a fan of thin triangles (and
slivers under them). The sphere is therefore built with its axis along x: its poles (R, 0, R) and
(−R, 0, R) are on the clamped edge or outside the quarter, far from the contact point (0, 0, 0).

The size is H_MIN near the contact point (within X_FINE of it), growing with slope GROWTH away from it,
up to H_MAX; every node is then moved at random by at most H_MIN/100 within its surface or curve, so
that no two edges of a face are equally long and refinement is the same on any number of ranks. Refinement in the solver only bisects edges, so the level-0 facets are the resolution of the
spherical surface for good: their kinks (angle ~ h/R) would give pressure spikes that grow under refinement
(see meshes/hertz.py). The case therefore takes the gap from the exact sphere (its height above the plane
at (x, y)), which is smooth whatever the facets, and H_MIN only has to resolve the contact zone.

Run: ``/usr/bin/python3 meshes/hertz3d.py`` (from any directory).
"""
import math
import sys
from pathlib import Path

import gmsh
from gmsh_common import generate_and_write, jitter_nodes, name_groups

R = 1.0
X_C = 0.5 * R                          # the contact group is the cap within this distance of the z-axis
Z_C = R - math.sqrt(R ** 2 - X_C ** 2)  # its height
H_MAX = R / 5                          # far from the contact
H_MIN = R / 40                         # near the contact point (the contact radius is ~0.1 R)
X_FINE = 0.15 * R                      # ... up to this distance from it
GROWTH = 0.35                          # size gradient away from that region
JITTER = 0.01 * H_MIN                  # random node offsets (gmsh_common.jitter_nodes): no exactly equal edges
# The mesh ships with the package, beside its problem file.
OUT = Path(__file__).resolve().parent.parent / "nc_dolfinx" / "cases" / (Path(__file__).stem + ".msh")


def quarter_ball():
    """The volumes (below and above z = Z_C) and the boundary surfaces by group name."""
    occ = gmsh.model.occ
    ball = occ.addSphere(0, 0, R, R)
    occ.rotate([(3, ball)], 0, 0, R, 0, 1, 0, math.pi / 2)  # poles onto the x-axis through the centre
    quarter = occ.addBox(0, 0, 0, R, R, R)
    (body,), _ = occ.intersect([(3, ball)], [(3, quarter)])
    cut = occ.addRectangle(0, 0, Z_C, R, R)
    pieces, _ = occ.fragment([body], [(2, cut)])
    occ.synchronize()
    volumes = [tag for dim, tag in pieces if dim == 3]
    groups = {"top": [], "symm_x": [], "symm_y": [], "contact": [], "free": []}
    for dim, tag in gmsh.model.getBoundary([(3, v) for v in volumes], oriented=False):
        x, y, z = gmsh.model.occ.getCenterOfMass(dim, tag)  # (OCC bounding boxes are loose)
        if abs(x) < 1e-9:
            groups["symm_x"].append(tag)
        elif abs(y) < 1e-9:
            groups["symm_y"].append(tag)
        elif abs(z - R) < 1e-9:
            groups["top"].append(tag)
        else:
            groups["contact" if z < Z_C else "free"].append(tag)
    assert all(groups.values()), groups
    return volumes, groups


def size_field():
    """H_MIN within X_FINE of the contact point, growing with slope GROWTH up to H_MAX."""
    field = gmsh.model.mesh.field
    point = gmsh.model.occ.addPoint(0, 0, 0)  # not in the model: only the distance field uses it
    distance = field.add("MathEval")
    field.setString(distance, "F", f"Min({H_MAX}, {H_MIN} + {GROWTH} * Max(0, Sqrt(x*x + y*y + z*z) - {X_FINE}))")
    field.setAsBackgroundMesh(distance)
    gmsh.model.occ.remove([(0, point)])
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def main(out=OUT):
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("hertz3d")
        volumes, groups = quarter_ball()
        name_groups(groups, volumes, dim=3)
        size_field()
        generate_and_write(out, dim=3, before_writing=lambda: jitter_nodes(JITTER))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(*sys.argv[1:])
