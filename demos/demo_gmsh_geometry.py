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
# # Your own geometry with gmsh: a plate with a hole and a stiff inclusion, solved adaptively
#
# The built-in rectangle and box are for learning; real bodies come from a mesh generator. This demo
# builds a geometry with the [gmsh](https://gmsh.info) Python API inside the script, names its parts
# with *physical groups*, hands the model to `nc_dolfinx` without a file (`nc.from_gmsh_model`), gives
# each part its own material, and solves the normal compliance problem (7) of Fernández & Hild with
# adaptive refinement driven by the estimator of Definition 5.
#
# The body is the paper's setting with holes in it: a plate [0, 2] × [0, 1], clamped on its left side
# (Γ_D), loaded by its weight and a traction on top (Γ_N), resting along its base (Γ_C) on a foundation
# with the normal compliance law (4),
#
# $$ \sigma_n(u) = -c_n (u_n)_+^{m_n}, \qquad \sigma_t(u) = 0 \quad \text{on } \Gamma_C, $$
#
# and with a circular hole (traction free) and a circular inclusion of a material 20 times stiffer.
#
# Run as a script (`python3 demos/demo_gmsh_geometry.py [--small] [--out DIR]`, also under mpirun) or
# as a notebook (jupytext). `--small` / `NC_DEMO_SMALL=1`: a coarser mesh and fewer levels.

# %%
import math

import gmsh
import matplotlib.pyplot as plt
import numpy as np
import ufl
from dolfinx import fem
from matplotlib.colors import LogNorm
from mpi4py import MPI

import nc_dolfinx as nc

from support import SMALL, check, draw_cells, output_directory, say  # the demos' plumbing: options, printing, checks

comm = MPI.COMM_WORLD
out_dir = output_directory()


# %% [markdown]
# ## The geometry in gmsh
#
# With gmsh's OpenCASCADE kernel we cut a disc out of a rectangle (the hole) and *fragment* the result
# with a second disc (the inclusion): fragmenting keeps both pieces and makes their meshes match along
# the circle between them. gmsh numbers the curves and surfaces it creates; we recognise them by their
# centres of mass.
#
# *Physical groups* give the parts the names the problem refers to: the curves `left` (clamped, Γ_D),
# `bottom` (Γ_C), `top` (loaded, Γ_N), `right` and `hole` (traction free), and the surfaces `plate` and
# `inclusion`, the two materials. The circle between plate and inclusion is inside the body and needs no
# group. Only rank 0 builds the model; `from_gmsh_model` distributes the mesh over the ranks. The work of
# rank 0 goes to it as a function, `build`, which it runs on rank 0 between `gmsh.initialize()` and
# `gmsh.finalize()`: if `build` raises, every rank stops with the same `InputError` ("the gmsh model built
# on rank 0 failed: …"), where a script that built the model itself would leave the other ranks waiting
# in `from_gmsh_model` for rank 0, which never comes.

# %%
hole_centre, inclusion_centre, radius = (1.4, 0.55), (0.6, 0.45), 0.2
size, per_circle = (0.15, 32) if SMALL else (0.08, 64)  # element size; elements along a circle


def plate_model():
    """Mesh the plate with its hole and inclusion in gmsh.model (call on one rank)."""
    occ = gmsh.model.occ
    rectangle = occ.addRectangle(0, 0, 0, 2, 1)
    hole = occ.addDisk(*hole_centre, 0, radius, radius)
    inclusion = occ.addDisk(*inclusion_centre, 0, radius, radius)
    plate, _ = occ.cut([(2, rectangle)], [(2, hole)])
    occ.fragment(plate, [(2, inclusion)])
    occ.synchronize()

    def named(dim, where):
        """Tags of the entities of dimension dim whose centre of mass (x, y) satisfies where(x, y)."""
        return [tag for _, tag in gmsh.model.getEntities(dim) if where(*occ.getCenterOfMass(dim, tag)[:2])]

    near = lambda a, b: abs(a - b) < 1e-6  # noqa: E731
    groups = {(1, "left"): named(1, lambda x, y: near(x, 0)), (1, "right"): named(1, lambda x, y: near(x, 2)),
              (1, "bottom"): named(1, lambda x, y: near(y, 0)), (1, "top"): named(1, lambda x, y: near(y, 1)),
              (1, "hole"): named(1, lambda x, y: near(x, hole_centre[0]) and near(y, hole_centre[1])),
              (2, "inclusion"): named(2, lambda x, y: near(x, inclusion_centre[0])),
              (2, "plate"): named(2, lambda x, y: not near(x, inclusion_centre[0]))}
    for (dim, name), tags in groups.items():
        gmsh.model.setPhysicalName(dim, gmsh.model.addPhysicalGroup(dim, tags), name)
    # element sizes: at most `size`, and `per_circle` elements along a full circle (from its curvature)
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", per_circle)
    gmsh.model.mesh.generate(2)


def build(gmsh):
    """Rank 0's work: the model, meshed, also saved as a file (for the problem's [mesh] below)."""
    gmsh.option.setNumber("General.Terminal", 0)  # quiet
    gmsh.model.add("plate")
    plate_model()
    gmsh.write(str(out_dir / "plate.msh"))


domain = nc.from_gmsh_model(comm, build=build, rank=0)
say(f"{domain.num_cells()} triangles; boundary groups {domain.facet_groups}, regions {domain.cell_groups}")

# %% [markdown]
# ## The problem
#
# The problem names the groups and regions of the mesh:
#
# - `[mesh]`: the roles of the boundary groups — `left` is Γ_D, `bottom` is Γ_C, `top` is Γ_N with a
#   traction; `right` and `hole`, in no role, are traction free. A problem also says how to make its
#   mesh: we saved the model as `plate.msh` above, so `file` can name it (and the same problem, written
#   as TOML, runs from the command line), but here we hand `adapt` the domain we already have.
# - `[material]`: E and ν for the whole body, and `regions.inclusion` overriding them on the cell group
#   `inclusion`.
# - `[loads]`: the weight f and the traction g on `top` (growing along x), as in the paper's setting.
# - `[contact]`: c_n, stiffer to the right, and m_n = 1.5.

# %%
levels = 4 if SMALL else 8
problem = nc.Problem.from_dict({
    "title": "plate with a hole and a stiff inclusion on a foundation",
    "mesh": {"file": str(out_dir / "plate.msh"), "dirichlet": ["left"], "contact": ["bottom"],
             "neumann": ["top"]},
    "material": {"E": 1.0e3, "nu": 0.3, "regions": {"inclusion": {"E": 2.0e4, "nu": 0.3}}},
    "loads": {"f": ["0", "-10"], "g": {"top": ["0", "-20*x"]}},
    "contact": {"c_n": "2.0e3*(1 + x)", "m_n": 1.5},
    "adapt": {"refine": "adaptive", "levels": levels, "theta": 0.5},
}, "plate")

# %% [markdown]
# ## Solving adaptively
#
# `adapt` runs SOLVE → ESTIMATE → MARK → REFINE from our domain. Refinement bisects edges, and
# `from_gmsh_model` kept the model's CAD (OpenCASCADE geometry): a new vertex on the hole's boundary is
# placed on the hole's circle, not left on the chord of its parent, so the body converges to the true
# plate (guide: "Curved boundaries: the true shape"). The circle between plate and inclusion lies inside the
# body, in no boundary group: its level-0 polygon stays (interfaces inside the body are not moved). The
# boundary groups and the two materials follow every refinement. We keep each level's region areas to check
# that.

# %%
def region_areas(level_domain):
    """{region name: area} from the domain's DG0 region ids."""
    indicator = fem.Function(level_domain.region.function_space)
    areas = {}
    for name, region_id in level_domain.cell_groups.items():
        indicator.x.array[:] = np.isclose(level_domain.region.x.array, region_id)
        areas[name] = nc.integrate(indicator * ufl.dx(domain=level_domain.mesh), comm)
    return areas


areas = []


def on_level(level):
    areas.append(region_areas(level.solution.domain))
    row = level.row
    say(f"  level {level.number}: {row['cells']:6d} cells, η = {row['eta']:.4e}, contact force "
        f"{row['contact_resultant']:.5f}, contact length {row['contact_length']:.4f}")


result = nc.adapt(problem, domain=domain, on_level=on_level)
final = result.final

# %% [markdown]
# ## Checks
#
# **Materials follow the geometry, the hole its circle.** Refinement never moves the circle between
# plate and inclusion, so the inclusion's area is the same on every level, close to the exact one (the
# level-0 polygon is inscribed in the circle). The hole's boundary does move onto its circle: the hole's
# area, 2 minus the two regions', comes no farther from πr² than on level 0 (closer wherever its boundary
# was refined).

# %%
inclusion = [a["inclusion"] for a in areas]
spread = max(abs(a - inclusion[0]) for a in inclusion) / inclusion[0]
check(spread <= 1e-12, f"region inclusion: area {inclusion[-1]:.6f} on every level (largest relative change "
                       f"{spread:.0e})")
circle = math.pi * radius ** 2
check(abs(inclusion[0] / circle - 1) < 0.01, f"region inclusion: its area is within 1 % of the exact "
                                             f"{circle:.6f} ({100 * (inclusion[0] / circle - 1):+.2f} %)")
hole = [2.0 - a["plate"] - a["inclusion"] for a in areas]
check(abs(hole[0] / circle - 1) < 0.01, f"the hole: its area on level 0, {hole[0]:.6f}, is within 1 % of πr² = "
                                       f"{circle:.6f}")
check(abs(hole[-1] - circle) <= abs(hole[0] - circle),
      f"the hole: its area on the last level, {hole[-1]:.6f}, is no farther from πr² (its boundary on the circle)")

# %% [markdown]
# **Where the load goes.** The weight and the traction on top, together
# $\int_\Omega 10 + \int_{top} 20x = 10|\Omega| + 40$, are carried by the clamp and the foundation, both
# pushing up: the contact force must be positive and less than the load.

# %%
load = 10 * sum(areas[-1].values()) + 40
force = final.row["contact_resultant"]
check(0 < force < load, f"0 < contact force {force:.4f} < load {load:.4f} "
                        f"(the foundation carries {100 * force / load:.1f} %)")

# %% [markdown]
# **Convergence.** The estimator falls level by level, at a rate close to the optimal N^{-1/2} of P1
# elements in 2D, although the solution is singular where the clamp meets the free and the contact
# edges.

# %%
dofs = np.array([row["dofs"] for row in result.history], dtype=float)
eta = np.array([row["eta"] for row in result.history])
slope = np.polyfit(np.log(dofs[-3:]), np.log(eta[-3:]), 1)[0]
check(np.all(np.diff(eta) < 0), f"η falls on every level: {eta[0]:.4e} -> {eta[-1]:.4e}")
say(f"η ∝ N^{slope:.3f} over the last three levels (optimal: N^-0.5)")


# %% [markdown]
# ## Pictures
#
# The final mesh coloured by material, and the estimator η_K on it (log scale): the refinement gathers
# at the corners of the clamp, around the hole and along the inclusion.

# %%
fig, axes = plt.subplots(1, 2, figsize=(12, 3.6), constrained_layout=True)
draw_cells(axes[0], final.solution.domain.region, f"the final mesh: plate (grey) and inclusion (red), "
           f"{final.row['cells']} cells", cmap="Pastel1", edgecolors="k", linewidth=0.05)
shown = draw_cells(axes[1], final.estimate.fields["eta"], "η_K", norm=LogNorm(), cmap="viridis",
                   edgecolors="w", linewidth=0.05)
if comm.rank == 0:
    fig.colorbar(shown, ax=axes[1], shrink=0.8)
    fig.savefig(out_dir / "plate.png", dpi=130)
    plt.show(block=False)  # in a notebook: the figure, here; a script wrote the file
    say(f"wrote {out_dir / 'plate.png'}")
