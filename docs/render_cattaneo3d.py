#!/usr/bin/env python3
"""Render the stick zone of the ``cattaneo3d`` case (Cattaneo–Mindlin partial slip) into docs/cattaneo3d.png.

Run (no ParaView needed: it solves the case and draws with matplotlib)::

    PYTHONPATH=. /usr/bin/python3 docs/render_cattaneo3d.py docs/cattaneo3d.png

The contact cap Γ_C of the half ball, seen from below (x to the right, the symmetry plane y = 0 at the
top edge, the lower half plane y > 0 of the picture being the model; the mirror image y < 0 drawn faintly
completes the full contact), at the end of the tangential loading: every Γ_C facet is cut into the thirds
the vertex rule gives its vertices, each coloured by the state of the regularised Coulomb law at its vertex,
where the law is evaluated — stick (|s| ≤ ε_r (u·N − g̃_0)_+, blue), slip (orange) or no contact (light
grey) — recomputed from the law's inputs by the rule of the output's stick_slip field
(verification/cattaneo3d_patch.py): the drawn areas are the history's stick_area / slip_area. Overlaid:
Cattaneo–Mindlin's stick circle c = a (1 − Q/(μP))^(1/3) (black, with a the computed contact radius),
the computed contact radius a = sqrt(2A/π) (dashed) and Hertz's a_H (dotted). The arrow shows the direction of the top's motion.
"""
import argparse
import math
import sys
from pathlib import Path

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import PolyCollection  # noqa: E402
from matplotlib.colors import to_rgb  # noqa: E402
from mpi4py import MPI  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "verification"))
import nc_dolfinx as nc  # noqa: E402
from cattaneo3d import measures  # noqa: E402
from cattaneo3d_patch import NO_CONTACT, SLIP, STICK, classify, contact_facets  # noqa: E402

COLOURS = {NO_CONTACT: "#e4e4e4", STICK: "#3b6fb6", SLIP: "#f0a030"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("output", nargs="?", default=str(ROOT / "docs" / "cattaneo3d.png"))
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="problem overrides")
    args = ap.parse_args()
    problem = nc.load_problem("cattaneo3d", args.set)
    result = nc.adapt(problem)
    final_state = list(problem.load_path())[-1].problem
    patch = contact_facets(result.final.solution)
    if MPI.COMM_WORLD.rank != 0:
        return 0
    eps_r = final_state.values["contact"]["slip_regularisation"]
    pieces, state, area, _ = classify(patch, eps_r)
    m = measures(result.history[-1], final_state)
    a, c_mindlin = m["a"], m["a"] * m["c/a_mindlin"]

    keep = np.hypot(*pieces[:, :, :2].mean(axis=1).T) < 1.6 * a
    fig, ax = plt.subplots(figsize=(8.2, 7.0), dpi=130)
    for mirror, fade in ((1.0, 0.0), (-1.0, 0.6)):  # the mirror image: colours faded towards white
        xy = pieces[keep][:, :, :2] * np.array([1.0, mirror])
        colours = [(1 - fade) * np.array(to_rgb(COLOURS[s])) + fade for s in state[keep]]
        ax.add_collection(PolyCollection(xy, facecolors=colours, edgecolors=colours, linewidths=0.3))
    t = np.linspace(0, 2 * math.pi, 400)
    ax.plot(c_mindlin * np.cos(t), c_mindlin * np.sin(t), "k-", lw=2.0,
            label=f"Cattaneo–Mindlin stick circle c = a(1 − Q/μP)^(1/3) = {c_mindlin:.4f}")
    ax.plot(a * np.cos(t), a * np.sin(t), "k--", lw=1.0, label=f"computed contact radius a = {a:.4f}")
    ax.plot(m["a_hertz"] * np.cos(t), m["a_hertz"] * np.sin(t), "k:", lw=1.0,
            label=f"Hertz a = {m['a_hertz']:.4f}")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.annotate("", xy=(1.35 * a, -1.35 * a), xytext=(0.95 * a, -1.35 * a),
                arrowprops=dict(arrowstyle="->", lw=1.5))
    ax.text(1.15 * a, -1.30 * a, "top moves", ha="center", fontsize=9)
    ax.text(-1.55 * a, 0.04 * a, "symmetry plane y = 0; below: the model", fontsize=8, va="top")
    ax.text(-1.55 * a, -0.04 * a, "above: its mirror image", fontsize=8, va="bottom", color="0.4")
    for s, name in ((STICK, "stick"), (SLIP, "slip"), (NO_CONTACT, "no contact")):
        ax.fill([], [], color=COLOURS[s], label=name)
    ax.set_xlim(-1.6 * a, 1.6 * a)
    ax.set_ylim(1.6 * a, -1.6 * a)  # seen from below: y grows downwards, x to the right
    ax.set_aspect("equal")
    ax.set_xlabel("x")
    ax.set_ylabel("y (seen from below)")
    ax.set_title(f"cattaneo3d: stick zone on Γ_C from below, Q/(μP) = {m['Q/muP']:.3f} (μ = "
                 f"{final_state.parameters['mu']:g})\nstick radius a sqrt(A_stick/(A_stick + A_slip)) = {m['c']:.4f}, "
                 f"c/a = {m['c/a']:.3f} vs Mindlin {m['c/a_mindlin']:.3f} ({100 * m['c/a_error']:+.1f} %)",
                 fontsize=10)
    ax.legend(loc="lower left", fontsize=8, framealpha=0.9)
    fig.tight_layout()
    fig.savefig(args.output)
    print(f"wrote {args.output}: c/a = {m['c/a']:.4f}, Mindlin {m['c/a_mindlin']:.4f}, a = {a:.5f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
