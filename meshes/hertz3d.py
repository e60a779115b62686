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

The geometry, groups, size field and jitter are gmsh_common.lower_ball's (shared with meshes/hertz3d_half.py):
the OCC sphere is built with its axis along x, so that its poles, vertices with a fan of thin triangles,
(R, 0, R) and (−R, 0, R) are on the clamped edge or outside the quarter, far from the contact point (0, 0, 0).

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

from gmsh_common import lower_ball

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


def main(out=OUT):
    lower_ball(out, "hertz3d", radius=R, x_min=0.0, symmetry_planes={"symm_x": 0, "symm_y": 1}, z_contact=Z_C,
               h_min=H_MIN, h_max=H_MAX, x_fine=X_FINE, growth=GROWTH, jitter=JITTER)


if __name__ == "__main__":
    main(*sys.argv[1:])
