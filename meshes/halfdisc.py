#!/usr/bin/env python3
"""A coarse half-disc of uniform size h (issue 46: a curved body whose level-0 facets are visibly faceted).

Disc of radius R = 1 centred at (0, 1), its part y <= 1: a flat top on y = 1 and the lower half arc through
(0, 0), a mesh vertex. Linear triangles of size h (default R/10) everywhere, msh 4.1 ASCII. Physical groups:

    top      the flat edge y = 1
    contact  the arc where |x| <= R/2
    free     the rest of the arc
    body     the cells

Unlike meshes/hertz.py (R/400 along the contact arc, shipped), this mesh is coarse where the contact is: its
chords sag by h²/8R from the circle, and refinement converges to the circle only if the problem file gives
the shape ([mesh.shapes.contact.circle], verification/curved.py). It is not shipped: it takes well under a
second to make.

Run: ``/usr/bin/python3 meshes/halfdisc.py [H] [OUT]`` (default H = 0.1, OUT = halfdisc.msh here).
"""
import math
import sys
from pathlib import Path

import gmsh

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gmsh_common import generate_and_write, name_groups  # noqa: E402

R = 1.0
X_C = 0.5 * R            # the contact group is the arc with |x| <= X_C


def write(out, h=R / 10):
    """Write the half-disc of size ``h`` to ``out`` (.msh)."""
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("halfdisc")
        geo = gmsh.model.geo
        yc = R - math.sqrt(R ** 2 - X_C ** 2)
        centre = geo.addPoint(0, R, 0)
        left, right = geo.addPoint(-R, R, 0), geo.addPoint(R, R, 0)
        c_left, c_right = geo.addPoint(-X_C, yc, 0), geo.addPoint(X_C, yc, 0)
        bottom = geo.addPoint(0, 0, 0)
        top = geo.addLine(right, left)
        arcs = [geo.addCircleArc(left, centre, c_left), geo.addCircleArc(c_left, centre, bottom),
                geo.addCircleArc(bottom, centre, c_right), geo.addCircleArc(c_right, centre, right)]
        surface = geo.addPlaneSurface([geo.addCurveLoop([top, *arcs])])
        geo.synchronize()
        name_groups({"top": [top], "contact": arcs[1:3], "free": [arcs[0], arcs[3]]}, surface)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h)
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        generate_and_write(out)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    write(sys.argv[2] if len(sys.argv) > 2 else Path.cwd() / "halfdisc.msh", float(sys.argv[1]) if len(sys.argv) > 1 else R / 10)
