#!/usr/bin/env python3
"""Generate ``nc_dolfinx/cases/corner.msh``: the L-shaped body of the ``corner`` case.

Polygon (0,0), (2,0), (2,1), (1,1), (1,2), (0,2) with the re-entrant corner at (1,1), uniform size
h = 0.25, linear triangles, msh 4.1 ASCII. Physical groups (names become boundary groups):

    bottom  y = 0, 0 <= x <= 2            (Γ_C in the case)
    left    x = 0                         (Γ_D)
    top     y = 2, 0 <= x <= 1            (Γ_N, loaded)
    free    (2,0)-(2,1), (2,1)-(1,1), (1,1)-(1,2)   (traction free)
    body    the cells

Run: ``/usr/bin/python3 meshes/corner.py`` (from any directory).
"""
from pathlib import Path

import gmsh
from gmsh_common import generate_and_write, name_groups

H = 0.25
# The mesh ships with the package, beside its problem file.
OUT = Path(__file__).resolve().parent.parent / "nc_dolfinx" / "cases" / (Path(__file__).stem + ".msh")


def main():
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("corner")
        geo = gmsh.model.geo
        xy = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
        p = [geo.addPoint(x, y, 0, H) for x, y in xy]
        lines = [geo.addLine(p[i], p[(i + 1) % len(p)]) for i in range(len(p))]
        # lines: 0 (0,0)-(2,0), 1 (2,0)-(2,1), 2 (2,1)-(1,1), 3 (1,1)-(1,2), 4 (1,2)-(0,2), 5 (0,2)-(0,0)
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.synchronize()
        groups = {"bottom": [lines[0]], "free": [lines[1], lines[2], lines[3]], "top": [lines[4]],
                  "left": [lines[5]]}
        name_groups(groups, surface)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", H)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", H)
        generate_and_write(OUT)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
