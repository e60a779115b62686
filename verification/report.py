"""verification/report.md and its PNGs, from the checked results (written atomically: temp file, then rename)."""
import datetime
import os
import platform
import subprocess
import tempfile
from pathlib import Path

import numpy as np

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from common import ROOT  # noqa: E402


def _save(fig, path):
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=".png", dir=path.parent)
    os.close(fd)
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    os.replace(tmp, path)
    return path.name


def _cell(value):
    return str(value).replace("|", "\\|").replace("\n", " ")


def md_table(headers, rows):
    out = ["| " + " | ".join(_cell(h) for h in headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    out += ["| " + " | ".join(_cell(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def write_summary_json(report, out, mode, nprocs, total_time):
    """summary.json: every check, machine-readable (read by the estimator-sensitivity study)."""
    import json
    data = {"mode": mode, "ranks": nprocs, "ok": report.ok, "time": total_time,
            "sections": [{"key": s.key, "title": s.title, "ok": s.ok, "error": s.error,
                          "checks": [vars(c) for c in s.checks]} for s in report.sections]}
    fd, tmp = tempfile.mkstemp(prefix=".summary-", suffix=".json", dir=out)
    with os.fdopen(fd, "w") as fh:
        json.dump(data, fh, indent=1)
    os.replace(tmp, Path(out) / "summary.json")


# --- plots --------------------------------------------------------------------------------------------------

def plot_manufactured(data, out):
    runs = data["runs"]
    ms = sorted({r["m"] for r in runs})
    cs = sorted({r["c"] for r in runs})
    colors = plt.cm.viridis(np.linspace(0, 0.9, len(cs)))
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    for run in runs:
        h = [r["h"] for r in run["rows"]]
        color = colors[cs.index(run["c"])]
        style = ["-", "--", "-.", ":"][ms.index(run["m"]) % 4]
        axes[0].loglog(h, [r["h1_error"] for r in run["rows"]], style, color=color, marker="o", ms=3)
        axes[0].loglog(h, [r["eta"] for r in run["rows"]], style, color=color, marker="s", ms=3, alpha=0.5)
        axes[1].loglog(h, [r["l2_error"] for r in run["rows"]], style, color=color, marker="o", ms=3)
        axes[2].semilogx(h, [r["effectivity"] for r in run["rows"]], style, color=color, marker="o", ms=3)
    h = np.array([r["h"] for r in runs[0]["rows"]])
    axes[0].loglog(h, 0.5 * h / h[-1] * runs[0]["rows"][-1]["h1_error"], "k:", lw=1)
    axes[0].text(h[1], 0.5 * h[1] / h[-1] * runs[0]["rows"][-1]["h1_error"], " slope 1", fontsize=8)
    axes[1].loglog(h, 0.5 * (h / h[-1]) ** 2 * runs[0]["rows"][-1]["l2_error"], "k:", lw=1)
    axes[0].set_title("‖u − u_h‖_1 (circles) and η (squares)")
    axes[1].set_title("‖u − u_h‖_0 (dotted: slope 2)")
    axes[2].set_title("effectivity η / ‖u − u_h‖_1")
    for ax in axes:
        ax.set_xlabel("h (max h_K)")
        ax.grid(True, which="both", alpha=0.3)
        ax.invert_xaxis()
    from matplotlib.lines import Line2D
    handles = [Line2D([], [], color=colors[i], label=f"c_n = {c:g}") for i, c in enumerate(cs)]
    handles += [Line2D([], [], color="k", ls=["-", "--", "-.", ":"][i % 4], label=f"m_n = {m:g}") for i, m in enumerate(ms)]
    axes[2].legend(handles=handles, fontsize=7, ncol=2)
    return _save(fig, out / "manufactured_rates.png")


def plot_indicators(data, out):
    picks = [r for r in data["runs"] if (r["m"], r["c"]) in ((1.5, 10), (1, 1000), (3, 1000))]
    fig, axes = plt.subplots(1, len(picks), figsize=(5.2 * len(picks), 4.4), squeeze=False)
    for ax, run in zip(axes[0], picks):
        h = [r["h"] for r in run["rows"]]
        for key, style in (("eta", "k-o"), ("eta_1", "-^"), ("eta_2", "-v"), ("eta_3", "-<"), ("eta_4", "->"),
                           ("zeta", "--x"), ("h1_error", "k--o"), ("augmented_error", "k:s")):
            values = [r[key] for r in run["rows"]]
            if max(values) > 0:
                ax.loglog(h, values, style, ms=4, label=key.replace("h1_error", "‖e‖_1").replace("augmented_error", "ẽ"))
        ax.set_title(f"m_n = {run['m']:g}, c_n = {run['c']:g}")
        ax.set_xlabel("h")
        ax.invert_xaxis()
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=7)
    return _save(fig, out / "manufactured_indicators.png")


def plot_efficiency(data, out):
    cases = data["efficiency"]
    fig, axes = plt.subplots(1, len(cases), figsize=(4.6 * len(cases), 4), squeeze=False, sharey=True)
    for ax, case in zip(axes[0], cases):
        lv = case["levels"]
        x = [s["cells"] for s in lv]
        ax.fill_between(x, [s["q05"] for s in lv], [s["q95"] for s in lv], alpha=0.3, label="5–95 % quantiles")
        ax.semilogx(x, [s["q50"] for s in lv], "b-o", ms=3, label="median")
        ax.semilogx(x, [s["max"] for s in lv], "r-^", ms=3, label="max")
        ax.semilogx(x, [s["min"] for s in lv], "g-v", ms=3, label="min")
        ax.semilogx(x, [s["contact_max"] for s in lv], "m--", label="max on Γ_C cells")
        ax.set_title(f"m_n = {case['m']:g}, c_n = {case['c']:g}")
        ax.set_xlabel("cells")
        ax.set_yscale("log")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("η_K / ‖u − u_h‖_{1,ω_K}")
    axes[0][0].legend(fontsize=7)
    return _save(fig, out / "local_efficiency.png")


def plot_closed_form(data, out):
    rows = data["rows"]
    h = [1.0 / r["mesh"][0] * data["parameters"]["a"] for r in rows]
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    ax.loglog(h, [abs(r["contact_resultant"] / data["exact"]["force"] - 1) for r in rows], "o-", label="|P_h/P − 1|")
    ax.loglog(h, [r["h1_error"] for r in rows], "s-", label="‖u − u_h‖_1")
    ax.loglog(h, [r["l2_error"] for r in rows], "^-", label="‖u − u_h‖_0")
    ax.axhline(1e-3, color="r", ls=":", label="0.1 %")
    ax.set_xlabel("h (cell width)")
    ax.invert_xaxis()
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("hanging block: force and displacement errors")
    return _save(fig, out / "closed_form.png")


def plot_penalty(data, out):
    rows = sorted(data["rows"], key=lambda r: r["eps"])
    eps = [r["eps"] for r in rows]
    fig, ax = plt.subplots(figsize=(5.5, 4.2))
    ax.loglog(eps, [r["h1_diff"] for r in rows], "o-", label="‖u_ε − u_S‖_1")
    ax.loglog(eps, [r["l2_diff"] for r in rows], "s-", label="‖u_ε − u_S‖_0")
    ax.loglog(eps, [r["max_penetration"] for r in rows], "^-", label="max (u_εn)_+")
    e = np.array(eps)
    ax.loglog(e, rows[0]["h1_diff"] * e / e[0], "k:", label="slope 1")
    ax.set_xlabel("ε = 1/c_n")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("penalty (m_n = 1, c_n = 1/ε) → Signorini")
    return _save(fig, out / "penalty.png")


def plot_hertz(data, out):
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.3))
    prof = data.get("profile") or {}
    last = data["rows"][-1]
    if prof:
        x, p = np.array(prof["x"]), np.array(prof["p"])
        a, p0 = last["hertz_half_width"], last["hertz_peak_pressure"]
        sel = np.abs(x) < 2 * a
        axes[0].plot(x[sel], p[sel], "o-", ms=2, label=f"computed (level {prof['level']}, lumped nodal p)")
        xs = np.linspace(-a, a, 400)
        axes[0].plot(xs, p0 * np.sqrt(np.maximum(1 - (xs / a) ** 2, 0)), "k--", label="Hertz, same total force")
        axes[0].set_xlabel("x")
        axes[0].set_ylabel("contact pressure")
        axes[0].legend(fontsize=8)
        axes[0].grid(alpha=0.3)
    dofs = [r["dofs"] for r in data["rows"]]
    axes[1].semilogx(dofs, [100 * (r["half_width"] / r["hertz_half_width"] - 1) for r in data["rows"]], "o-",
                     label="half-width a")
    axes[1].semilogx(dofs, [100 * (r["max_contact_pressure"] / r["hertz_peak_pressure"] - 1) for r in data["rows"]],
                     "s-", label="peak pressure p_0")
    axes[1].axhline(3, color="r", ls=":")
    axes[1].axhline(-3, color="r", ls=":")
    axes[1].set_xlabel("dofs")
    axes[1].set_ylabel("deviation from Hertz [%]")
    axes[1].legend(fontsize=8)
    axes[1].grid(alpha=0.3, which="both")
    return _save(fig, out / "hertz.png")


def plot_corner(data, out):
    ha, hu = data["histories"]["adaptive"], data["histories"]["uniform"]
    fig, ax = plt.subplots(figsize=(6.5, 4.8))
    scale = ha[0]["eta"] / ha[0]["h1_error"]
    for rows, name, color in ((ha, "adaptive", "C0"), (hu, "uniform", "C1")):
        d = [r["dofs"] for r in rows]
        ax.loglog(d, [r["eta"] / scale for r in rows], "--s", color=color, ms=4, label=f"{name}: η / {scale:.0f}")
        ax.loglog(d, [r["h1_error"] for r in rows], "-o", color=color, ms=4, label=f"{name}: ‖u_ref − u_h‖_1")
    d = np.array([ha[-5]["dofs"], ha[-1]["dofs"]], float)
    ax.loglog(d, 0.6 * ha[-5]["h1_error"] * (d / d[0]) ** -0.5, "k:", label="dofs^(−1/2)")
    ax.set_xlabel("dofs")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("corner: adaptive vs uniform")
    name1 = _save(fig, out / "corner_convergence.png")
    meshes = np.load(data["meshes"])
    levels = data["picture_levels"]
    fig, axes = plt.subplots(1, len(levels) + 1, figsize=(4.2 * (len(levels) + 1), 4.3))
    for ax, lev in zip(axes, levels):
        X, T = meshes[f"adaptive_{lev:02d}_X"], meshes[f"adaptive_{lev:02d}_T"]
        ax.triplot(X[:, 0], X[:, 1], T, lw=0.25, color="k")
        ax.set_title(f"adaptive level {lev}: {2 * len(X)} dofs")
    X, T = meshes["uniform_X"], meshes["uniform_T"]
    axes[-1].triplot(X[:, 0], X[:, 1], T, lw=0.15, color="k")
    axes[-1].set_title(f"finest uniform: {2 * len(X)} dofs")
    for ax in axes:
        ax.set_aspect("equal")
        ax.axis("off")
    name2 = _save(fig, out / "corner_meshes.png")
    return name1, name2


# --- the markdown --------------------------------------------------------------------------------------------

def _git(*args):
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10).stdout.strip()
    except Exception:
        return ""


def _head_commit():
    """The checked-out commit, short: from git, or where git is not installed (the root file systems CI
    makes for other releases) from the repository's own files."""
    commit = _git("rev-parse", "--short", "HEAD")
    if commit:
        return commit
    try:
        head = (ROOT / ".git" / "HEAD").read_text().strip()
        if not head.startswith("ref: "):
            return head[:7]
        ref = head[5:]
        if (ROOT / ".git" / ref).is_file():
            return (ROOT / ".git" / ref).read_text().strip()[:7]
        for line in (ROOT / ".git" / "packed-refs").read_text().splitlines():
            if line.endswith(" " + ref):
                return line.split()[0][:7]
    except OSError:
        pass
    return ""


def section_md(sec):
    lines = []
    for caption, headers, rows in sec.tables:
        lines += [f"*{caption}*", "", md_table(headers, rows), ""]
    lines += ["**Expectations**", "", md_table(["check", "measured", "expected", "result"],
                                             [[c.name, c.value, c.expectation, "PASS" if c.ok else "**FAIL**"]
                                              for c in sec.checks]), ""]
    if sec.error:
        lines += ["```", sec.error, "```", ""]
    return "\n".join(lines)


def write(report, results, out, mode, nprocs, total_time, timings):
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_summary_json(report, out, mode, nprocs, total_time)
    pictures, plot_errors = {}, []
    plots = {"manufactured": [plot_manufactured, plot_indicators], "efficiency": [plot_efficiency],
             "closed_form": [plot_closed_form], "penalty": [plot_penalty], "hertz": [plot_hertz], "corner": [plot_corner]}
    from report3d import PLOTS
    plots.update(PLOTS)
    for study, funcs in plots.items():
        source = "manufactured" if study == "efficiency" else study
        if source in results:
            for func in funcs:
                try:
                    names = func(results[source], out)
                    pictures.setdefault(study, []).extend([names] if isinstance(names, str) else list(names))
                except Exception as err:
                    plot_errors.append(f"{func.__name__}: {type(err).__name__}: {err}")
    from narrative import compose
    text = compose(report, results, pictures, mode=mode, nprocs=nprocs, total_time=total_time, timings=timings,
                   section_md=section_md, md_table=md_table, plot_errors=plot_errors,
                   commit=_head_commit(), dirty=_git("status", "--porcelain", "nc_dolfinx"),
                   when=datetime.datetime.now().strftime("%Y-%m-%d %H:%M"), machine=platform.platform())
    fd, tmp = tempfile.mkstemp(prefix=".report-", suffix=".md", dir=out)
    with os.fdopen(fd, "w") as fh:
        fh.write(text)
    os.replace(tmp, out / "report.md")
    if plot_errors:
        raise RuntimeError("plots failed: " + "; ".join(plot_errors))
