"""``pip install .`` on top of the Debian stack: the ``nc-dolfinx`` command, ``python3 -m nc_dolfinx`` and
``import nc_dolfinx`` work from any folder, built-in cases and their meshes included.

The package is installed into a fresh venv (``--system-site-packages`` sees Debian's DOLFINx, PETSc, mpi4py
and gmsh) from a copy of the sources, so the repository gets no build/ or .egg-info folder; the build
backend is Debian's setuptools (``--no-build-isolation``, no network).
"""
import json
import os
import shutil
import subprocess

import pytest

from conftest import PYTHON, ROOT


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    base = tmp_path_factory.mktemp("packaging")
    source = base / "source"
    source.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, source / name)
    shutil.copytree(ROOT / "nc_dolfinx", source / "nc_dolfinx", ignore=shutil.ignore_patterns("__pycache__"))
    env_dir = base / "venv"
    for cmd in ([PYTHON, "-m", "venv", "--system-site-packages", str(env_dir)],
                [str(env_dir / "bin" / "pip"), "install", "--quiet", "--no-build-isolation", "--no-deps",
                 "--no-index", str(source)]):
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stdout + done.stderr
    shutil.rmtree(source)  # the installed package must not need its sources
    return env_dir


def run(venv, args, cwd):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # only what is installed
    return subprocess.run(args, cwd=cwd, env=dict(env, OMP_NUM_THREADS="1"), capture_output=True, text=True,
                          timeout=300)


def test_installed_command_runs_the_gmsh_cases(venv, tmp_path):
    listed = run(venv, [str(venv / "bin" / "nc-dolfinx"), "--list"], tmp_path)
    assert listed.returncode == 0 and "corner" in listed.stdout and "hertz" in listed.stdout, listed.stderr
    for command, case in (([str(venv / "bin" / "nc-dolfinx")], "corner"),
                          ([str(venv / "bin" / "python"), "-m", "nc_dolfinx"], "hertz")):
        done = run(venv, [*command, case, "--refine", "none", "--quiet", "--out", case], tmp_path)
        assert done.returncode == 0, done.stdout + done.stderr
        summary = json.loads((tmp_path / case / "summary.json").read_text())
        assert summary["status"] == "completed" and summary["cells"] > 0
        assert str(venv) in summary["source"]  # the case file (and its mesh) came from the installed package


def test_import_from_anywhere(venv, tmp_path):
    done = run(venv, [str(venv / "bin" / "python"), "-c",
                      "import nc_dolfinx as nc; print(nc.__file__); print(nc.__version__);"
                      "print(nc.case_path('corner'))"], tmp_path)
    assert done.returncode == 0, done.stderr
    path, version, case = done.stdout.split()
    import nc_dolfinx
    assert path.startswith(str(venv)) and version == nc_dolfinx.__version__ and case.startswith(str(venv))


def test_every_subpackage_is_packaged():
    """pyproject.toml lists the packages by hand: a new subpackage left out installs a package that cannot be
    imported (nc_dolfinx.pairs was, for one commit)."""
    import re
    text = (ROOT / "pyproject.toml").read_text()
    listed = set(re.findall(r'"(nc_dolfinx(?:\.\w+)*)"', text.split("packages =", 1)[1].split("]", 1)[0]))
    found = {".".join(p.parent.relative_to(ROOT).parts) for p in (ROOT / "nc_dolfinx").rglob("__init__.py")}
    assert listed == found
