"""The plots of the 3D studies (report.py calls :func:`plots` and writes them beside report.md)."""
import numpy as np

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from report import _save, plot_penalty  # noqa: E402


def plot_manufactured3d(data, out):
    runs = data["runs"]
    ms, cs = sorted({r["m"] for r in runs}), sorted({r["c"] for r in runs})
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(cs)))
    styles = ["-", "--", "-.", ":"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for run in runs:
        d = [r["dofs"] for r in run["rows"]]
        color, style = colors[cs.index(run["c"])], styles[ms.index(run["m"]) % 4]
        axes[0].loglog(d, [r["h1_error"] for r in run["rows"]], style, color=color, marker="o", ms=3)
        axes[0].loglog(d, [r["eta"] for r in run["rows"]], style, color=color, marker="s", ms=3, alpha=0.5)
        axes[1].loglog(d, [r["l2_error"] for r in run["rows"]], style, color=color, marker="o", ms=3)
        axes[2].semilogx(d, [r["effectivity"] for r in run["rows"]], style, color=color, marker="o", ms=3)
    last = runs[0]["rows"]
    d = np.array([r["dofs"] for r in last], float)
    axes[0].loglog(d, 0.5 * last[-1]["h1_error"] * (d / d[-1]) ** (-1 / 3), "k:", lw=1)
    axes[1].loglog(d, 0.5 * last[-1]["l2_error"] * (d / d[-1]) ** (-2 / 3), "k:", lw=1)
    axes[0].set_title("‖u − u_h‖_1 (circles), η (squares); dotted: dofs^(−1/3)")
    axes[1].set_title("‖u − u_h‖_0 (dotted: dofs^(−2/3))")
    axes[2].set_title("effectivity η / ‖u − u_h‖_1")
    for ax in axes:
        ax.set_xlabel("dofs")
        ax.grid(True, which="both", alpha=0.3)
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], color=colors[i], label=f"c_n = {c:g}") for i, c in enumerate(cs)]
    handles += [Line2D([], [], color="k", ls=styles[i % 4], label=f"m_n = {m:g}") for i, m in enumerate(ms)]
    axes[2].legend(handles=handles, fontsize=7, ncol=2)
    return _save(fig, out / "manufactured3d_rates.png")


def plot_hertz3d(data, out):
    fig, ax = plt.subplots(figsize=(6, 4.3))
    rows = data["rows"]
    dofs = [r["dofs"] for r in rows]
    ax.semilogx(dofs, [100 * (r["radius"] / r["hertz_radius"] - 1) for r in rows], "o-", label="contact radius a")
    ax.semilogx(dofs, [100 * (r["max_contact_pressure"] / r["hertz_peak_pressure"] - 1) for r in rows], "s-",
                label="peak pressure p_0")
    for bound in (3, -3):
        ax.axhline(bound, color="r", ls=":")
    ax.set_xlabel("dofs")
    ax.set_ylabel("deviation from Hertz [%]")
    ax.set_title("hertz3d (adaptive)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, which="both")
    return _save(fig, out / "hertz3d.png")


def plot_fichera(data, out):
    n = data["compared_adaptive_levels"]
    runs = (("adaptive", data["histories"]["adaptive"][:n], "C0"), ("uniform", data["histories"]["uniform"], "C1"))
    scale = runs[0][1][0]["eta"] / runs[0][1][0]["energy_error"]
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    for name, rows, color in runs:
        d = [r["dofs"] for r in rows]
        ax.loglog(d, [r["eta"] / scale for r in rows], "--s", color=color, ms=4, label=f"{name}: η / {scale:.3g}")
        ax.loglog(d, [r["energy_error"] for r in rows], "-o", color=color, ms=4, label=f"{name}: energy error E_h")
    rows = runs[0][1]
    d = np.array([rows[0]["dofs"], rows[-1]["dofs"]], float)
    ax.loglog(d, 0.6 * rows[0]["energy_error"] * (d / d[0]) ** (-1 / 3), "k:", label="dofs^(−1/3)")
    ax.set_xlabel("dofs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("fichera: adaptive vs uniform")
    return _save(fig, out / "fichera_convergence.png")


def plot_penalty3d(data, out):
    return _save_as(plot_penalty, data, out, "penalty3d.png")


def _save_as(plot, data, out, name):
    """A 2D plot function on the 3D study's data, saved under another name."""
    import tempfile
    from pathlib import Path
    with tempfile.TemporaryDirectory(dir=out) as tmp:
        produced = Path(tmp) / plot(data, Path(tmp))
        produced.replace(Path(out) / name)
    return name


PLOTS = {"manufactured3d": [plot_manufactured3d], "hertz3d": [plot_hertz3d], "fichera": [plot_fichera],
         "penalty3d": [plot_penalty3d]}
