"""Smoke run of benchmarks/run.py (tiny meshes, serial): the harness runs end to end, and what it compares
is the same problem — our solver, the plain-dolfinx baseline (PETSc LU and MUMPS) and, when python3-dolfin
is installed, legacy FEniCS reach the same elastic energy and contact force to 1e-8 — and the forms are
compiled once per run (an empty FFCx cache: level 0 compiles, the nested level compiles nothing)."""
import csv
import json
import subprocess

import pytest

from conftest import PYTHON, ROOT, import_script, run

BENCH = ROOT / "benchmarks" / "run.py"
RTOL = 1e-8


def legacy_installed():
    return subprocess.run([PYTHON, "-c", "import dolfin"], capture_output=True).returncode == 0


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    proc = run([BENCH, "--smoke", "--np", "1", "--problems", "block", "corner", "--cold-jit-cache",
                "--csv", out / "bench.csv", "--json-out", out / "bench.json"], timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    with open(out / "bench.csv") as fh:
        rows = list(csv.DictReader(fh))
    return proc.stdout, rows, json.loads((out / "bench.json").read_text())


def test_table_has_the_expected_columns(smoke):
    stdout, rows, _ = smoke
    run_script = import_script("benchmarks", "run")
    COLUMNS, TABLES = run_script.COLUMNS, run_script.TABLES
    assert {r["problem"] for r in rows} == {"block", "corner"}
    optional = {"parallel_speedup"} | ({"t_legacy", "legacy_newton", "legacy_krylov", "speedup_legacy",
                                        "legacy_energy_rdiff", "legacy_force_rdiff"}
                                       if not legacy_installed() else set())
    missing = set(COLUMNS) - optional - set(rows[0])
    assert not missing, missing
    for title, columns in TABLES.items():
        assert title in stdout
        header = next(line for line in stdout.splitlines()[stdout.splitlines().index(title) + 1:])
        assert header.split() == [h for _, h, _ in columns for h in h.split()]
    for r in rows:
        for key in ("t_mesh", "t_setup", "t_solve", "t_linear", "t_estimate", "t_refine", "t_output",
                    "t_nested_solve", "mem_peak_MB"):
            assert float(r[key]) > 0, key
        assert int(r["newton"]) >= 1 and int(r["krylov"]) >= 1 and int(r["linear_its"]) >= 1


def test_baselines_reach_the_same_solution(smoke):
    _, _, rows = smoke
    for r in rows:
        for base in ("lu", "mumps"):
            assert r[f"base_{base}_converged"], (r["problem"], base)
            assert r[f"base_{base}_energy_rdiff"] < RTOL, (r["problem"], base, r[f"base_{base}_energy_rdiff"])
            assert r[f"base_{base}_force_rdiff"] < RTOL, (r["problem"], base, r[f"base_{base}_force_rdiff"])
        assert r["base_lu_type"] == "petsc"  # PETSc's default LU type on one rank


def test_legacy_fenics_reaches_the_same_solution(smoke):
    if not legacy_installed():
        pytest.skip("python3-dolfin (legacy FEniCS 2019) is not installed")
    _, _, rows = smoke
    for r in rows:
        assert "t_legacy" in r, r["problem"]
        assert r["legacy_energy_rdiff"] < RTOL, (r["problem"], r["legacy_energy_rdiff"])
        assert r["legacy_force_rdiff"] < RTOL, (r["problem"], r["legacy_force_rdiff"])


# Both meshes carry an equispaced P1 coordinate element (nc_dolfinx.mesh.builtin.rectangle sets it as gmshio
# does): FFCx 0.5 would otherwise set the variant in place while compiling, refined meshes would inherit
# it, and level 1 would compile its forms again.
@pytest.mark.parametrize("problem", ["corner", "block"])
def test_forms_compiled_once_per_run(smoke, problem):
    _, _, rows = smoke
    r = next(r for r in rows if r["problem"] == problem)
    assert r["compiled"] > 0                 # the empty cache: level 0 compiles its forms
    assert r["nested_compiled"] == 0, r["nested_compiled"]  # the next level of the same run reuses them


def test_the_boomeramg_floor_is_set_up_as_the_solver_sets_it_up():
    """benchmarks/ use the public API only, so the BoomerAMG floor spells out its options: they must be the
    solver's in each dimension (solver.linear.HYPRE_BY_DIM), or the "(hypre)" columns would compare against another
    preconditioner."""
    import importlib.util
    from nc_dolfinx.solver import HYPRE_BY_DIM
    spec = importlib.util.spec_from_file_location("benchmarks_common", ROOT / "benchmarks" / "common.py")
    common = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(common)
    for dim, settings in HYPRE_BY_DIM.items():
        floor = common.floor_amg_options("hypre", dim)
        assert floor["pc_type"] == "hypre" and floor["ksp_type"] == "cg"
        assert {key: value for key, value in floor.items() if key.startswith("pc_hypre")} == settings


def test_the_amg_comparison_solves_to_the_accuracy_it_compares_at(tmp_path):
    """benchmarks/amg.py on the smoke meshes, 1 rank: every preconditioner it times reaches the true residual
    1e-10 ‖L‖ that Newton stops at (so the columns compare equal accuracy), the floor (preconditioned rtol
    1e-8) a coarser one, on generated and Plaza-refined meshes of all four bodies."""
    out = tmp_path / "amg.json"
    proc = run([ROOT / "benchmarks" / "amg.py", "--small", "--np", "1", "--repeat", "1", "--json-out", out],
               timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    assert len(rows) == 8 and {r["mesh"] for r in rows} == {"generated", "refined"}
    for r in rows:
        for name in ("gamg", "hypre", "hypre_before"):
            assert r[f"residual_{name}"] <= 2e-10, (r["body"], r["mesh"], name)
        assert r["residual_floor"] > 1e-9


def test_the_laws_beyond_the_family_converge_with_the_defaults(tmp_path):
    """benchmarks/extremes.py on small meshes, 1 and 2 ranks, c_n/E = 1e9: all 36 members (m_n 1–3, with and
    without gaps, 2D and 3D) converge with no options and no fallback; the penalties with a gap end at the
    residual's round-off (they ended in an error after every fallback before)."""
    out = tmp_path / "extremes.csv"
    proc = run([ROOT / "benchmarks" / "extremes.py", "--np", "1", "2", "--bodies", "square", "--cells", "16",
                "--cells3d", "4", "--c-n", "1e9", "--csv", out], timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    with open(out) as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 36
    assert all(r["reason"].startswith("CONVERGED") and not r["recoveries"] for r in rows)
    penalties_with_gap = [r for r in rows if r["m_n"] == "1" and r["gap"] != "0"]
    assert len(penalties_with_gap) == 8 and all(r["reason"] == "CONVERGED_ROUNDOFF" for r in penalties_with_gap)


def test_the_replayed_systems_are_the_cold_solve_s(tmp_path):
    """benchmarks/replay.py on small meshes, 2D and 3D: PETSc wrote one linear system per Newton step of the
    cold frictional solve (so the replay solves what the solver solved), every replayed solve reaches its
    tolerance in the true residual (the harness checks it), and 'refresh' sets up once a system, 'kept' and
    'block' once in all."""
    out = tmp_path / "replay.json"
    proc = run([ROOT / "benchmarks" / "replay.py", "--members", "1-1-mu0.3", "3d-1-1-mu0.3", "--cells", "16",
                "--cells3d", "4", "--repeat", "1", "--json-out", out], timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    assert [r["member"] for r in rows] == ["1-1-mu0.3", "3d-1-1-mu0.3"]
    for r in rows:
        assert r["systems"] == r["Newton"] > 1, r
        assert (r["refresh set-ups"], r["kept set-ups"], r["block set-ups"]) == (r["systems"], 1, 1), r


def test_the_load_cycle_runs_and_reports_its_costs(tmp_path):
    """benchmarks/load_cycle.py --smoke (16 and 4 cells, one 2D and one 3D friction member, one rank): the cycle
    converges in its 20 increments, every cost is a positive multiple of the floor (the worst at least the mean),
    and the table carries its provenance (date, commit, machine, command)."""
    out = tmp_path / "cycle.json"
    proc = run([ROOT / "benchmarks" / "load_cycle.py", "--smoke", "--json-out", out], timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(out.read_text())
    assert [(r["member"], r["dim"]) for r in rows] == [("1-1-mu0.3", 2), ("3d-1-1-mu0.3", 3)]
    for r in rows:
        assert r["converged"] and r["incr"] == 20 and r["cuts"] == 0, r
        assert 0 < r["mean"] <= r["worst"] and r["cold"] > 0 and len(r["costs"]) == 20, r
    for label in ("- date:", "- commit:", "- machine:", "- command:"):
        assert label in proc.stdout
