"""Helpers shared by the verification studies (run under MPI by worker.py, or serially by verify.py)."""
import math
import os
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
HERE = Path(__file__).resolve().parent
PYTHON = "/usr/bin/python3"
CASES = ROOT / "nc_dolfinx" / "cases"

if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def fitted_slope(x, y):
    """Least-squares slope of log y against log x."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0)
    if ok.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def loglog_interpolate(x, xs, ys):
    """y at x by linear interpolation of log y against log x between the points (xs, ys), xs monotone
    (increasing or decreasing: dofs against errors either way); None outside their range."""
    lx, ly = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    if lx[0] > lx[-1]:
        lx, ly = lx[::-1], ly[::-1]
    if not np.all(np.diff(lx) > 0):  # (np.interp would answer anyway, wrongly)
        raise ValueError(f"loglog_interpolate: the points are not monotone: {list(xs)}")
    t = math.log(x)
    if not lx[0] <= t <= lx[-1]:
        return None
    return math.exp(np.interp(t, lx, ly))


def spread(values):
    """max/min − 1 of positive values (relative variation)."""
    values = np.asarray(values, float)
    return float(values.max() / values.min() - 1.0)


def mpirun_prefix(nprocs):
    if nprocs <= 1:
        return []
    cmd = ["mpirun", "-n", str(nprocs), "--oversubscribe"]
    if os.geteuid() == 0:
        cmd.insert(1, "--allow-run-as-root")
    return cmd


def child_env():
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), str(HERE)] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    env.setdefault("OMP_NUM_THREADS", "1")
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    return env


def fmt(value, spec=".3e"):
    if value is None:
        return "–"
    if isinstance(value, float) and math.isnan(value):
        return "nan"
    if isinstance(value, (int, np.integer)):
        return str(value)
    return format(value, spec)


def provenance(script, argv, ranks=1, folder="verification"):
    """The lines that go beside a measurement's table: date (UTC), commit (and whether the tree differs from it),
    machine (with the DOLFINx version and the ranks) and the command that reproduces it (``script`` under
    ``folder`` of the repository, ``argv`` its arguments)."""
    import datetime
    import platform
    import subprocess
    import dolfinx

    def git(*args):
        try:
            return subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True).stdout.strip()
        except OSError:
            return ""

    commit = git("rev-parse", "--short", "HEAD") or "?"
    if git("status", "--porcelain", "--untracked-files=no"):
        commit += " (with uncommitted changes)"
    return [f"- date: {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC",
            f"- commit: {commit}",
            f"- machine: {platform.node()}, {platform.machine()}, {os.cpu_count()} cores, Python "
            f"{platform.python_version()}, DOLFINx {dolfinx.__version__}, {ranks} rank(s)",
            f"- command: PYTHONPATH=. /usr/bin/python3 {folder}/{script} {' '.join(argv)}".rstrip()]


def refined_around(problem, inside, uniform=0, local=0, comm=None):
    """The problem's level-0 mesh (its [mesh.shapes] resolved, so that refinement puts new boundary vertices on
    them) refined ``uniform`` times everywhere, then ``local`` times in the owned cells whose midpoints
    satisfy ``inside(midpoints)`` (an (n, 3) array -> (n,) booleans). Public API only."""
    import numpy as np
    from mpi4py import MPI
    from dolfinx.mesh import compute_midpoints
    import nc_dolfinx as nc
    domain = nc.build_domain(problem, comm or MPI.COMM_WORLD)
    nc.bind(problem, domain)
    for _ in range(uniform):
        domain = nc.refine(domain)
    for _ in range(local):
        msh = domain.mesh
        tdim = msh.topology.dim
        owned = np.arange(msh.topology.index_map(tdim).size_local, dtype=np.int32)
        mids = compute_midpoints(msh, tdim, owned)
        domain = nc.refine(domain, np.flatnonzero(inside(mids)).astype(np.int32))
    return domain
