"""The literate demos (issue 12): each runs at its small size on 1 and 2 ranks with warnings as errors,
exits 0, and prints every ``checked:`` line of the properties it asserts; its pictures go to the output
directory it is given, nothing into the repository. Each is a valid jupytext percent-format script.

A demo's checks are physical or mathematical (Dörfler's criterion on the marked set, the exactness of the
transfer, rates, penetration ∝ c_n^(-1/m_n), compile-once, plane strain = a 3D slab between symmetry
planes): a wrong number stops the demo with an AssertionError, so exit 0 with all ``checked:`` lines
means they held.
"""
import os
import re
import signal
import subprocess

import pytest

from conftest import PYTHON, ROOT

DEMOS = ROOT / "demos"
# demo -> (number of checks it makes, pictures it writes)
EXPECTED = {
    "demo_paper_setting.py": (6, ["indicators.png", "convergence.png", "indicators_final.png"]),
    "demo_parameter_study.py": (7, ["parameter_study.png"]),
    "demo_gmsh_geometry.py": (6, ["plate.png", "plate.msh"]),
    "demo_3d.py": (4, ["block_3d.png"]),
    "demo_two_bodies.py": (4, ["two_cylinders_pressure.png"]),
}
TIMEOUT = 400  # seconds for one run; a hang fails the test instead of blocking the suite


def run_demo(name, nprocs, out_dir):
    """``mpirun -n NPROCS python3 -W error -m mpi4py demos/NAME --small --out OUT_DIR`` from a scratch
    directory. A demo fails on every rank together (global checks; rank 0's gmsh model through
    nc.from_gmsh_model(build=...)); ``-m mpi4py`` alone would not stop ranks waiting for a failed one (with
    petsc4py loaded the failed rank does not reach mpi4py's abort at exit: demos/README.md). A run that does
    not end in TIMEOUT is killed with its process group."""
    mpirun = ["mpirun", "-n", str(nprocs)] + (["--allow-run-as-root"] if os.geteuid() == 0 else [])
    # DOLFINx 0.9 warns at import that the optional numba is missing: that one warning is not the demo's
    command = mpirun + [PYTHON, "-W", "error", "-W", "ignore:Could not import numba:ImportWarning", "-m", "mpi4py",
                        str(DEMOS / name), "--small", "--out", str(out_dir)]
    # (no bytecode cache: Python 3.13 writes demos/__pycache__ for support.py, which is not the demo's output)
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1")
    env.pop("NC_DEMO_OUT", None)
    proc = subprocess.Popen(command, cwd=out_dir, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    try:
        out, err = proc.communicate(timeout=TIMEOUT)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        pytest.fail(f"{name} on {nprocs} rank(s) did not end within {TIMEOUT} s:\n{out[-2000:]}\n{err[-2000:]}")
    return subprocess.CompletedProcess(command, proc.returncode, out, err)


def test_every_demo_is_tested():
    assert sorted(p.name for p in DEMOS.glob("demo_*.py")) == sorted(EXPECTED)


@pytest.mark.parametrize("nprocs", [1, 2])
@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_demo_runs_and_its_checks_hold(name, nprocs, tmp_path):
    before = sorted(p.name for p in DEMOS.iterdir() if p.name != "__pycache__")
    proc = run_demo(name, nprocs, tmp_path)
    text = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{name} on {nprocs} rank(s) failed:\n{text[-4000:]}"
    assert "Traceback" not in text and "Warning" not in text, text[-4000:]
    checks, pictures = EXPECTED[name]
    checked = [line for line in proc.stdout.splitlines() if line.startswith("checked: ")]
    assert len(checked) == checks, f"{len(checked)} checks ran, expected {checks}:\n{proc.stdout}"
    for picture in pictures:
        assert (tmp_path / picture).is_file() and (tmp_path / picture).stat().st_size > 0, picture
    assert sorted(p.name for p in DEMOS.iterdir() if p.name != "__pycache__") == before, "the demo wrote into demos/"


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_demo_is_a_percent_format_notebook(name):
    """What jupytext needs to read the file as a notebook: its header naming the percent format, and
    cells opened by ``# %%`` lines; a markdown cell holds comment lines only, and some of them cite the
    paper."""
    text = (DEMOS / name).read_text()
    assert text.startswith("# ---\n# jupyter:\n#   jupytext:\n") and "#       format_name: percent\n" in text
    cells = re.split(r"^# %%", text, flags=re.M)[1:]
    markdown = [c for c in cells if c.startswith(" [markdown]")]
    assert len(markdown) >= 4 and len(cells) - len(markdown) >= 4, (len(markdown), len(cells))
    for cell in markdown:
        body = cell.split("\n", 1)[1].rstrip("\n")
        assert all(line.startswith("#") for line in body.splitlines()), cell[:200]
    assert re.search(r"\(\d\)|Definition 5|Remark 1", " ".join(markdown)), "no reference to the paper"
