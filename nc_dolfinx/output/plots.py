"""The plots of a run: the convergence plot (η, and the H¹ error when known, against dofs) and, on a load
path, the load-path plot (each support's reaction and the friction force against the load time or a
parameter of the path)."""
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


AXES = "xyz"


def path_states(rows):
    """A load path's states, each by its finest row (the last of the rows with its ``load_time``: a step's
    last increment is followed by the levels refined from it), in the path's order."""
    states = {}
    for row in rows:
        states[(row["step"], row["increment"])] = row
    return list(states.values())


def load_path_curves(rows, x="load_time"):
    """What :func:`load_path_plot` draws: ``(xs, {vector name: {component label: values}})`` over the path's
    states (:func:`path_states`), ``x`` a column (``load_time`` or ``param_NAME``); the vectors are every
    ``reaction_GROUP`` and, with friction, ``friction_force``; a component that is zero all along is left
    out (a roller's free one, a symmetry plane's tangential ones)."""
    states = path_states(rows)
    xs = [row[x] for row in states]
    names = [k for k in states[-1] if k.startswith("reaction_") and isinstance(states[-1][k], (list, tuple))]
    names += ["friction_force"] if "friction_force" in states[-1] else []
    curves = {}
    for name in names:
        values = np.array([row.get(name, [0.0] * len(states[-1][name])) for row in states], dtype=float)
        curves[name] = {f"{name}_{AXES[i]}": values[:, i] for i in range(values.shape[1]) if np.any(values[:, i])}
    return xs, {name: parts for name, parts in curves.items() if parts}


def load_path_plot(path, rows, x, title):
    """load_path.png: each reaction's components and the friction force's against ``x`` (``load_time`` or a
    parameter's column ``param_NAME``), a panel per component (a row of panels per vector: each on its own
    scale, so that a small tangential force is not flattened by a large normal one), one point per state
    of the path (its finest level), joined in the path's order with the first state marked: a load cycle's
    hysteresis shows as a loop."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    xs, curves = load_path_curves(rows, x)
    nrows, ncols = max(len(curves), 1), max([len(parts) for parts in curves.values()] + [1])
    fig, axes = plt.subplots(nrows, ncols, figsize=(3.6 * ncols + 0.8, 1.2 + 2.6 * nrows), sharex=True,
                             squeeze=False)
    for row_axes, (name, parts) in zip(axes, curves.items()):
        for ax, (label, values) in zip(row_axes, parts.items()):
            ax.plot(xs, values, "o-", ms=3)
            ax.plot(xs[:1], values[:1], "ks", ms=7, mfc="none")
            ax.set_title(label, fontsize="small")
            ax.grid(True, alpha=0.3)
        for ax in row_axes[len(parts):]:
            ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel(x if x == "load_time" else f"{x[len('param_'):]} (parameter)")
    fig.suptitle((title if len(title) <= TITLE else title[:TITLE - 1] + "…") + ": the forces on the body along "
                 "the load path (□ its first state)", fontsize="medium")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
