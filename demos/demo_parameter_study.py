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
# # A parameter study: the foundation's stiffness c_n and exponent m_n
#
# The normal compliance law (4) of Fernández & Hild,
#
# $$ \sigma_n(u) = -c_n (u_n)_+^{m_n}, \qquad \sigma_t(u) = 0, \qquad (4)$$
#
# models a deformable foundation: it lets the body penetrate by $(u_n)_+$ and pushes back with the
# pressure $p = c_n (u_n)_+^{m_n}$. Here we solve the discrete problem (7) for a range of stiffnesses
# c_n and the exponents m_n ∈ {1, 2, 3}, and plot the contact force and the largest penetration.
#
# What to expect. As c_n → ∞ the foundation becomes rigid (for m_n = 1 the law is the penalty method,
# Remark 1): the penetration δ tends to 0 and the pressure tends to the pressure of the rigid
# (Signorini) contact, which does not depend on m_n. Where the pressure has (nearly) reached that limit
# p*, the law gives $c_n \delta^{m_n} \approx p^*$, i.e.
#
# $$ \delta \approx (p^*/c_n)^{1/m_n}, \qquad \frac{d\log\delta}{d\log c_n} \to -\frac{1}{m_n}:$$
#
# the penetration falls like 1/c_n for m_n = 1, but only like $c_n^{-1/3}$ for m_n = 3. The demo
# measures these slopes. It also shows the practical point of the API: all values of a problem enter
# the forms as `fem.Constant`s, so a sweep over 3 × n values compiles the forms once — we record every
# form the sweep hands to the JIT compiler and check that no new one appears after the first solve.
#
# Run as a script (`python3 demos/demo_parameter_study.py [--small] [--out DIR]`, also under mpirun)
# or as a notebook (jupytext). `--small` / `NC_DEMO_SMALL=1`: a coarse mesh and fewer values of c_n.

# %%
import time

import dolfinx.jit
import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

import nc_dolfinx as nc

from support import SMALL, check, output_directory, say  # the demos' plumbing: options, printing, checks

comm = MPI.COMM_WORLD
out_dir = output_directory()


# %% [markdown]
# ## Watching the JIT compiler
#
# DOLFINx compiles every form (and every interpolated expression) through `dolfinx.jit.ffcx_jit`. The
# compiled module's name is `libffcx_forms_<hash>`, the hash of the form's *symbolic* content: a
# `fem.Constant` enters as a symbol, whatever its value, while a number written into a form would
# change the hash and force a new compilation. We wrap the function to record the module names.

# %%
jit_modules = []
_ffcx_jit = dolfinx.jit.ffcx_jit


def recording_ffcx_jit(*args, **kwargs):
    compiled, module, code = _ffcx_jit(*args, **kwargs)
    jit_modules.append(module.__name__)
    return compiled, module, code


dolfinx.jit.ffcx_jit = recording_ffcx_jit

# %% [markdown]
# ## The problem and the sweep
#
# We take the built-in `block` case — the paper's setting: a plane strain block [0, 2] × [0, 1], clamped
# on the left, loaded by its weight and a traction on top, on the foundation along its base — with a
# constant c_n, and keep one mesh for the whole study. `problem.replace` returns a new, validated problem
# with some values changed; `nc.solve` binds it to the mesh and solves (7).

# %%
cells = [8, 4] if SMALL else [32, 16]
stiffnesses = [1e2, 1e4, 1e6, 1e7, 1e8] if SMALL else [10.0 ** k for k in range(2, 10)]
exponents = [1, 2, 3]
base = nc.load_problem("block", [f"mesh.cells={cells}"])
domain = nc.build_domain(base, comm)
say(f"{base.title}\n{domain.num_cells()} cells; c_n ∈ {stiffnesses}; m_n ∈ {exponents}")

rows = []
for m_n in exponents:
    for c_n in stiffnesses:
        before, start = len(jit_modules), time.perf_counter()
        solution = nc.solve(base.replace({"contact.c_n": c_n, "contact.m_n": m_n}), domain)
        q = nc.solution_quantities(solution.u, solution.fields)
        rows.append({"m_n": m_n, "c_n": c_n, "force": q["contact_resultant"], "penetration": q["max_penetration"],
                     "pressure": q["max_contact_pressure"], "newton": solution.stats.newton_iterations,
                     "seconds": time.perf_counter() - start, "modules": set(jit_modules[before:])})
        say(f"m_n = {m_n}, c_n = {c_n:7.0e}: contact force {q['contact_resultant']:8.4f}, largest penetration "
            f"{q['max_penetration']:.4e}, {solution.stats.newton_iterations} Newton iterations, "
            f"{rows[-1]['seconds']:.2f} s")

# %% [markdown]
# ## The forms compiled once
#
# The first solve (and its quantities) needed a set of compiled modules: compiled now, or loaded from
# FFCx's disk cache if an earlier run compiled them. Every later solve, with new values of c_n and m_n,
# must need no module outside that set.

# %%
first = rows[0]["modules"]
new_later = set().union(*(row["modules"] for row in rows[1:])) - first
later_seconds = np.mean([row["seconds"] for row in rows[1:]])
say(f"the first solve used {len(first)} compiled modules and took {rows[0]['seconds']:.2f} s; the "
    f"{len(rows) - 1} later solves took {later_seconds:.2f} s each on average")
check(len(first) > 0 and not new_later,
      f"{len(rows)} solves with {len(rows)} different (c_n, m_n) compile the forms once: "
      f"{len(new_later)} new modules after the first solve")

# %% [markdown]
# ## Physics
#
# A stiffer foundation carries more of the load (the clamp less) and is penetrated less: for each
# m_n the contact force must grow and the penetration fall as c_n grows.

# %%
for m_n in exponents:
    series = [row for row in rows if row["m_n"] == m_n]
    force = np.array([row["force"] for row in series])
    penetration = np.array([row["penetration"] for row in series])
    check(np.all(np.diff(force) > 0) and np.all(np.diff(penetration) < 0),
          f"m_n = {m_n}: the contact force grows ({force[0]:.3f} -> {force[-1]:.3f}) and the penetration "
          f"falls ({penetration[0]:.3e} -> {penetration[-1]:.3e}) with c_n")

# %% [markdown]
# At the stiff end the penetration follows δ ∝ c_n^{-1/m_n}: we measure the slope of log δ against
# log c_n between the two stiffest foundations. For m_n = 1 this is the penalty method's familiar
# "penetration ∝ 1/c_n"; the larger m_n, the slower the penetration vanishes.

# %%
slopes = {}
for m_n in exponents:
    stiff = [row for row in rows if row["m_n"] == m_n][-2:]
    slopes[m_n] = np.log(stiff[1]["penetration"] / stiff[0]["penetration"]) / np.log(stiff[1]["c_n"] / stiff[0]["c_n"])
    check(abs(slopes[m_n] * m_n + 1) < 0.05,
          f"m_n = {m_n}: d log δ / d log c_n = {slopes[m_n]:.4f} at the stiff end, within 5 % of -1/m_n "
          f"= {-1 / m_n:.4f}")

# %% [markdown]
# And the pressure's limit does not depend on the exponent: the largest pressure at the stiffest
# foundation, $c_n\delta^{m_n}$, is nearly the same for the three laws.

# %%
peaks = [row["pressure"] for row in rows if row["c_n"] == stiffnesses[-1]]
say("largest contact pressure at c_n = {:.0e}: {}".format(stiffnesses[-1], ", ".join(
    f"{p:.3f} (m_n = {m})" for p, m in zip(peaks, exponents))))

# %% [markdown]
# ## The plot

# %%
if comm.rank == 0:
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    for m_n in exponents:
        series = [row for row in rows if row["m_n"] == m_n]
        c = np.array([row["c_n"] for row in series])
        left.semilogx(c, [row["force"] for row in series], "o-", label=f"m_n = {m_n}")
        delta = np.array([row["penetration"] for row in series])
        line, = right.loglog(c, delta, "o-", label=f"m_n = {m_n}")
        right.loglog(c[-3:], 0.4 * delta[-1] * (c[-3:] / c[-1]) ** (-1 / m_n), ":", color=line.get_color(),
                     label=f"∝ c_n^(−1/{m_n})")
    left.set_xlabel("c_n")
    left.set_ylabel("contact force ∫_Γ_C p")
    right.set_xlabel("c_n")
    right.set_ylabel("largest penetration δ")
    left.legend()
    right.legend(fontsize=8)
    fig.savefig(out_dir / "parameter_study.png", dpi=120)
    plt.show(block=False)  # in a notebook: the figure, here; a script wrote the file
    say(f"wrote {out_dir / 'parameter_study.png'}")

# %% [markdown]
# The wrapper is no longer needed:

# %%
dolfinx.jit.ffcx_jit = _ffcx_jit
