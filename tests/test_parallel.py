"""Serial and parallel runs agree: dofs, iterations, marked sets, η, forces, energy and errors per level."""
import pytest

from conftest import history, run_cli

EXACT_KEYS = ("dofs", "cells", "newton_iterations", "marked")
CLOSE_KEYS = ("eta", "eta_1", "eta_2", "eta_3", "eta_4", "zeta", "contact_resultant", "elastic_energy",
              "max_penetration", "max_contact_pressure", "h1_error", "l2_error", "augmented_error")

RUNS = {
    "block-adaptive": ["block", "--refine", "adaptive", "--levels", "5"],
    "manufactured-uniform": ["manufactured", "--refine", "uniform", "--levels", "3"],
    "manufactured-maximum": ["manufactured", "--refine", "adaptive", "--marking", "maximum", "--levels", "4",
                             "--set", "parameters.m=1"],
}


@pytest.fixture(scope="module", params=sorted(RUNS))
def runs(request, tmp_path_factory):
    out = {}
    for nprocs in (1, 2, 3):
        target = tmp_path_factory.mktemp(f"{request.param}-{nprocs}")
        proc = run_cli(RUNS[request.param] + ["--out", target, "--quiet"], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        out[nprocs] = history(target)
    return out


@pytest.mark.parametrize("nprocs", [2, 3])
def test_parallel_matches_serial(runs, nprocs):
    serial, parallel = runs[1], runs[nprocs]
    assert len(serial) == len(parallel)
    for s, p in zip(serial, parallel):
        for key in EXACT_KEYS:
            assert s.get(key) == p.get(key), (key, s["level"])
        for key in CLOSE_KEYS:
            if key in s:
                assert p[key] == pytest.approx(s[key], rel=1e-8, abs=1e-14), (key, s["level"])
        assert p["contact_force"] == pytest.approx(s["contact_force"], rel=1e-8, abs=1e-12)
