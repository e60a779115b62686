#!/usr/bin/env python3
"""A coarse quarter of the lower half ball, uniform size h (issue 46: the 3D curved body, faceted at level 0).

The part x >= 0, y >= 0, z <= R of the ball of radius R = 1 centred at (0, 0, R) (the ``hertz3d`` body),
by :func:`gmsh_common.lower_ball`: groups ``top`` (z = R), ``symm_x`` (x = 0), ``symm_y`` (y = 0),
``contact`` (the spherical cap within R/2 of the z-axis) and ``free`` (the rest of the sphere); the lowest
point (0, 0, 0) a vertex. Linear tetrahedra of size h (default R/8) everywhere, nodes jittered by h/100
(projected back onto their surfaces: Plaza's ties, see gmsh_common.jitter_nodes). Not shipped: it takes
about a second to make.

Run: ``/usr/bin/python3 meshes/quarterball.py [H] [OUT]`` (default H = 0.125, OUT = quarterball.msh here).
"""
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from gmsh_common import lower_ball  # noqa: E402

R = 1.0
X_C = 0.5 * R                                # the contact cap: within X_C of the z-axis
Z_C = R - math.sqrt(R ** 2 - X_C ** 2)


def write(out, h=R / 8, cad=None):
    """Write the quarter ball of size ``h`` to ``out`` (.msh), and its CAD to ``cad`` (.brep) if given."""
    lower_ball(str(out), "quarterball", radius=R, x_min=0.0, symmetry_planes={"symm_x": 0, "symm_y": 1},
               z_contact=Z_C, h_min=h, h_max=h, x_fine=0.0, growth=0.0, jitter=0.01 * h, cad=cad)


if __name__ == "__main__":
    write(sys.argv[2] if len(sys.argv) > 2 else Path.cwd() / "quarterball.msh", float(sys.argv[1]) if len(sys.argv) > 1 else R / 8)
