#!/usr/bin/env python3
"""Generate ``nc_dolfinx/cases/hertz.msh``: the half-disc of the ``hertz`` case.

Disc of radius R = 1 centred at (0, 1), its part y <= 1: a flat top on y = 1 (x from -1 to 1) and the
lower half arc through (0, 0), where a mesh vertex sits exactly. Linear triangles, msh 4.1 ASCII.
Physical groups (names become boundary groups):

    top      the flat edge y = 1                       (Γ_D, clamped, in the case)
    contact  the arc where |x| <= X_C = R/2            (Γ_C)
    free     the rest of the arc                       (traction free)
    body     the cells

The size is H_MAX = R/8 far away and H_MIN = R/400 along the contact arc near (0, 0) (|x| <~ X_FINE),
growing with slope GROWTH away from that stretch of arc (so about R/100 at depth 0.03 R below it). It is
the maximum of two Distance + Threshold fields: one of the distance to (0, 0) (H_MIN up to X_FINE,
H_MAX further out), one of the distance to the contact arc (H_MIN on it). The arc is meshed by straight
edges, and refinement in the solver only bisects them, so the level-0 chords are the resolution of the
circular profile for good: with R/100 chords the kinks between them (angle h/R) give pressure spikes
at the vertices that grow under refinement (the peak pressure of the hertz case drifted to +6.4 % of
Hertz after 10 levels and kept rising); with R/400 it is +1.8 % after 10 levels, +2.1 % after 12, and
the half-width is within 1 %.

Run: ``/usr/bin/python3 meshes/hertz.py`` (from any directory).
"""
import math
from pathlib import Path

import gmsh
from gmsh_common import generate_and_write, name_groups

R = 1.0
X_C = 0.5 * R            # the contact group is the arc with |x| <= X_C
H_MAX = R / 8            # far from the contact
H_MIN = R / 400          # along the contact arc near (0, 0)
X_FINE = 0.12 * R        # ... up to this distance from (0, 0) (the contact half-width is ~0.08 R)
GROWTH = 0.2             # size gradient away from that stretch of arc
# The mesh ships with the package, beside its problem file.
OUT = Path(__file__).resolve().parent.parent / "nc_dolfinx" / "cases" / (Path(__file__).stem + ".msh")


def main():
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("hertz")
        geo = gmsh.model.geo
        yc = R - math.sqrt(R ** 2 - X_C ** 2)  # height of the arc at x = ±X_C
        centre = geo.addPoint(0, R, 0)
        left, right = geo.addPoint(-R, R, 0), geo.addPoint(R, R, 0)
        c_left, c_right = geo.addPoint(-X_C, yc, 0), geo.addPoint(X_C, yc, 0)
        bottom = geo.addPoint(0, 0, 0)
        top = geo.addLine(right, left)
        free_left = geo.addCircleArc(left, centre, c_left)
        contact_left = geo.addCircleArc(c_left, centre, bottom)
        contact_right = geo.addCircleArc(bottom, centre, c_right)
        free_right = geo.addCircleArc(c_right, centre, right)
        loop = geo.addCurveLoop([top, free_left, contact_left, contact_right, free_right])
        surface = geo.addPlaneSurface([loop])
        geo.synchronize()

        groups = {"top": [top], "contact": [contact_left, contact_right], "free": [free_left, free_right]}
        name_groups(groups, surface)

        field = gmsh.model.mesh.field
        near_origin = field.add("Distance")
        field.setNumbers(near_origin, "PointsList", [bottom])
        around_origin = field.add("Threshold")  # H_MIN within X_FINE of (0, 0), H_MAX far away
        field.setNumber(around_origin, "InField", near_origin)
        field.setNumber(around_origin, "SizeMin", H_MIN)
        field.setNumber(around_origin, "SizeMax", H_MAX)
        field.setNumber(around_origin, "DistMin", X_FINE)
        field.setNumber(around_origin, "DistMax", X_FINE + (H_MAX - H_MIN) / GROWTH)
        near_arc = field.add("Distance")
        field.setNumbers(near_arc, "CurvesList", [contact_left, contact_right])
        field.setNumber(near_arc, "NumPointsPerCurve", 2000)
        along_arc = field.add("Threshold")      # H_MIN on the contact arc, growing into the body
        field.setNumber(along_arc, "InField", near_arc)
        field.setNumber(along_arc, "SizeMin", H_MIN)
        field.setNumber(along_arc, "SizeMax", H_MAX)
        field.setNumber(along_arc, "DistMin", 0.0)
        field.setNumber(along_arc, "DistMax", (H_MAX - H_MIN) / GROWTH)
        size = field.add("Max")                 # fine only near both the arc and (0, 0)
        field.setNumbers(size, "FieldsList", [around_origin, along_arc])
        field.setAsBackgroundMesh(size)
        gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
        gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)
        generate_and_write(OUT)
    finally:
        gmsh.finalize()


if __name__ == "__main__":
    main()
