"""The convergence plot: η (and the H¹ error when known) against dofs."""
import numpy as np

TITLE = 80  # characters of the title shown


def convergence_plot(path, histories, title):
    """η (and the H¹ error when known) against dofs, log–log, with a slope −1/2 guide."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    styles = {"adaptive": "o-", "uniform": "s--", "none": "d-"}
    dofs_all = []
    for label, rows in histories.items():
        dofs = np.array([r["dofs"] for r in rows], dtype=float)
        dofs_all.extend(dofs)
        style = styles.get(label, "o-")
        ax.loglog(dofs, [r["eta"] for r in rows], style, label=f"η ({label})")
        if rows and rows[0].get("h1_error") is not None:
            ax.loglog(dofs, [r["h1_error"] for r in rows], style, mfc="none",
                      label=f"‖u − u_h‖₁ ({label})")
    if dofs_all:
        d = np.array(sorted(set(dofs_all)))
        first = next(iter(histories.values()))[0]
        ax.loglog(d, first["eta"] * (d / d[0]) ** -0.5, "k:", label="slope −1/2")
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel("estimator / error")
    ax.set_title(title if len(title) <= TITLE else title[:TITLE - 1] + "…")  # (a long one overflows the raster)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
