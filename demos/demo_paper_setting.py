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
# # The paper's setting step by step: solve, estimate, mark, refine
#
# This demo walks through the method of J.R. Fernández and P. Hild, *A posteriori error analysis for
# the normal compliance problem*, with `nc_dolfinx`. Equation and definition numbers are the paper's.
#
# An elastic body Ω ⊂ ℝ² (plane strain) is clamped on Γ_D, loaded by a body force f and a traction g on
# Γ_N, and rests on a deformable foundation along Γ_C:
#
# $$ -\operatorname{div}\sigma(u) = f \text{ in } \Omega, \quad u = 0 \text{ on } \Gamma_D, \quad
#    \sigma(u)\nu = g \text{ on } \Gamma_N \qquad (1)\text{–}(3)$$
#
# and on Γ_C the **normal compliance** law (4): the foundation pushes back with a pressure that grows
# with the penetration $(u_n)_+$,
#
# $$ \sigma_n(u) = -c_n (u_n)_+^{m_n}, \qquad \sigma_t(u) = 0. \qquad (4)$$
#
# With P1 elements the discrete problem (7) reads: find $u_h \in V_h$ with
#
# $$ a(u_h, v_h) + j_n(u_h, v_h) = L(v_h) \quad \forall v_h \in V_h, \qquad
#    j_n(u, v) = \int_{\Gamma_C} c_n (u_n)_+^{m_n} v_n. \qquad (7)$$
#
# Definition 5 measures the error of $u_h$ cell by cell with four indicators: the element residual
# $\eta_{1K} = h_K\|f_K\|_K$, the stress jumps across edges $\eta_{2K}$, the tangential stress on Γ_C
# $\eta_{3K}$ (the law wants σ_t = 0) and the residual of the law (4) on Γ_C
# $\eta_{4K} = h_K^{1/2}\|c_n (u_{hn})_+^{m_n} + \sigma_n(u_h)\|$; $\eta_K^2 = \sum_i \eta_{iK}^2$.
# Theorem 6 bounds the error by η (+ the data oscillation ζ), Theorem 7 bounds each η_K by the local
# error, so η can both certify a solution and say *where* to refine.
#
# We go through: the problem in code → solve (7) → the four indicators as pictures → one adaptive step
# by hand (estimate, mark, refine, solve again from the transferred solution) → the whole loop and its
# convergence plot. Each step checks a number it prints (lines starting with `checked:`).
#
# Run it as a script (`python3 demos/demo_paper_setting.py [--small] [--out DIR]`, also under
# `mpirun -n 2`) or open it as a notebook with jupytext. `--small` (or `NC_DEMO_SMALL=1`) uses a coarse
# mesh and few levels; pictures go to `--out DIR` (or `NC_DEMO_OUT`), by default a new temporary
# directory.

# %%
import matplotlib.pyplot as plt
import numpy as np
import ufl
from dolfinx import fem
from matplotlib.colors import LogNorm
from mpi4py import MPI

import nc_dolfinx as nc
from nc_dolfinx import dolfinx_versions as versions

from support import SMALL, check, draw_cells, output_directory, say  # the demos' plumbing: options, printing, checks

comm = MPI.COMM_WORLD
out_dir = output_directory()


# %% [markdown]
# ## The problem, written in code
#
# A problem is a table with the same keys as a TOML problem file (`nc.load_problem("block")` reads the
# built-in file of this very setting). Key by key:
#
# - `mesh`: the built-in `rectangle` [0, 2] × [0, 1] with `cells` triangles per direction; its sides
#   are the boundary groups `left`, `right`, `bottom`, `top`. The groups take the roles of §2:
#   `dirichlet` is Γ_D (clamped, (2)), `neumann` is Γ_N (tractions, (3)), `contact` is Γ_C (law (4)).
# - `material`: Young's modulus E and Poisson's ratio ν of Hooke's law σ(u) = 2με(u) + λ tr ε(u) I.
# - `loads`: the body force f (the weight, one expression per coordinate) and the traction g per
#   Neumann group (here a load growing along the top, `x` is the coordinate). `right` gets no entry:
#   it is traction free.
# - `contact`: the foundation's stiffness c_n (a function of x here: stiffer to the right) and the
#   exponent m_n ≥ 1 of the law (4). m_n = 1 with a large c_n is the penalty method (Remark 1).
# - `adapt`: the loop's defaults: adaptive refinement, the number of levels, Dörfler's θ.
#
# Every number becomes a `fem.Constant` in the forms, so changing a value later
# (`problem.replace({"contact.c_n": 5e3})`) compiles nothing new (see `demo_parameter_study.py`).

# %%
cells = [8, 4] if SMALL else [16, 8]
levels = 5 if SMALL else 9
data = {
    "title": "block: the paper's setting",
    "mesh": {"rectangle": [[0.0, 0.0], [2.0, 1.0]], "cells": cells,
             "dirichlet": ["left"], "neumann": ["top", "right"], "contact": ["bottom"]},
    "material": {"E": 1.0e3, "nu": 0.3},
    "loads": {"f": ["0", "-10"], "g": {"top": ["0", "-20*x"]}},
    "contact": {"c_n": "2.0e3*(1 + x)", "m_n": 1.5},
    "adapt": {"refine": "adaptive", "levels": levels, "theta": 0.5},
}
problem = nc.Problem.from_dict(data, "block")
say(f"{problem.title}: c_n = {problem['contact.c_n']}, m_n = {problem['contact.m_n']}")

# %% [markdown]
# A mistake is caught before any mesh exists, with one line that names it: every key is checked
# (unknown keys, missing physics, ranges such as m_n ≥ 1).

# %%
try:
    nc.Problem.from_dict({**data, "contact": {"c_n": 1e3, "m_n": 0.5}})
except nc.InputError as err:
    say(f"refused: {err}")

# %% [markdown]
# ## The mesh and the solution of (7)
#
# `build_domain` makes the level-0 mesh of the `[mesh]` table: a `Domain`, i.e. a DOLFINx mesh with its
# named boundary groups and material regions (which survive refinement). `solve` binds the problem to
# it (`nc.bind`: every coefficient of (7) as UFL) and solves (7) with Newton's method (PETSc SNES) and
# the exact Jacobian of j_n. For m_n > 1 the map $u \mapsto (u_n)_+^{m_n}$ is C¹; for m_n = 1 it has a
# kink and the Jacobian is the generalized (semismooth Newton) one.

# %%
domain = nc.build_domain(problem, comm)
solution = nc.solve(problem, domain)
u, fields = solution.u, solution.fields
say(f"{domain.num_cells()} cells, groups {domain.facet_groups}; Newton: {solution.stats.newton_iterations} "
    f"iterations ({solution.stats.converged_reason})")

quantities = nc.solution_quantities(u, fields)
say(f"contact resultant ∫_Γ_C p = {quantities['contact_resultant']:.4f}, largest penetration "
    f"{quantities['max_penetration']:.3e}, elastic energy {quantities['elastic_energy']:.4f}")

# %% [markdown]
# **Check.** $u_h$ solves (7) for every $v_h \in V_h$, in particular for $v_h = u_h$ itself:
# $a(u_h, u_h) + j_n(u_h, u_h) = L(u_h)$. We assemble the three terms separately — the elastic energy
# is $\tfrac12 a(u_h, u_h)$, `nc.contact_pressure` is $p = c_n (u_{hn})_+^{m_n}$ on Γ_C and the loads
# are the problem's f and g — and compare.

# %%
n = ufl.FacetNormal(domain.mesh)
a_uu = 2 * quantities["elastic_energy"]
j_uu = nc.integrate(nc.contact_pressure(u, fields) * ufl.dot(u, n) * nc.contact_measure(fields), comm)
L_u = nc.integrate(ufl.dot(fields.f, u) * ufl.dx, comm)
for group, g in fields.g.items():
    L_u += nc.integrate(ufl.dot(g, u) * fields.ds(group), comm)
say(f"a(u_h,u_h) = {a_uu:.6f}, j_n(u_h,u_h) = {j_uu:.6f}, L(u_h) = {L_u:.6f}")
check(abs(a_uu + j_uu - L_u) <= 1e-8 * abs(L_u),
      f"(7) tested with v_h = u_h: |a + j_n − L| / L = {abs(a_uu + j_uu - L_u) / abs(L_u):.1e} <= 1e-8")

# %% [markdown]
# ## The indicators of Definition 5
#
# `estimate` returns the cellwise indicators as DG0 fields (`est.fields["eta_1"]` … `["eta_4"]`,
# `["eta"]`, `["zeta"]`) and their global values $\eta_i = (\sum_K \eta_{iK}^2)^{1/2}$ (`est.totals`).

# %%
est = nc.estimate(u, fields)
say("  ".join(f"{name} = {value:.4g}" for name, value in est.totals.items()))


# %% [markdown]
# To draw a DG0 field, `draw_cells` (in `support.py`, next to the demos) gathers each owned cell's
# three vertices and its value on rank 0 and colours the triangles with matplotlib's `tripcolor`.

# %%
def draw_indicators(estimate, path):
    """η_1 … η_4 on a common log colour scale (cells where an indicator is 0 are left blank)."""
    largest = max(comm.allreduce(float(estimate.fields[f"eta_{i}"].x.array.max()), MPI.MAX)
                  for i in range(1, 5))
    norm = LogNorm(vmin=largest * 1e-4, vmax=largest)
    fig, axes = plt.subplots(2, 2, figsize=(11, 5.5), constrained_layout=True)
    for i, ax in enumerate(axes.ravel(), start=1):
        field = estimate.fields[f"eta_{i}"]
        masked = fem.Function(field.function_space)
        masked.x.array[:] = np.where(field.x.array > 0, field.x.array, np.nan)  # 0: not on this part
        shown = draw_cells(ax, masked, f"η_{i}K  (η_{i} = {estimate.totals[f'eta_{i}']:.3g})", norm=norm,
                           cmap="viridis", edgecolors="w", linewidth=0.1)
        if shown is not None:
            fig.colorbar(shown, ax=ax, shrink=0.8)
    if comm.rank == 0:
        fig.savefig(path, dpi=120)
        plt.show(block=False)  # in a notebook: the figure, here; a script wrote the file
        say(f"wrote {path}")


draw_indicators(est, out_dir / "indicators.png")

# %% [markdown]
# What the pictures show (`indicators.png`): η_1 (the weight, h_K‖f_K‖) is the same small value
# everywhere on a uniform mesh; η_2, the stress jumps, dominates and peaks at the two left corners,
# where the clamp meets a free or a contact edge and σ is singular; η_3 and η_4 live on the contact
# cells only: the tangential stress the law forbids, and the mismatch between the discrete pressure
# $c_n(u_{hn})_+^{m_n}$ and $-\sigma_n(u_h)$ computed from the displacement.
#
# ## One adaptive step by hand
#
# **MARK.** Dörfler's bulk criterion: a set M of cells, as small as possible, carrying the fraction θ
# of the squared estimator: $\sum_{K\in M} \eta_K^2 \ge \theta\,\eta^2$. `mark` returns the local
# indices of the owned cells in M; the decision is global, so it does not depend on the partition.

# %%
theta = problem["adapt.theta"]
marked = nc.mark(est, theta)
eta_K = est.fields["eta"].x.array[:domain.mesh.topology.index_map(2).size_local]
marked_share = comm.allreduce(float(np.sum(eta_K[marked] ** 2)), MPI.SUM) / est.totals["eta"] ** 2
n_marked = comm.allreduce(len(marked), MPI.SUM)
say(f"marked {n_marked} of {domain.num_cells()} cells")
check(marked_share >= theta, f"Dörfler: the marked cells carry {marked_share:.4f} of η² >= θ = {theta}")

# %% [markdown]
# **REFINE.** `refine` bisects the marked cells (Plaza's algorithm, plus what conformity needs); the
# boundary groups and material regions follow. **Transfer.** The old solution is carried to the new
# mesh by `transfer`: every new vertex is an old vertex or an edge midpoint, so the P1 function is
# carried *exactly* — the same piecewise-linear function on a finer mesh. We check that: its
# integrals ∫|u|² and ∫|∇u|² must not change.

# %%
child = nc.refine(domain, marked)
V_child = versions.p1_space(child.mesh, (child.mesh.geometry.dim,))  # P1 vectors, in any DOLFINx's spelling
u_carried = nc.transfer(u, V_child)
say(f"refined: {domain.num_cells()} -> {child.num_cells()} cells")
for name, norm_of in (("∫|u|²", lambda w: ufl.inner(w, w) * ufl.dx),
                      ("∫|∇u|²", lambda w: ufl.inner(ufl.grad(w), ufl.grad(w)) * ufl.dx)):
    before, after = nc.integrate(norm_of(u), comm), nc.integrate(norm_of(u_carried), comm)
    check(abs(after - before) <= 1e-12 * before, f"transfer is exact: {name} = {before:.10g} on both meshes")

# %% [markdown]
# **SOLVE again**, starting Newton from the carried solution (nested iteration) instead of from zero.

# %%
warm = nc.solve(problem, child, initial=u)
cold = nc.solve(problem, child)
say(f"on the refined mesh: {warm.stats.newton_iterations} Newton iterations from the carried solution, "
    f"{cold.stats.newton_iterations} from zero")
est_child = nc.estimate(warm.u, warm.fields)
say(f"η: {est.totals['eta']:.4f} -> {est_child.totals['eta']:.4f}")

# %% [markdown]
# ## The whole loop
#
# `adapt` repeats SOLVE → ESTIMATE → MARK → REFINE with the problem's `[adapt]` settings (or an
# `nc.AdaptSettings`), calls `on_level` with each `Level` (its solution, estimate, history row and marked
# cells; a place to write files or draw) and returns the history rows and the final level.
# (`nc.show_progress()` would print the package's own progress line per level.) For comparison we also
# refine uniformly: the same problem with `AdaptSettings(refine="uniform")`.

# %%
def report(level):
    row = level.row
    say(f"  level {level.number}: {row['dofs']:6d} dofs, η = {row['eta']:.4f}, "
        f"{row.get('marked', '–'):>4} cells marked, contact resultant {row['contact_resultant']:.4f}")


result = nc.adapt(problem, on_level=report)
uniform = nc.adapt(problem, nc.AdaptSettings(refine="uniform", levels=3 if SMALL else 4))
adaptive_rows, uniform_rows = result.history, uniform.history
say(f"adaptive: stopped after {len(adaptive_rows)} levels ({result.stop_reason})")

# %% [markdown]
# **Check.** Level 1 of the loop is the step we did by hand (same marking, same mesh), so its η is the
# one we computed above, up to the solver tolerance.

# %%
eta_loop = adaptive_rows[1]["eta"]
check(abs(eta_loop - est_child.totals["eta"]) <= 1e-6 * eta_loop,
      f"level 1 of adapt is the step by hand: η = {eta_loop:.6f} both ways")

# %% [markdown]
# ## Convergence
#
# For P1 elements the best possible rate in 2D is η ∝ N^{-1/2} (N the number of dofs), reached on smooth
# solutions (Corollary 8). Here σ is singular where the clamp meets the free edges, which slows uniform
# refinement down; adaptive refinement puts the cells there and recovers the rate. We fit the slope of
# log η against log N over the last three adaptive levels.

# %%
dofs = np.array([row["dofs"] for row in adaptive_rows], dtype=float)
eta = np.array([row["eta"] for row in adaptive_rows])
slope = np.polyfit(np.log(dofs[-3:]), np.log(eta[-3:]), 1)[0]
uniform_dofs = np.array([row["dofs"] for row in uniform_rows], dtype=float)
uniform_eta = np.array([row["eta"] for row in uniform_rows])
uniform_slope = np.polyfit(np.log(uniform_dofs[-2:]), np.log(uniform_eta[-2:]), 1)[0]
say(f"η ∝ N^{slope:.3f} (adaptive, last three levels), N^{uniform_slope:.3f} (uniform, last two)")
check(slope <= -0.4, f"adaptive refinement converges at the optimal rate: slope {slope:.3f} <= -0.4 "
                     "(optimal: -1/2)")

if comm.rank == 0:
    fig, ax = plt.subplots(figsize=(6, 4.5), constrained_layout=True)
    ax.loglog(dofs, eta, "o-", label="η, adaptive")
    for i in range(1, 5):
        ax.loglog(dofs, [row[f"eta_{i}"] for row in adaptive_rows], ".:", label=f"η_{i}, adaptive")
    ax.loglog(uniform_dofs, uniform_eta, "s--", label="η, uniform")
    ax.loglog(dofs, eta[0] * (dofs / dofs[0]) ** -0.5, "k-", lw=0.8, label="∝ N^(−1/2)")
    ax.set_xlabel("degrees of freedom N")
    ax.set_ylabel("estimator")
    ax.legend(fontsize=8)
    fig.savefig(out_dir / "convergence.png", dpi=120)
    plt.show(block=False)  # in a notebook: the figure, here; a script wrote the file
    say(f"wrote {out_dir / 'convergence.png'}")

# %% [markdown]
# And the indicators on the finest mesh: the refinement has gathered at the two left corners and along
# the contact edge, where η_4 lives.

# %%
draw_indicators(result.final.estimate, out_dir / "indicators_final.png")
say(f"pictures in {out_dir}")
