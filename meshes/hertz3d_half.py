#!/usr/bin/env python3
"""Generate ``nc_dolfinx/cases/hertz3d_half.msh``: half of the lower half of a ball, for the ``cattaneo3d`` case.

Ball of radius R = 1 centred at (0, 0, R); the part y >= 0, z <= R (the quarter of meshes/hertz3d.py
mirrored across x = 0). A tangential load along x keeps the plane y = 0 a symmetry plane but not x = 0,
hence the half. Its lowest point (0, 0, 0) is a mesh vertex. Linear tetrahedra, msh 4.1 ASCII. Physical
groups (names become boundary groups):

    top       the flat half disc z = R                     (Γ_D: clamped or moved, in the case)
    symmetry  the plane y = 0                              (symmetry: u_y = 0)
    contact   the spherical cap z <= Z_C (radius X_C = R/2 around the z-axis)   (Γ_C)
    free      the rest of the sphere                       (traction free)
    body      the cells (two volumes, split by the plane z = Z_C)

Built by gmsh_common.lower_ball, as meshes/hertz3d.py: the OCC sphere has its axis along x, so that its
poles (±R, 0, R) lie on the clamped edge, far from the contact point; the size is H_MIN within X_FINE of
the contact point, growing with slope GROWTH up to H_MAX, and the nodes are jittered (gmsh_common.jitter_nodes) so that
refinement is the same on any number of ranks. H_MIN = R/100 ≈ a/10 for the contact radius a ≈ 0.1 R of the
case (the stick radius c ≈ 0.8 a is then resolved by about eight cells).

Run: ``/usr/bin/python3 meshes/hertz3d_half.py`` (from any directory).
"""
import math
import sys
from pathlib import Path

from gmsh_common import lower_ball

R = 1.0
X_C = 0.5 * R                          # the contact group is the cap within this distance of the z-axis
Z_C = R - math.sqrt(R ** 2 - X_C ** 2)  # its height
H_MAX = R / 5                          # far from the contact
H_MIN = R / 100                        # near the contact point (the contact radius is ~0.1 R): a/10
X_FINE = 0.13 * R                      # ... up to this distance from it
GROWTH = 0.4                           # size gradient away from that region
JITTER = 0.01 * H_MIN                  # random node offsets (gmsh_common.jitter_nodes): no exactly equal edges
OUT = Path(__file__).resolve().parent.parent / "nc_dolfinx" / "cases" / (Path(__file__).stem + ".msh")


def main(out=OUT):
    lower_ball(out, "hertz3d_half", radius=R, x_min=-R, symmetry_planes={"symmetry": 1}, z_contact=Z_C,
               h_min=H_MIN, h_max=H_MAX, x_fine=X_FINE, growth=GROWTH, jitter=JITTER)


if __name__ == "__main__":
    main(*sys.argv[1:])
