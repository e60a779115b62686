"""verification/two_bodies.py and benchmarks/two_bodies.py (issue 47) as tests: what their tables rest on.

- the patch test's contrast in 2D: the shipped scheme (edges cut where the other face's vertices project)
  transmits the uniform pressure to round-off, the Gauss rule on whole edges and node-to-segment do not;
- the symmetry identity on mirrored meshes, as the script computes it;
- two-body Hertz on the first levels of two_cylinders, within the coarse levels' error;
- the benchmark's --smoke run prints its table and a finite ratio.
"""
import importlib.util
import math
import os
import re
import subprocess
import sys

import pytest

from conftest import ROOT


@pytest.fixture(scope="module")
def script():
    spec = importlib.util.spec_from_file_location("verification_two_bodies", ROOT / "verification" / "two_bodies.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def blocks(tmp_path_factory, script):
    path = tmp_path_factory.mktemp("vblocks") / "b2.msh"
    script.meshes.stacked_blocks_2d(str(path))
    return path


def test_patch_test_needs_the_cut(script, blocks):
    shipped = script.patch_error(blocks, 2, "two")[0]
    whole_edges = script.patch_error(blocks, 2, "two", "gauss")[0]
    node_to_segment = script.patch_error(blocks, 2, "one", "nodes")[0]
    assert shipped < 1e-12
    assert whole_edges > 1e-4          # (measured 1.2e-2: the kinks of v(Πx) inside whole edges)
    assert node_to_segment > 1e-3      # (measured 5.6e-2)


def test_symmetry_identity_on_mirrored_meshes(script, tmp_path):
    row = script.symmetry_mirrored(tmp_path, 0.25)
    assert 0 < row["contact"] < 1.0  # part of the face: the identity holds across the law's kink
    assert max(row["reaction"], row["energy"], row["force"]) < 1e-8


def test_two_cylinders_first_levels_near_hertz(script):
    rows = script.part_hertz2d(quick=True)
    assert len(rows) == 2
    assert rows[-1]["eta"] < rows[0]["eta"]
    assert rows[-1]["err_a"] < 0.08 and rows[-1]["err_p"] < 0.03  # (measured 4.1e-2, 6.2e-3 at level 1)


def test_benchmark_smoke():
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "two_bodies.py"), "--smoke"], cwd=ROOT,
                            capture_output=True, text=True, timeout=300,
                            env=dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1"))
    assert result.returncode == 0, result.stderr[-2000:]
    assert "commit:" in result.stdout and "machine:" in result.stdout and "command:" in result.stdout
    found = re.search(r"two_cylinders np=1 \((\d+) dofs\): cold ([\d.]+)x .* nested ([\d.]+)x", result.stdout)
    assert found, result.stdout
    assert int(found.group(1)) > 1954  # refined once from the shipped mesh
    assert all(0 < float(found.group(i)) < math.inf for i in (2, 3))
