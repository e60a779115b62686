# ---
# jupyter:
#   jupytext:
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#   kernelspec:
#     display_name: Python 3 (Debian, DOLFINx 0.5)
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Three dimensions: a block on a foundation, half of it modelled with a symmetry plane
#
# Everything in Fernández & Hild's analysis is written for plane strain, but nothing in the method is
# two-dimensional: the discrete problem (7) is the same on tetrahedra, and the indicators of
# Definition 5 become integrals over the faces of the cells (η_2: stress jumps across interior faces and
# the traction misfit on Neumann faces; η_3, η_4: the tangential stress and the residual of the law (4)
# on contact faces), with h_K the diameter of the tetrahedron. The law itself,
#
# $$ \sigma_n(u) = -c_n (u_n)_+^{m_n}, \qquad \sigma_t(u) = 0 \qquad (4)$$
#
# now has a tangential stress *vector* σ_t = σν − σ_n ν. (In 3D the term $(u_n)_+^{m_n} v_n$ of (7) is
# integrable for all u, v in H¹ only if m_n ≤ 3: `nc_dolfinx` refuses larger exponents.)
#
# The body is the paper's block made 3D: [0, 2] × [−w, w] × [0, 1], clamped on its face x = 0, resting on
# the foundation along its base z = 0, loaded by its weight and by a traction on top that grows along x
# and is largest in the middle plane y = 0. Geometry and loads are symmetric about y = 0, so we model the
# half y ≥ 0 only: on the **symmetry plane** y = 0 the normal displacement u_y is 0 and the tangential
# traction vanishes (the `symmetry` role of a boundary group).
#
# Before that, a check of the 3D code against the 2D one: a slab with symmetry planes on *both* faces
# y = const and loads independent of y is in plane strain, so it must carry the same contact force per
# unit width as the 2D block.
#
# Run as a script (`python3 demos/demo_3d.py [--small] [--out DIR]`, also under mpirun) or as a notebook
# (jupytext). `--small` / `NC_DEMO_SMALL=1`: coarse meshes and few levels.

# %%
import matplotlib.pyplot as plt
import numpy as np
from dolfinx import mesh as dmesh
from mpi4py import MPI

import nc_dolfinx as nc

from support import SMALL, check, output_directory, say  # the demos' plumbing: options, printing, checks

comm = MPI.COMM_WORLD
out_dir = output_directory()


# %% [markdown]
# ## The plane strain check
#
# The built-in `box` is meshed with tetrahedra; its faces are the groups `left`/`right` (x = x0/x1),
# `front`/`back` (y = y0/y1) and `bottom`/`top` (z = z0/z1). Here both `front` and `back` are symmetry
# planes, every load is independent of y, and the data are the 2D block's (`nc.load_problem("block")`):
# E, ν, the weight, the traction −20x on top, c_n = 2000(1 + x), m_n = 1.5. A problem for a box gives
# every vector three components.

# %%
width = 0.25
block_3d = {
    "mesh": {"box": [[0.0, 0.0, 0.0], [2.0, width, 1.0]], "cells": [8, 1, 4],
             "dirichlet": ["left"], "neumann": ["top"], "contact": ["bottom"], "symmetry": ["front", "back"]},
    "material": {"E": 1.0e3, "nu": 0.3},
    "loads": {"f": ["0", "0", "-10"], "g": {"top": ["0", "0", "-20*x"]}},
    "contact": {"c_n": "2.0e3*(1 + x)", "m_n": 1.5},
    "adapt": {"refine": "adaptive", "levels": 3 if SMALL else 5, "theta": 0.5},
}
slab = nc.Problem.from_dict(block_3d, "slab")
slab_result = nc.adapt(slab)
force_3d = slab_result.final.row["contact_resultant"] / width

# %% [markdown]
# The 2D reference: the block in plane strain on a fine mesh (adaptive, so that its own discretisation
# error is well below the 3D one).

# %%
block_2d = nc.load_problem("block", ["adapt.levels=8" if SMALL else "adapt.levels=12"])
force_2d = nc.adapt(block_2d).final.row["contact_resultant"]
difference = abs(force_3d - force_2d) / force_2d
say(f"contact force per unit width: 3D slab {force_3d:.4f} ({slab_result.final.row['cells']} tetrahedra), "
    f"2D plane strain {force_2d:.4f}")
check(difference < 0.01, f"a 3D slab between two symmetry planes is in plane strain: its contact force per "
                         f"unit width is the 2D one within {100 * difference:.2f} % (< 1 %)")

# %% [markdown]
# ## The 3D problem
#
# The half block y ∈ [0, 0.5] of the block of width 1: `front` (y = 0) is the symmetry plane, `back`
# (y = 0.5) and `right` are in no role, hence traction free. The traction on top,
# $g = (0, 0, -40x(1 - 4y^2))$, is largest on the symmetry plane and vanishes on the free face.

# %%
half = nc.Problem.from_dict({
    **block_3d,
    "mesh": {**block_3d["mesh"], "box": [[0.0, 0.0, 0.0], [2.0, 0.5, 1.0]],
             "cells": [6, 2, 3] if SMALL else [8, 2, 4], "symmetry": ["front"]},
    "loads": {"f": ["0", "0", "-10"], "g": {"top": ["0", "0", "-40*x*(1 - 4*y*y)"]}},
    "adapt": {"refine": "adaptive", "levels": 4 if SMALL else 8, "theta": 0.5},
}, "half block")


def report(level):
    row = level.row
    say(f"  level {level.number}: {row['cells']:7d} tetrahedra, {row['dofs']:7d} dofs, η = {row['eta']:.4f} "
        f"(η_2 {row['eta_2']:.3f}, η_3 {row['eta_3']:.3f}, η_4 {row['eta_4']:.3f}), contact force "
        f"{row['contact_resultant']:.4f}")


result = nc.adapt(half, on_level=report)
history, final = result.history, result.final

# %% [markdown]
# ## Checks
#
# **Convergence.** For P1 elements in 3D the best possible rate is η ∝ N^{-1/3} (N dofs): adaptive
# refinement should approach it.

# %%
dofs = np.array([row["dofs"] for row in history], dtype=float)
eta = np.array([row["eta"] for row in history])
slope = np.polyfit(np.log(dofs[-3:]), np.log(eta[-3:]), 1)[0]
check(np.all(np.diff(eta) < 0), f"η falls on every level: {eta[0]:.4f} -> {eta[-1]:.4f}")
check(slope <= -0.25, f"η ∝ N^{slope:.3f} over the last three levels, close to the optimal N^(-1/3)")

# %% [markdown]
# **Where the load goes.** The modelled half carries half of the load: its weight
# $10 \cdot 2 \cdot 0.5 \cdot 1 = 10$ and the traction $\int_{top} 40x(1-4y^2) = 40 \cdot 2 \cdot (0.5 - 4/24)
# = 80/3$. The clamp and the foundation share it, both pushing up: the contact force lies between 0 and
# the load.

# %%
force = final.row["contact_resultant"]
load = 10 + 80 / 3
check(0 < force < load, f"0 < contact force {force:.4f} < load {load:.4f} "
                        f"(the foundation carries {100 * force / load:.1f} %)")

# %% [markdown]
# ## Pictures
#
# The contact pressure on the base z = 0, from the pressure projected onto P1 on Γ_C
# (`nc.contact_projection`) and evaluated at the midpoints of the contact faces, and the convergence
# of the estimator and its parts.

# %%
domain, u, fields = final.solution.domain, final.u, final.fields
pressure = nc.contact_projection(nc.contact_pressure(u, fields), fields, "contact_pressure")
msh = domain.mesh
faces = domain.facet_tags.indices[np.isin(domain.facet_tags.values, fields.ids["contact"])]
msh.topology.create_connectivity(2, 3)
face_cells = msh.topology.connectivity(2, 3)
cells = np.array([face_cells.links(f)[0] for f in faces], dtype=np.int32)
midpoints = dmesh.compute_midpoints(msh, 2, faces)
values = pressure.eval(midpoints, cells)[:, 0] if len(faces) else np.zeros(0)
gathered = comm.gather((midpoints[:, :2], values), root=0)
if comm.rank == 0:
    xy = np.concatenate([g[0] for g in gathered])
    p = np.concatenate([g[1] for g in gathered])
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 3.8), constrained_layout=True)
    shown = left.tricontourf(xy[:, 0], xy[:, 1], p, levels=20, cmap="viridis")
    left.set_aspect("equal")
    left.set_xlabel("x")
    left.set_ylabel("y (y = 0: symmetry plane)")
    left.set_title("contact pressure on Γ_C")
    fig.colorbar(shown, ax=left, shrink=0.8)
    right.loglog(dofs, eta, "o-", label="η")
    for i in range(1, 5):
        right.loglog(dofs, [row[f"eta_{i}"] for row in history], ".:", label=f"η_{i}")
    right.loglog(dofs, eta[0] * (dofs / dofs[0]) ** (-1 / 3), "k-", lw=0.8, label="∝ N^(−1/3)")
    right.set_xlabel("degrees of freedom N")
    right.legend(fontsize=8)
    fig.savefig(out_dir / "block_3d.png", dpi=120)
    plt.show(block=False)  # in a notebook: the figure, here; a script wrote the file
    say(f"wrote {out_dir / 'block_3d.png'}")
