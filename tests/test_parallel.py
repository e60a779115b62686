"""Serial and parallel runs agree: dofs, iterations, marked sets, η, forces, energy and errors per level."""
import pytest

from conftest import ROOT, history, run, run_cli

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


@pytest.mark.parametrize("case,strategy,theta", [("block", "doerfler", 0.5), ("manufactured", "doerfler", 0.3),
                                                 ("corner", "maximum", 0.5)])
def test_marked_sets_are_identical_on_1_2_3_ranks(case, strategy, theta):
    import json
    from conftest import ROOT, run
    script, toml = ROOT / "tests" / "mpi" / "marked_cells.py", ROOT / "nc_dolfinx" / "cases" / f"{case}.toml"
    sets = []
    for nprocs in (1, 2, 3):
        proc = run([script, toml, strategy, theta], nprocs)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        sets.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    assert len(sets[0]) > 0
    assert sets[1] == sets[0] and sets[2] == sets[0]


@pytest.mark.parametrize("nprocs", [2, 3])
def test_the_same_command_gives_the_same_partition(nprocs):
    """Debian's PT-SCOTCH partitions with several threads unless told otherwise: the same run on 2 ranks
    then got one of several partitions (3 in 5 runs of this script), and with it other AMG hierarchies,
    Newton counts and last digits. nc_dolfinx asks SCOTCH for one thread."""
    script = ROOT / "tests" / "mpi" / "partition_hash.py"
    prints = set()
    for _ in range(4):
        proc = run([script], nprocs)
        assert proc.returncode == 0, proc.stderr[-2000:]
        prints.add(proc.stdout.strip())
    assert len(prints) == 1
