#!/usr/bin/env python3
"""Generate ``nc_dolfinx/cases/fichera.msh``: the Fichera corner, the cube [−1, 1]³ without the octant (0, 1]³.

The re-entrant vertex is the origin; the three re-entrant edges run from it along the positive x, y and z
axes. Uniform size H (each node then moved at random by at most H/100 within its face or edge, so that
no two edges of a face are equally long and refinement is the same on any number of ranks), linear tetrahedra, msh 4.1 ASCII. Physical groups (names become boundary groups):

    bottom   z = −1, the full square          (Γ_C in the case)
    left     x = −1                           (Γ_D)
    top      z = 1, the L-shaped part x < 0 or y < 0   (Γ_N, loaded)
    free     every other face: x = 1, y = ±1 and the three faces of the notch x = 0, y = 0, z = 0
             (traction free)
    body     the cells

Run: ``/usr/bin/python3 meshes/fichera.py`` (from any directory).
"""
import sys
from pathlib import Path

import gmsh
from gmsh_common import generate_and_write, jitter_nodes, name_groups

H = 0.25
JITTER = 0.01 * H   # random node offsets (see gmsh_common.jitter_nodes): no exactly equal edges
# The mesh ships with the package, beside its problem file.
OUT = Path(__file__).resolve().parent.parent / "nc_dolfinx" / "cases" / (Path(__file__).stem + ".msh")


def fichera():
    """The volume and its boundary surfaces by group name."""
    occ = gmsh.model.occ
    cube = occ.addBox(-1, -1, -1, 2, 2, 2)
    octant = occ.addBox(0, 0, 0, 1, 1, 1)
    (body,), _ = occ.cut([(3, cube)], [(3, octant)])
    occ.synchronize()
    groups = {"bottom": [], "left": [], "top": [], "free": []}
    for dim, tag in gmsh.model.getBoundary([body], oriented=False):
        x, y, z = occ.getCenterOfMass(dim, tag)
        name = "bottom" if abs(z + 1) < 1e-9 else "left" if abs(x + 1) < 1e-9 else \
            "top" if abs(z - 1) < 1e-9 else "free"
        groups[name].append(tag)
    return body[1], groups


def main(out=OUT):
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("fichera")
        body, groups = fichera()
        name_groups(groups, body, dim=3)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", H)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", H)
        generate_and_write(out, dim=3, before_writing=lambda: jitter_nodes(JITTER))
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main(*sys.argv[1:])
