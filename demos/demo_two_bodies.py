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
# # Two deformable bodies: two cylinders pressed together, against Hertz
#
# Until now one body met a foundation. Here both sides deform: two elastic cylinders (plane strain), each
# a half-disc of radius 1, touch at the origin; the lower one's flat bottom is clamped and the upper one's
# flat top is pushed down by d. Between their contact arcs acts the normal compliance law of the paper,
# with the jump of the normal displacement across the pair in place of the body's normal displacement:
#
# $$ p = c_n \big( (u(x) - u(\Pi x))\cdot\nu - g_0(x) \big)_+^{m_n}, $$
#
# Π x the closest point of the other arc (in the reference configuration), ν the outward normal of the arc
# that x lies on, g_0 the distance between the arcs along ν. A problem file names the two faces of the pair
# (`[[pairs]] faces = ["upper_contact", "lower_contact"]`) and its law (`c_n`, `m_n`); the two bodies are
# two connected parts of one mesh, here the built-in case `two_cylinders`, whose arcs are meshed
# differently (non-matching).
#
# Hertz for two cylinders: the combined radius R = R₁R₂/(R₁ + R₂) = 1/2 and modulus
# E* = ((1 − ν₁²)/E₁ + (1 − ν₂²)/E₂)⁻¹ give the half-width a = 2 √(F R/(π E*)) and the peak pressure
# p₀ = 2F/(π a) for the force F per unit length.
#
# Run as a script (`python3 demos/demo_two_bodies.py [--small] [--out DIR]`, also under mpirun) or as a
# notebook (jupytext). `--small` / `NC_DEMO_SMALL=1`: few levels.

# %%
import math

import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

from support import SMALL, check, output_directory, say  # the demos' plumbing: options, printing, checks

comm = MPI.COMM_WORLD
out_dir = output_directory()

# %% [markdown]
# ## Solve and refine
#
# The case gives each arc its circle (`[mesh.shapes]`), so that refinement converges to the cylinders and
# not to the level-0 chords. The estimator's contact terms (η_3, η_4 of Definition 5) are taken on both
# faces of the pair, each with the pressure of its own points.

# %%
problem = nc.load_problem("two_cylinders")
result = nc.adapt(problem, levels=3 if SMALL else 6)
history = result.history
for row in history:
    say(f"level {row['level']}: {row['dofs']:6d} dofs, eta = {row['eta']:.3e}, "
        f"F = {abs(row['pair1_force'][1]):.5f}, a = {row['pair1_contact_length'] / 2:.5f}")

# %% [markdown]
# ## Against Hertz
#
# F is the force the lower cylinder exerts on the upper one (`pair1_force`, what the residual carries);
# the contact half-width is half the measure of {p > 0} on the upper arc, the peak the largest pressure at
# the pair's integration points.

# %%
E, nu, R = problem.parameters["E"], 0.3, 0.5
e_star = E / (2 * (1 - nu ** 2))
last = history[-1]
F = abs(last["pair1_force"][1])
a_hertz = 2 * math.sqrt(F * R / (math.pi * e_star))
p0_hertz = 2 * F / (math.pi * a_hertz)
a, p0 = last["pair1_contact_length"] / 2, last["pair1_max_pressure"]
say(f"half-width {a:.5f} (Hertz {a_hertz:.5f}, {a / a_hertz - 1:+.2%}), "
    f"peak {p0:.3f} (Hertz {p0_hertz:.3f}, {p0 / p0_hertz - 1:+.2%})")
tolerance = 0.06 if SMALL else 0.03
check(abs(a / a_hertz - 1) < tolerance, f"the half-width is within {tolerance:.0%} of Hertz")
check(abs(p0 / p0_hertz - 1) < tolerance, f"the peak pressure is within {tolerance:.0%} of Hertz")

# %% [markdown]
# Each body is in equilibrium by itself: the clamp under the lower cylinder carries exactly the pair's
# force (the force on the lower body is −`pair1_force`), and the prescribed top of the upper one the
# opposite.

# %%
lower, upper = last["reaction_lower_bottom"], last["reaction_upper_top"]
check(abs(lower[1] - last["pair1_force"][1]) < 1e-8 * F and abs(upper[1] + last["pair1_force"][1]) < 1e-8 * F,
      "each body's reactions balance the pair's force (to 1e-8)")
check(history[-1]["eta"] < history[0]["eta"], "η falls as the meshes of both bodies are refined")

# %% [markdown]
# ## The pressure along the contact
#
# Each rank holds the pair's points on its own facets; gathered on rank 0 they trace Hertz's ellipse
# p(x) = p₀ √(1 − x²/a²).

# %%
points, pressure = nc.pair_pressure(result.final.u, result.final.fields)
gathered = comm.gather((points[:, 0], pressure), root=0)
if comm.rank == 0:
    x = np.concatenate([g[0] for g in gathered])
    p = np.concatenate([g[1] for g in gathered])
    near = np.abs(x) < 2.5 * a_hertz
    xs = np.linspace(-a_hertz, a_hertz, 201)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(x[near], p[near], ".", ms=2, label="computed (integration points of the upper arc)")
    ax.plot(xs, p0_hertz * np.sqrt(np.maximum(1 - xs ** 2 / a_hertz ** 2, 0)), "k-", lw=1, label="Hertz")
    ax.set_xlabel("x")
    ax.set_ylabel("contact pressure")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out_dir / "two_cylinders_pressure.png", dpi=120)
    say(f"wrote {out_dir / 'two_cylinders_pressure.png'}")
