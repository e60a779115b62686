#!/usr/bin/env python3
"""Verification of nc_dolfinx against the paper (Fernández & Hild): run every study from scratch under
mpirun, check the expectations, print a table per study and a PASS/FAIL summary.

    /usr/bin/python3 verification/verify.py --quick          # CI: fewer levels, same expectations
    /usr/bin/python3 verification/verify.py                  # full: writes verification/report.md + PNGs
    /usr/bin/python3 verification/verify.py --np 3 --quick   # the studies on 3 MPI ranks (default 2)

Exit status 0 if every expectation holds, 1 if one fails (or a study crashes). The heavy parts run as
``mpirun -n NP /usr/bin/python3 verification/worker.py STUDY`` subprocesses (``worker3d.py`` for the 3D
studies; the parallel-invariance studies on 1, 2 and 3 ranks); this driver only checks, tabulates and plots. Quick mode writes its tables, plots and
report into a temporary directory (``--out`` to choose it), never over the committed full report.
"""
import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from common import PYTHON, child_env, mpirun_prefix  # noqa: E402
import checks  # noqa: E402

STUDY_ORDER = ["manufactured", "closed_form", "penalty", "hertz", "corner", "parallel",
               "manufactured3d", "hertz3d", "fichera", "penalty3d", "parallel3d", "friction_exact",
               "friction_manufactured", "cattaneo", "curved"]
STUDIES_3D = {"manufactured3d", "hertz3d", "fichera", "penalty3d", "parallel3d"}  # run by worker3d.py
STUDIES_FRICTION = {"friction_exact", "friction_manufactured", "cattaneo"}  # run by worker_friction.py
STUDIES_OWN_WORKER = {"curved": "curved.py"}  # a study module that is its own worker and checks (issue 46)
ON_ALL_RANK_COUNTS = {"parallel", "parallel3d"}
PARALLEL_RANKS = (1, 2, 3)


def run_worker(study, mode, nprocs, out_json, log, timeout):
    worker = STUDIES_OWN_WORKER.get(study) or ("worker3d.py" if study in STUDIES_3D else
                                               "worker_friction.py" if study in STUDIES_FRICTION else "worker.py")
    cmd = mpirun_prefix(nprocs) + [PYTHON, str(HERE / worker), study, "--mode", mode, "--out", str(out_json)]
    start = time.perf_counter()
    try:
        proc = subprocess.run(cmd, env=child_env(), capture_output=True, text=True, timeout=timeout)
        output, code = proc.stdout + proc.stderr, proc.returncode
    except subprocess.TimeoutExpired as err:
        output = (err.stdout or b"").decode() if isinstance(err.stdout, bytes) else (err.stdout or "")
        output, code = output + f"\nTIMEOUT after {timeout} s", -1
    elapsed = time.perf_counter() - start
    with open(log, "a") as fh:
        fh.write(f"$ {' '.join(cmd)}\n{output}\n(exit {code}, {elapsed:.1f} s)\n\n")
    if code != 0 or not Path(out_json).is_file():
        tail = "\n".join(line for line in output.splitlines() if "INFO" not in line)[-3000:]
        raise RuntimeError(f"{study} on {nprocs} rank(s) failed (exit {code}):\n{tail}")
    data = json.loads(Path(out_json).read_text())
    data["wall_time"] = elapsed
    return data


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="CI mode: fewer levels and parameters")
    parser.add_argument("--np", type=int, default=2, help="MPI ranks for the studies (default 2)")
    parser.add_argument("--out", default=None,
                        help="directory for report.md and the PNGs (default: verification/ in full mode, "
                             "a temporary directory in quick mode)")
    parser.add_argument("--studies", nargs="*", default=None, choices=STUDY_ORDER,
                        help="run only these studies (debugging; the summary then covers only them)")
    parser.add_argument("--timeout", type=float, default=3600, help="per worker run, seconds")
    parser.add_argument("--keep", action="store_true", help="keep the workers' JSON results and log")
    parser.add_argument("--workdir", default=None, help="directory for the workers' results (default: a new temporary one)")
    parser.add_argument("--sensitivity", choices=("auto", "yes", "no"), default="auto",
                        help="study 8: run the quick mode on temporary copies with a broken estimator/indicators.py and expect "
                             "it to fail (auto: in full mode only)")
    parser.add_argument("--reuse", default=None, metavar="WORKDIR",
                        help="development: re-check and re-report the JSON results kept in WORKDIR, running nothing")
    args = parser.parse_args(argv)
    mode = "quick" if args.quick else "full"
    t0 = time.perf_counter()
    if args.out:
        out = Path(args.out).resolve()
    elif mode == "full":
        out = HERE
    else:
        out = Path(tempfile.mkdtemp(prefix="nc_verify_quick-"))
    out.mkdir(parents=True, exist_ok=True)
    if args.reuse:
        work = Path(args.reuse)
    elif args.workdir:
        work = Path(args.workdir)
        work.mkdir(parents=True, exist_ok=True)
    else:
        work = Path(tempfile.mkdtemp(prefix="nc_verify_work-"))
    log = work / "workers.log"
    print(f"nc_dolfinx verification ({mode} mode, {args.np} rank(s)); output -> {out}; worker log -> {log}",
          flush=True)

    results, errors, timings = {}, {}, {}
    for study in args.studies or STUDY_ORDER:
        start = time.perf_counter()
        print(f"\n=== running {study} ...", flush=True)
        try:
            if args.reuse:
                every = study in ON_ALL_RANK_COUNTS
                names = [f"{study}_{n}.json" for n in PARALLEL_RANKS] if every else [f"{study}.json"]
                loaded = [json.loads((work / name).read_text()) for name in names]
                results[study] = dict(zip(PARALLEL_RANKS, loaded)) if every else loaded[0]
            elif study in ON_ALL_RANK_COUNTS:
                results[study] = {n: run_worker(study, mode, n, work / f"{study}_{n}.json", log, args.timeout)
                                  for n in PARALLEL_RANKS}
            else:
                results[study] = run_worker(study, mode, args.np, work / f"{study}.json", log, args.timeout)
        except Exception as err:  # a crashed study is a failed study; go on with the others
            errors[study] = str(err)
            print(f"    {study} FAILED to run: {err}", flush=True)
        timings[study] = time.perf_counter() - start

    if args.sensitivity == "yes" or (args.sensitivity == "auto" and mode == "full" and not args.studies):
        start = time.perf_counter()
        print("\n=== running sensitivity (quick mode on copies with a broken estimator) ...", flush=True)
        if args.reuse and (work / "sensitivity.json").is_file():
            results["sensitivity"] = json.loads((work / "sensitivity.json").read_text())
        else:
            try:
                import sensitivity
                results["sensitivity"] = sensitivity.run(args.np)
                (work / "sensitivity.json").write_text(json.dumps(results["sensitivity"], indent=1))
            except Exception as err:
                errors["sensitivity"] = f"{type(err).__name__}: {err}"
        timings["sensitivity"] = time.perf_counter() - start

    report = checks.evaluate(results, errors, mode)
    for section in report.sections:
        print()
        print(section.console())
    total = time.perf_counter() - t0
    run_file = work / "run.json"
    if args.reuse and run_file.is_file():  # report the original run's times, not the re-check's
        saved = json.loads(run_file.read_text())
        total, timings = saved["total"], saved["timings"]
    else:
        run_file.write_text(json.dumps({"total": total, "timings": timings}))
    print("\n=== summary")
    print(report.summary_table())
    print(f"\n{report.passed_count} of {report.count} expectations hold; "
          f"{'PASS' if report.ok else 'FAIL'} ({mode} mode, {args.np} rank(s), {total:.0f} s)")
    print("studies: " + ", ".join(f"{s} {timings[s]:.0f} s" for s in timings))

    try:
        import report as report_module
        report_module.write(report, results, out, mode=mode, nprocs=args.np, total_time=total, timings=timings)
        print(f"report: {out / 'report.md'}")
    except Exception as err:  # the report is a by-product: its failure is a failure too
        import traceback
        traceback.print_exc()
        print(f"writing the report failed: {err}")
        return 1
    if report.ok and not args.reuse and not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    else:
        print(f"worker results and log kept in {work}")
    return 0 if report.ok else 1


if __name__ == "__main__":
    sys.exit(main())
