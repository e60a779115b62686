"""Problem values enter the forms as fem.Constants: a sweep compiles the forms once (issues 12, 13).

The sweep runs in a subprocess with an empty FFCx cache (XDG_CACHE_HOME in a temporary directory): its
first adaptive run (two levels: solve, estimate, quantities, refinement) compiles every form; every later
run with new values of c_n (also inside an expression of x), m_n, E and ν, the gap, f and a [parameters]
entry compiles nothing.
"""
import json

from conftest import ROOT, run


def test_a_parameter_sweep_compiles_once(tmp_path):
    proc = run([ROOT / "tests" / "mpi" / "compile_count.py"], timeout=600,
               env={"XDG_CACHE_HOME": str(tmp_path / "cache")})
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    rows = json.loads(proc.stdout.strip().splitlines()[-1])
    assert rows[0]["compiled"] > 5, rows[0]           # the empty cache: the first run compiles
    for row in rows[1:]:
        assert row["compiled"] == 0, row              # new values reuse the compiled forms
