"""Study 8: the quick mode must fail when the estimator is broken.

Each break is a textual patch of ``nc_dolfinx/estimator/indicators.py`` applied to a *temporary copy* of the
repository (the real file is never touched); the copy's ``verification/verify.py --quick`` must then exit
non-zero. Its summary.json tells which expectations caught the break. If a patch no longer applies
(estimator/indicators.py was refactored), that is reported as a failure, so the patterns get updated.
"""
import json
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from common import PYTHON, ROOT, child_env

JUMP = '    form += ufl.inner(jump, jump) * (wv("+")[eta_2] + wv("-")[eta_2]) * dS\n'
# the estimator multiplies the assembled facet terms by h_K afterwards: h_E² / h_K in the integrand gives h_E²
# (FacetArea restricted: UFL 2026 (DOLFINx 0.11) refuses an unrestricted one on interior facets)
H_E_SQUARED = ('    msh, h = fields.domain.mesh, ufl.CellDiameter(fields.domain.mesh)\n'
               '    form += ufl.inner(jump, jump) * ufl.FacetArea(msh)("+") ** 2 * (wv("+")[eta_2] / h("+")'
               ' + wv("-")[eta_2] / h("-")) * dS\n')
BREAKS = {
    "interior jumps dropped from η_2": (JUMP, ""),
    "h_E² instead of h_K on interior edges": (JUMP, H_E_SQUARED),
}
COPY = ["nc_dolfinx", "verification", "meshes", "run_cases.py", "tests/mpi"]  # (tests/mpi: the friction studies' layer)


def run(nprocs, timeout=1800):
    results = []
    for name, (old, new) in BREAKS.items():
        start = time.perf_counter()
        tmp = Path(tempfile.mkdtemp(prefix="nc_verify_break-"))
        try:
            for item in COPY:
                src = ROOT / item
                if src.is_dir():
                    shutil.copytree(src, tmp / item, ignore=shutil.ignore_patterns("__pycache__", "*.png", "report.md",
                                                                                   "summary.json"))
                elif src.exists():
                    shutil.copy2(src, tmp / item)
            target = tmp / "nc_dolfinx" / "estimator" / "indicators.py"
            text = target.read_text()
            if text.count(old) != 1:
                results.append({"break": name, "applied": False, "exit": None, "caught_by": [],
                                "time": time.perf_counter() - start})
                continue
            target.write_text(text.replace(old, new))
            out = tmp / "out"
            proc = subprocess.run([PYTHON, str(tmp / "verification" / "verify.py"), "--quick", "--np", str(nprocs),
                                   "--out", str(out), "--workdir", str(tmp / "work")], cwd=tmp, env=child_env_for(tmp), capture_output=True,
                                  text=True, timeout=timeout)
            caught = []
            summary = out / "summary.json"
            if summary.is_file():
                for sec in json.loads(summary.read_text())["sections"]:
                    caught += [f"{sec['title'].split(' ', 1)[0]} {c['name']}" for c in sec["checks"] if not c["ok"]]
                    if sec["error"]:
                        caught.append(f"{sec['title'].split(' ', 1)[0]} did not run")
            results.append({"break": name, "applied": True, "exit": proc.returncode, "caught_by": caught,
                            "time": time.perf_counter() - start})
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return results


def child_env_for(root):
    env = child_env()
    # the copy's package and verification helpers, not the working tree's
    env["PYTHONPATH"] = f"{root}:{root / 'verification'}"
    return env
