#!/usr/bin/env python3
"""Study 17 (issue 46): a coarse curved body refined with and without its true shape.

The 2D half-disc of meshes/halfdisc.py (R = 1, from h = R/10) pressed by its clamped top onto a stiff flat,
and the 3D quarter ball of meshes/quarterball.py (from h = R/8) pressed by its weight (the ``hertz3d``
setting), each under uniform and Dörfler refinement, once with ``[mesh.shapes]`` giving the circle (sphere)
of its contact and free groups and once without. Measured per level: the contact resultant against a
fine-mesh answer of the same body computed here (a finer gmsh mesh *with* the shape, refined adaptively far;
its last successive differences and an Aitken extrapolation say how converged it is), the contact size and
the peak pressure against Hertz (nc_dolfinx.physics.reference, for the computed resultant), η and the
geometric term eta_geometry.

Run by verify.py like the other studies (the worker half of this module)::

    mpirun -n N /usr/bin/python3 verification/curved.py curved --mode quick|full --out RESULT.json

and evaluated by :func:`curved` (the checks half, :data:`BUILDERS`). The problem files are written into a
temporary directory by :func:`write_problem` (tests/test_curved.py uses it too).
"""
import math
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import PYTHON, ROOT  # noqa: E402

MESHES = ROOT / "meshes"
R = 1.0
TITLES = {"curved": "17. Curved bodies: a coarse half-disc and quarter ball refined onto their shape (issue 46)"}
ORDER = list(TITLES)

# --- the problems ------------------------------------------------------------------------------------

HALFDISC = """title = "half-disc (issue 46)"
[parameters]
E = 1.0e3
delta = 0.009773
[mesh]
file = "{mesh}"
dirichlet = ["top"]
neumann = ["free"]
contact = ["contact"]
[material]
E = "E"
nu = 0.45
[loads]
u_D = ["0", "-delta"]
[contact]
c_n = "1.0e3*E"
m_n = 1
gap = "y"
[adapt]
refine = "adaptive"
levels = 4
[reference]
hertz = "line"
radius = 1.0
"""

QUARTERBALL = """title = "quarter ball under its weight (issue 46)"
[parameters]
E = 1.0e3
R = 1.0
rho_g = 30.0
[mesh]
file = "{mesh}"
dirichlet = ["top"]
symmetry = ["symm_x", "symm_y"]
neumann = ["free"]
contact = ["contact"]
[material]
E = "E"
nu = 0.3
[loads]
f = ["0", "0", "-rho_g"]
[contact]
c_n = "1.0e3*E"
m_n = 1
gap = "z"
[adapt]
refine = "adaptive"
levels = 3
theta = 0.5
[reference]
hertz = "sphere"
radius = "R"
model_fraction = 0.25
"""

SHAPES = {2: "circle", 3: "sphere"}
CENTRE = {2: "[0, 1]", 3: "[0, 0, 1]"}


def shape_table(dim, groups=("contact", "free"), text=None, radius=1):
    """The problem file's [mesh.shapes] for ``groups``: the circle (sphere) of the body (radius 1), or
    ``text`` in each (e.g. ``implicit = "..."``)."""
    body = text or f"centre = {CENTRE[dim]}\nradius = {radius}"
    kind = "" if text else f".{SHAPES[dim]}"
    return "".join(f"[mesh.shapes.{g}{kind}]\n{body}\n" for g in groups)


def make_mesh(dim, h, out):
    """Run the generator (meshes/halfdisc.py in 2D, quarterball.py in 3D) into ``out``; returns ``out``."""
    script = MESHES / ("halfdisc.py" if dim == 2 else "quarterball.py")
    subprocess.run([PYTHON, str(script), repr(h), str(out)], check=True, capture_output=True, timeout=300)
    return Path(out)


def write_problem(folder, dim, mesh, shape=True, shapes_text=None, name=None):
    """Write the half-disc (2D) or quarter-ball (3D) problem on ``mesh`` into ``folder``: with the true
    shape of the contact and free groups if ``shape`` (``shapes_text``: a [mesh.shapes] of one's own
    instead); returns the path."""
    text = (HALFDISC if dim == 2 else QUARTERBALL).format(mesh=Path(mesh).resolve())
    if shapes_text is not None:
        text += shapes_text
    elif shape:
        text += shape_table(dim)
    path = Path(folder) / (name or f"{'halfdisc' if dim == 2 else 'quarterball'}{'_shape' if shape else ''}.toml")
    path.write_text(text)
    return path


# --- the worker ----------------------------------------------------------------------------------------

ROW_KEYS = ("level", "dofs", "eta", "eta_geometry", "geometry_sag", "contact_resultant", "max_contact_pressure",
            "contact_length", "contact_area", "time_solve", "time_refine")

CONFIG = {
    "quick": {"curved": {
        "2": {"h": 0.1, "uniform": 4, "adaptive": 7, "reference": {"h": 0.05, "levels": 9, "max_dofs": 6e4}},
        "3": {"h": 0.125, "uniform": 2, "adaptive": 4, "reference": None}}},
    "full": {"curved": {
        "2": {"h": 0.1, "uniform": 6, "adaptive": 10, "reference": {"h": 0.025, "levels": 12, "max_dofs": 3e5}},
        "3": {"h": 0.125, "uniform": 3, "adaptive": 5,
              "reference": {"h": 0.0625, "levels": 5, "max_dofs": 1.5e6}}}},
}


def _runs(dim, cfg, folder, comm):
    import nc_dolfinx as nc

    def history(path, **settings):
        problem = nc.load_problem(str(path))
        rows = nc.adapt(problem, nc.AdaptSettings.from_problem(problem, **settings), comm=comm).history
        return [_row(r, problem) for r in rows]

    mesh = Path(folder) / f"coarse{dim}.msh"
    if comm.rank == 0:
        make_mesh(dim, cfg["h"], mesh)
    comm.barrier()
    out = {"h": cfg["h"]}
    for shape in (True, False):
        path = write_problem(folder, dim, mesh, shape) if comm.rank == 0 else None
        path = comm.bcast(path, root=0)
        key = "shape" if shape else "faceted"
        out[f"{key}_uniform"] = history(path, refine="uniform", levels=cfg["uniform"])
        out[f"{key}_adaptive"] = history(path, refine="adaptive", levels=cfg["adaptive"])
    ref = cfg["reference"]
    if ref:
        fine = Path(folder) / f"fine{dim}.msh"
        if comm.rank == 0:
            make_mesh(dim, ref["h"], fine)
            path = write_problem(folder, dim, fine, True, name=f"fine{dim}.toml")
        path = comm.bcast(path if comm.rank == 0 else None, root=0)
        out["reference"] = history(path, refine="adaptive", levels=ref["levels"], max_dofs=int(ref["max_dofs"]))
    return out


def _row(row, problem):
    import nc_dolfinx as nc
    out = {k: float(row[k]) if isinstance(row.get(k), float) else row.get(k) for k in ROW_KEYS if k in row}
    hertz = {name.split()[-1]: (computed, reference) for name, computed, reference in
             nc.compare_with_reference(problem, row)}
    out["size"], out["size_hertz"] = hertz.get("half-width", hertz.get("radius", (None, None)))
    out["peak"], out["peak_hertz"] = hertz["pressure"]
    return out


def study_curved(cfg):
    from mpi4py import MPI
    comm = MPI.COMM_WORLD
    folder = comm.bcast(tempfile.mkdtemp(prefix="nc_curved-") if comm.rank == 0 else None, root=0)
    return {dim: _runs(int(dim), cfg[dim], folder, comm) for dim in ("2", "3")}


STUDIES = {"curved": study_curved}

# --- the checks -----------------------------------------------------------------------------------------

FORCE_TARGET = {"2": 0.005, "3": 0.01}    # |F/F_ref − 1| with the shape, adaptive (issue 46)
SIZE_TARGET = 0.03                         # contact half-width / radius against Hertz
PEAK_TARGET = 0.05                         # peak pressure against Hertz
REFERENCE_SETTLED = 0.2                    # the reference's own uncertainty, as a share of the force target
ETA_FALL = 2.0       # without the shape η falls at least this much over the run, while the force error ends
STALL = 0.5          # above this × its mid-run value and above STALL_TARGETS × the force target
STALL_TARGETS = 2.0
GEOMETRY_FALL = 0.8  # with the shape eta_geometry falls by this factor per level at least (geometric mean);
GEOMETRY_KEPT = 0.8  # without, it ends above this × its level-0 value


def reference_value(rows):
    """(the reference force, its estimated error, the last successive difference) from the reference's
    levels: Aitken's Δ² extrapolation of the last three resultants (the limit of a geometric sequence),
    its distance from the last resultant as the error estimate; the plain last value where the differences
    do not shrink geometrically."""
    f = [r["contact_resultant"] for r in rows[-3:]]
    d1, d2 = f[1] - f[0], f[2] - f[1]
    last = abs(d2)
    if len(f) == 3 and d1 != 0 and 0 < d2 / d1 < 1:
        limit = f[2] - d2 * d2 / (d2 - d1)
        return limit, abs(f[2] - limit), last
    return f[-1], last, last


def _table(rows, force_ref):
    out = []
    for r in rows:
        force = f"{100 * (r['contact_resultant'] / force_ref - 1):+.3f} %" if force_ref else "–"
        out.append([r["level"], r["dofs"], f"{r['contact_resultant']:.5f}", force,
                    f"{100 * (r['size'] / r['size_hertz'] - 1):+.2f} %", f"{100 * (r['peak'] / r['peak_hertz'] - 1):+.2f} %",
                    f"{r['eta']:.4g}", f"{r['eta_geometry']:.3g}", f"{r['geometry_sag']:.2e}"])
    return out


HEADERS = ["level", "dofs", "F", "F/F_ref − 1", "size/Hertz − 1", "peak/Hertz − 1", "η", "η_geo", "sag"]


def curved(data):
    from checks import Section
    s = Section("curved", TITLES["curved"])
    for dim in ("2", "3"):
        d = data[dim]
        name = {"2": "2D half-disc", "3": "3D quarter ball"}[dim]
        size = "half-width" if dim == "2" else "radius"
        if "reference" in d:
            force_ref, uncertainty, last = reference_value(d["reference"])
            s.tables.append((f"{name}: the fine-mesh reference (h = R/{1 / data['config'][dim]['reference']['h']:g}"
                             f", with the shape, Dörfler); F_ref = {force_ref:.6f} (Aitken), last step {last:.2e}",
                             HEADERS, _table(d["reference"], force_ref)))
            s.check(f"{name}: the reference has settled", f"|F_last − F_ref|/F_ref = {uncertainty / force_ref:.1e}",
                    f"< {REFERENCE_SETTLED:g} × {100 * FORCE_TARGET[dim]:g} %",
                    uncertainty / force_ref < REFERENCE_SETTLED * FORCE_TARGET[dim])
        else:
            force_ref = None
        for key, label in (("shape_adaptive", "with the shape, adaptive"), ("shape_uniform", "with the shape, uniform"),
                           ("faceted_adaptive", "without the shape, adaptive"),
                           ("faceted_uniform", "without the shape, uniform")):
            s.tables.append((f"{name} from h = R/{1 / d['h']:g}, {label}", HEADERS, _table(d[key], force_ref)))
        final = d["shape_adaptive"][-1]
        if force_ref:  # (full mode in 3D: the quick runs end far from the targets, which need ~1e5 dofs)
            error = final["contact_resultant"] / force_ref - 1
            s.check(f"{name}, shape, adaptive: force against the reference",
                    f"{100 * error:+.3f} % at {final['dofs']} dofs", f"within ±{100 * FORCE_TARGET[dim]:g} %",
                    abs(error) <= FORCE_TARGET[dim])
            error = final["size"] / final["size_hertz"] - 1
            s.check(f"{name}, shape, adaptive: contact {size} against Hertz", f"{100 * error:+.2f} %",
                    f"within ±{100 * SIZE_TARGET:g} %", abs(error) <= SIZE_TARGET)
            error = final["peak"] / final["peak_hertz"] - 1
            s.check(f"{name}, shape, adaptive: peak pressure against Hertz", f"{100 * error:+.2f} %",
                    f"within ±{100 * PEAK_TARGET:g} %", abs(error) <= PEAK_TARGET)
        geo = [r["eta_geometry"] for r in d["shape_adaptive"]]
        per_level = (geo[-1] / geo[0]) ** (1 / (len(geo) - 1))
        s.check(f"{name}, shape: eta_geometry falls", f"÷{geo[0] / geo[-1]:.1f} over {len(geo) - 1} levels, "
                f"×{per_level:.2f} per level", f"×{GEOMETRY_FALL:g} per level or less", per_level <= GEOMETRY_FALL)
        faceted = d["faceted_adaptive"]
        geo = [r["eta_geometry"] for r in faceted]
        s.check(f"{name}, no shape: eta_geometry does not fall", f"last/first = {geo[-1] / geo[0]:.3f}",
                f"> {GEOMETRY_KEPT:g}", geo[-1] / geo[0] > GEOMETRY_KEPT)
        # without the shape the force converges to the faceted body's: η falls, the error against the
        # shaped body's answer (the reference; without one, the run with the shape's last level) does not
        target = force_ref or final["contact_resultant"]
        errors = [abs(r["contact_resultant"] / target - 1) for r in faceted]
        eta_fall = faceted[0]["eta"] / faceted[-1]["eta"]
        mid = len(faceted) // 2
        s.check(f"{name}, no shape: η falls while the force error stalls",
                f"η ÷{eta_fall:.1f}; force error {100 * errors[mid]:.2f} % (level {mid}) → {100 * errors[-1]:.2f} %",
                f"η ÷ ≥ {ETA_FALL:g}, error > {STALL:g} × its level-{mid} value and > "
                f"{STALL_TARGETS * 100 * FORCE_TARGET[dim]:g} %",
                eta_fall >= ETA_FALL and errors[-1] > STALL * errors[mid] and errors[-1] > STALL_TARGETS * FORCE_TARGET[dim])
        if force_ref:
            ours = abs(final["contact_resultant"] / force_ref - 1)
            s.check(f"{name}: the shape beats the facets at the end (adaptive)",
                    f"force error {100 * ours:.3f} % against {100 * errors[-1]:.2f} %", "smaller", ours < errors[-1])
    return s


BUILDERS = {"curved": curved}
PROSE = """A coarse half-disc (R = 1, h = R/10, meshes/halfdisc.py; its top pushed down by 0.009773 onto a stiff flat,
E = 1e3, ν = 0.45, c_n = 1e3 E) and a coarse quarter ball (h = R/8, meshes/quarterball.py; pressed by its weight as in
`hertz3d`), refined uniformly and by Dörfler's marking, with `[mesh.shapes]` giving the circle (sphere) of the contact
and free groups and without. F is the contact resultant, against a reference of the same body computed here: a finer
gmsh mesh with the shape, refined adaptively far, extrapolated by Aitken's Δ² over its last three levels (its last
difference from that limit is the uncertainty checked); the contact size and the peak pressure against Hertz for the
computed resultant; η the estimator, η_geo the geometric term, sag the largest distance of a Γ_C ∪ Γ_N facet from its
group's surface. Without the shape η falls while the force and the peak pressure converge to the faceted body's answer
and η_geo keeps the level-0 sag (`docs/src/curved.md`).
"""


if __name__ == "__main__":
    from worker import main
    sys.exit(main(STUDIES, CONFIG, with_output_path=()))
