#!/usr/bin/env python3
"""Generate ``corner.msh`` (next to this script): the L-shaped body of the ``corner`` case.

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

H = 0.25
OUT = Path(__file__).resolve().with_suffix(".msh")


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
        for tag, (name, curves) in enumerate(groups.items(), start=1):
            gmsh.model.addPhysicalGroup(1, curves, tag)
            gmsh.model.setPhysicalName(1, tag, name)
        gmsh.model.addPhysicalGroup(2, [surface], 1)
        gmsh.model.setPhysicalName(2, 1, "body")
        gmsh.option.setNumber("Mesh.CharacteristicLengthMin", H)
        gmsh.option.setNumber("Mesh.CharacteristicLengthMax", H)
        gmsh.option.setNumber("Mesh.ElementOrder", 1)
        gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay
        gmsh.model.mesh.generate(2)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.option.setNumber("Mesh.Binary", 0)
        gmsh.write(str(OUT))
        print(f"wrote {OUT}: {len(gmsh.model.mesh.getElementsByType(2)[0])} triangles")
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
