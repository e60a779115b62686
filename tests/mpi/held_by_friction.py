"""A block on the foundation that nothing but the foundation holds (no Γ_D, no symmetry plane): friction
holds the motions that slide it along Γ_C (nc_dolfinx.solver.settling). 2D: [0, 1] × [0, 0.5] pressed by
P on its top and sheared by ``shear`` (the horizontal traction); 3D: [0, 1] × [0, 0.5] × [0, 0.5], the
top also twisted about the vertical axis by ``twist`` (a traction twist·(−(y − y_c), x − x_c)), which
only friction's moment holds. ``half``: the block's right half, cut by the symmetry plane x = 1/2.

Shared by tests/test_held_by_foundation.py; run as a script (``held_by_friction.py DIM``, any number of
ranks) it prints (rank 0, JSON) the history's numbers and the nodal values sorted by coordinates.
"""
import json
import sys

import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

E, NU, P, C_N, M_N, MU = 1.0e3, 0.3, 10.0, 1.0e4, 1.5, 0.3
SHEAR, TWIST = 1.0, 0.3


def block(dim, friction=MU, shear=0.0, twist=0.0, half=False, diagonal="crossed"):
    """The block as an :class:`nc.Problem` (``friction`` None: frictionless)."""
    low = [0.5 if half else 0.0] + [0.0] * (dim - 1)
    high = [1.0] + [0.5] * (dim - 1)
    sides = ["left", "right"] + ([] if dim == 2 else ["front", "back"])
    mesh = {"contact": ["bottom"], "neumann": ["top"] + sides[half:], "symmetry": ["left"] if half else []}
    if dim == 2:
        mesh.update(rectangle=[low, high], cells=[3 if half else 6, 3], diagonal=diagonal)
        top = [f"{shear!r}", f"{-P!r}"]
    else:
        mesh.update(box=[low, high], cells=[3, 2, 2])
        top = [f"{shear!r} - {twist!r}*(y - 0.25)", f"{twist!r}*(x - 0.5)", f"{-P!r}"]
    contact = {"c_n": C_N, "m_n": M_N} | ({} if friction is None else {"friction": friction})
    data = {"mesh": mesh, "material": {"E": E, "nu": NU}, "loads": {"g": {"top": top}}, "contact": contact}
    return nc.Problem.from_dict(data, f"held{dim}d")


def sorted_nodal_values(u, comm):
    """(coordinates, values) of the owned nodes of all ranks, on rank 0, sorted by coordinates."""
    V = u.function_space
    dim, n = V.mesh.geometry.dim, V.dofmap.index_map.size_local
    gathered = comm.gather((V.tabulate_dof_coordinates()[:n, :dim], u.x.array[:n * dim].reshape(-1, dim)), root=0)
    if comm.rank != 0:
        return None, None
    points = np.concatenate([x for x, _ in gathered])
    values = np.concatenate([v for _, v in gathered])
    order = np.lexsort(np.round(points, 12).T[::-1])
    return points[order], values[order]


if __name__ == "__main__":
    dim = int(sys.argv[1])
    result = nc.adapt(block(dim, shear=SHEAR, twist=TWIST if dim == 3 else 0.0))
    row = result.history[-1]
    _, values = sorted_nodal_values(result.final.u, MPI.COMM_WORLD)
    if MPI.COMM_WORLD.rank == 0:
        keys = ("friction_force", "applied_load", "contact_force", "force_balance", "contact_resultant",
                "stick_length" if dim == 2 else "stick_area", "eta")
        print(json.dumps({"nodal_values": values.ravel().tolist(), **{k: row[k] for k in keys}}))
