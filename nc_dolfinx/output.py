"""Results on disk, written atomically.

Everything a run writes goes first to a staging directory ``OUT/.partial-XXXX`` and is moved to its final
name only when the run has succeeded (:meth:`ResultWriter.commit`); a failed run removes the staging
directory (:meth:`ResultWriter.abort`), so no half-written file ever appears under a final name.

The output contract (fields are added over time, never renamed):
- ``summary.json``: the run (problem, ranks, final level's dofs/cells/iterations/η/errors, phase times);
- ``history.csv`` / ``history.json``: one row per level;
- ``solution.xdmf`` / ``.h5``: the final mesh with ``displacement`` (P1), ``stress``, ``von_mises`` (DG0),
  ``contact_pressure`` (P1, lumped L² projection on Γ_C, zero elsewhere) and the indicators ``eta``,
  ``eta_1`` … ``eta_4``, ``zeta`` (DG0);
- ``levels/level_NN.xdmf``: mesh, displacement and indicators of every level;
- ``convergence.png``: η (and the error when known) against dofs.
"""
import csv
import json
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from dolfinx import fem, io

from . import forms, physics
from .quantities import contact_projection


class ResultWriter:
    def __init__(self, out_dir, comm):
        self.comm, self.out = comm, Path(out_dir)
        staging = None
        if comm.rank == 0:
            self.out.mkdir(parents=True, exist_ok=True)
            staging = tempfile.mkdtemp(prefix=".partial-", dir=self.out)
        self.staging = Path(comm.bcast(staging, root=0))

    def path(self, name):
        """Staged path for a file every rank writes (collective: the folder exists when it returns)."""
        path = self.staging / name
        if self.comm.rank == 0:
            path.parent.mkdir(parents=True, exist_ok=True)
        self.comm.barrier()
        return path

    def write_json(self, name, data):
        if self.comm.rank == 0:
            with open(self.path_local(name), "w") as fh:
                json.dump(data, fh, indent=2, default=_jsonable)
                fh.write("\n")

    def write_csv(self, name, rows):
        if self.comm.rank == 0 and rows:
            keys = list(dict.fromkeys(k for row in rows for k in row))
            with open(self.path_local(name), "w", newline="") as fh:
                writer = csv.DictWriter(fh, fieldnames=keys)
                writer.writeheader()
                writer.writerows(rows)

    def path_local(self, name):
        """Staged path for a file written by rank 0 alone (not collective)."""
        path = self.staging / name
        path.parent.mkdir(parents=True, exist_ok=True)
        return path

    def write_functions(self, name, mesh, functions):
        """One XDMF file (one mesh) holding the given functions."""
        with io.XDMFFile(self.comm, self.path(name), "w") as xdmf:
            xdmf.write_mesh(mesh)
            for fn in functions:
                xdmf.write_function(fn)

    def commit(self):
        """Move every staged file to its final name (files first into subfolders, then top level)."""
        self.comm.barrier()
        if self.comm.rank == 0:
            for src in sorted(self.staging.rglob("*"), key=lambda p: (-len(p.parts), str(p))):
                if src.is_file():
                    dst = self.out / src.relative_to(self.staging)
                    dst.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(src, dst)
            shutil.rmtree(self.staging, ignore_errors=True)
        self.comm.barrier()

    def abort(self):
        if self.comm.rank == 0:
            shutil.rmtree(self.staging, ignore_errors=True)
            try:
                self.out.rmdir()  # only if the run created it and left nothing in it
            except OSError:
                pass


def _jsonable(value):
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value)}")


def postprocess_fields(u, fields):
    """Stress, von Mises (DG0) and the nodal contact pressure (P1) for output."""
    msh = u.function_space.mesh
    T = fem.TensorFunctionSpace(msh, ("DG", 0), shape=(3, 3))  # plane strain: σ_zz = λ tr ε ≠ 0
    Q = fem.FunctionSpace(msh, ("DG", 0))
    stress = _interpolate(T, physics.stress_3x3(u, fields.lmbda, fields.mu), "stress")
    vm = _interpolate(Q, physics.von_mises(u, fields.lmbda, fields.mu), "von_mises")
    pressure = contact_projection(forms.contact_pressure(u, fields), fields, "contact_pressure")
    return [stress, vm, pressure]


def _interpolate(space, expr, name):
    fn = fem.Function(space, name=name)
    points = space.element.interpolation_points
    fn.interpolate(fem.Expression(expr, points() if callable(points) else points))
    return fn


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
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
