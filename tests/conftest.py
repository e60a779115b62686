"""Shared test helpers: run the CLI or a script serially or under mpirun, read results."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PYTHON = "/usr/bin/python3"
sys.path.insert(0, str(ROOT))


def import_script(folder, name):
    """The module ``name`` of the project's folder ``folder`` (verification/, benchmarks/, meshes/), imported
    with that folder's own helpers: verification/ and benchmarks/ each have a ``common`` module, and a test
    process that imported one must not hand it to the other's scripts. sys.path and sys.modules["common"]
    are as they were afterwards (the module keeps the names it imported)."""
    import importlib
    saved_path, saved_common = list(sys.path), sys.modules.pop("common", None)
    sys.path.insert(0, str(ROOT / folder))
    try:
        return importlib.import_module(name)
    finally:
        sys.path[:] = saved_path
        sys.modules.pop("common", None)
        if saved_common is not None:
            sys.modules["common"] = saved_common


def mpirun_prefix(nprocs):
    if nprocs == 1:
        return []
    cmd = ["mpirun", "-n", str(nprocs)]
    if os.geteuid() == 0:
        cmd.insert(1, "--allow-run-as-root")
    if nprocs > 2:
        cmd.insert(1, "--oversubscribe")
    return cmd


def run(args, nprocs=1, cwd=None, timeout=900, env=None):
    """Run ``python3 ARGS`` (a script and its arguments) on ``nprocs`` ranks; returns CompletedProcess."""
    env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", **(env or {}))
    return subprocess.run(mpirun_prefix(nprocs) + [PYTHON, *map(str, args)], cwd=cwd or ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)


def run_cli(args, nprocs=1, cwd=None):
    """Run ``run_cases.py ARGS --quiet``."""
    return run([ROOT / "run_cases.py", *args], nprocs, cwd)


def summary(out_dir):
    return json.loads((Path(out_dir) / "summary.json").read_text())


def history(out_dir):
    return json.loads((Path(out_dir) / "history.json").read_text())


@pytest.fixture
def cli():
    return run_cli


def pytest_collection_modifyitems(items):
    """Tests marked ``long`` first: under ``pytest -n auto`` (pytest-xdist) they then start at once, instead
    of one finishing alone at the end while the other processes wait."""
    items.sort(key=lambda item: item.get_closest_marker("long") is None)
