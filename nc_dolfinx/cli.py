"""Command line: ``python3 run_cases.py [CASE_OR_FILE ...] [options] [PETSc options]``.

Any argument starting with ``-`` that is not one of ours is a PETSc option (``-snes_monitor``,
``-ksp_type cg``, ``-pc_type gamg`` …); it is set under the solver's prefix, overriding the preset and the
problem file. Bad input ends the run with one line ``nc_dolfinx: error: …`` and exit status 1.
"""
import argparse
import dataclasses
import logging
import time

from mpi4py import MPI

from .errors import InputError

EXIT_INPUT, EXIT_INTERNAL = 1, 3


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # a bad option value is bad input: one line, exit status 1 (not usage + 2)
        raise InputError(f"{message} (see --help)")


def parser():
    p = _Parser(
        prog="run_cases.py",
        description="Normal compliance contact (Fernández & Hild) with a residual estimator and "
                    "adaptive refinement. Unknown -options are passed to PETSc (SNES/KSP/PC).",
        epilog="Example: mpirun -n 2 python3 run_cases.py block --refine adaptive --levels 6 -snes_monitor")
    p.add_argument("cases", nargs="*", metavar="CASE_OR_FILE",
                   help="built-in case name (see --list) or a .toml problem file; default: block")
    p.add_argument("--list", action="store_true", help="list the built-in cases and exit")
    p.add_argument("--out", default=None, help="output directory (default: results/CASE)")
    p.add_argument("--refine", choices=("none", "uniform", "adaptive"), default=None)
    p.add_argument("--levels", type=int, default=None, help="number of levels (solves)")
    p.add_argument("--theta", type=float, default=None, help="marking parameter (default 0.5)")
    p.add_argument("--marking", choices=("doerfler", "maximum"), default=None)
    p.add_argument("--max-dofs", type=int, default=None, help="stop once a level has this many dofs")
    p.add_argument("--tol", type=float, default=None, help="stop once eta <= TOL")
    p.add_argument("--rtol", type=float, default=None, help="stop once eta <= RTOL * eta(level 0)")
    p.add_argument("--preset", choices=("auto", "direct", "iterative"), default=None,
                   help="linear solver preset for CG on the Jacobian: preconditioned by a MUMPS Cholesky "
                        "factorisation (direct) or GAMG (iterative); auto (default) picks one from the "
                        "mesh's dimension and size")
    p.add_argument("--load-steps", type=int, default=None, help="increments of the loads on level 0")
    p.add_argument("--compare-uniform", action="store_true",
                   help="with --refine adaptive: also run uniform refinement (same level and dof limits) and "
                        "plot both in convergence.png (history_uniform.csv)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a problem-file entry, e.g. --set contact.m_n=2 (repeatable)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    return p


def petsc_options(tokens):
    """['-ksp_type', 'cg', '-snes_monitor'] -> {'ksp_type': 'cg', 'snes_monitor': None}."""
    options, i = {}, 0
    while i < len(tokens):
        key = tokens[i]
        if not key.startswith("-") or key.startswith("--") or len(key) < 2:
            raise InputError(f"unexpected argument '{key}' (PETSc options look like -ksp_type cg)")
        value = None
        if i + 1 < len(tokens) and (not tokens[i + 1].startswith("-") or _is_number(tokens[i + 1])):
            value, i = tokens[i + 1], i + 1
        options[key[1:]] = value
        i += 1
    return options


def _is_number(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


def main(argv=None):
    comm = MPI.COMM_WORLD
    say = (lambda text: print(text, flush=True)) if comm.rank == 0 else (lambda text: None)
    try:
        args, rest = parser().parse_known_args(argv)
    except InputError as err:
        say(f"nc_dolfinx: error: {err}")
        return EXIT_INPUT
    try:
        _quiet_jit_logging()
        if args.list:
            from . import cases
            for name, title in cases.available().items():
                say(f"{name:14s} {title}")
            return 0
        cli_options = petsc_options(rest)
        for case in args.cases or [_default_case()]:
            run_case(case, args, cli_options, comm, say)
        return 0
    except InputError as err:
        say(f"nc_dolfinx: error: {err}")
        return EXIT_INPUT
    except Exception as err:  # anything else is our bug or the system's: still one line unless --debug
        if args.debug:
            raise
        say(f"nc_dolfinx: internal error: {type(err).__name__}: {err} (rerun with --debug for details)")
        return EXIT_INTERNAL


def _default_case():
    from .cases import DEFAULT_CASE
    return DEFAULT_CASE


def _quiet_jit_logging():
    # FFCx/setuptools log every compilation at INFO on the root logger.
    # setuptools resets the root level on every compilation, so filter instead of setting a level.
    logging.getLogger().addFilter(lambda record: record.levelno >= logging.WARNING)


def run_case(case, args, cli_options, comm, say):
    from pathlib import Path

    from . import adaptive, cases, output, problem as problem_module, reference
    path = cases.resolve(case)
    problem = problem_module.load_problem(path, args.set)
    if args.preset:
        problem.preset = args.preset
    if args.load_steps is not None:
        if args.load_steps < 1:
            raise InputError(f"--load-steps must be >= 1, got {args.load_steps}")
        problem.load_steps = args.load_steps
    settings = adaptive.AdaptSettings.from_problem(
        problem, refine=args.refine, levels=args.levels, theta=args.theta, marking=args.marking,
        max_dofs=args.max_dofs, tol=args.tol, rtol=args.rtol)
    multiple = len(args.cases) > 1
    out = Path(args.out) / problem.name if (args.out and multiple) else Path(args.out or f"results/{problem.name}")
    say(f"{problem.name}: {problem.title} [{comm.size} rank(s), refine={settings.refine}, "
        f"levels={settings.levels}] -> {out}")
    writer = output.ResultWriter(out, comm)
    start = time.perf_counter()
    try:
        def write_level(level):
            writer.write_functions(f"levels/level_{level.row['level']:02d}.xdmf", level.u.function_space.mesh,
                                   [level.u, *level.estimate.fields.values()])

        final, history = adaptive.run(problem, comm, settings, cli_options, on_level=write_level,
                                      progress=None if args.quiet else say)
        mesh = final.u.function_space.mesh
        writer.write_functions("solution.xdmf", mesh, [final.u, *output.postprocess_fields(final.u, final.fields),
                                                        *final.estimate.fields.values()])
        comparisons = reference.compare(problem, history[-1])
        summary = {
            "problem": problem.name, "title": problem.title, "source": str(path), "ranks": comm.size,
            "refine": settings.refine, "levels": len(history), "m_n": problem.m_n,
            **history[-1],
            "time_total": time.perf_counter() - start,
            "reference": [{"quantity": q, "computed": c, "reference": r} for q, c, r in comparisons],
        }
        writer.write_json("summary.json", summary)
        writer.write_json("history.json", history)
        writer.write_csv("history.csv", history)
        histories = {settings.refine: history}
        if args.compare_uniform and settings.refine == "adaptive":
            # stop uniform refinement once it has as many dofs as the adaptive run's last level
            uniform = dataclasses.replace(settings, refine="uniform",
                                          max_dofs=min(settings.max_dofs or history[-1]["dofs"],
                                                       history[-1]["dofs"]))
            if not args.quiet:
                say("  uniform refinement for comparison:")
            _, histories["uniform"] = adaptive.run(problem, comm, uniform, cli_options,
                                                   progress=None if args.quiet else say)
            writer.write_json("history_uniform.json", histories["uniform"])
            writer.write_csv("history_uniform.csv", histories["uniform"])
        if comm.rank == 0:
            output.convergence_plot(writer.path_local("convergence.png"), histories,
                                    problem.title.split(":")[0])
        writer.commit()
    except BaseException:
        writer.abort()
        raise
    for quantity, computed, ref in comparisons:
        say(f"  {quantity}: computed {computed:.5g}, reference {ref:.5g} "
            f"({100 * (computed - ref) / ref:+.2f} %)")
    say(f"  wrote {out}/ (summary.json, history.csv, solution.xdmf, levels/, convergence.png) "
        f"in {time.perf_counter() - start:.1f} s")
