"""Command line: ``python3 run_cases.py [CASE_OR_FILE ...] [options] [PETSc options]``.

Any argument starting with ``-`` that is not one of ours is a PETSc option (``-snes_monitor``,
``-ksp_type cg``, ``-pc_type gamg`` …); it is set under the solver's prefix, overriding the preset and the
problem file; one that no solver reads is an error (:mod:`nc_dolfinx.solver.petsc_options`).

Exit status: 0 success; 1 bad input (one line ``nc_dolfinx: error: …`` naming the key, file or option, on
every rank together); 3 an internal error (under MPI the ranks are then aborted, so that none is left
waiting for one that failed); 130 interrupted (Ctrl-C, or SIGTERM from mpirun): the finished levels stay.
"""
import argparse
import difflib
import os
import sys
import time

from mpi4py import MPI

import nc_dolfinx as nc

from ..errors import InputError, brief_text
from . import interrupt

EXIT_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 1, 3, 130


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # a bad option value is bad input: one line, exit status 1 (not usage + 2)
        raise InputError(f"{message} (see --help)")


def _whole(text):
    """A whole number, also in floating-point notation (``--max-dofs 4e5``)."""
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value.is_integer():
        raise argparse.ArgumentTypeError(f"expected a whole number (e.g. 400000 or 4e5), got '{text}'")
    return int(value)


def parser():
    p = _Parser(
        prog=_program_name(),
        description="Normal compliance contact (Fernández & Hild) with a residual estimator and "
                    "adaptive refinement. Unknown -options are passed to PETSc (SNES/KSP/PC).",
        epilog="Example: mpirun -n 2 python3 run_cases.py block --refine adaptive --levels 6 -snes_monitor")
    p.add_argument("cases", nargs="*", metavar="CASE_OR_FILE",
                   help="built-in case name (see --list) or a .toml problem file; default: block")
    p.add_argument("--list", action="store_true", help="list the built-in cases and exit")
    p.add_argument("--out", default=None, help="output folder, empty or new (default: results/CASE; "
                                                  "with several cases OUT/CASE)")
    p.add_argument("--refine", choices=("none", "uniform", "adaptive"), default=None)
    p.add_argument("--levels", type=_whole, default=None, help="number of levels (solves)")
    p.add_argument("--theta", type=float, default=None, help="marking parameter (default 0.5)")
    p.add_argument("--marking", choices=("doerfler", "maximum"), default=None)
    p.add_argument("--max-dofs", type=_whole, default=None,
                   help="stop once a level has this many dofs (400000 or 4e5)")
    p.add_argument("--tol", type=float, default=None, help="stop once eta <= TOL")
    p.add_argument("--rtol", type=float, default=None, help="stop once eta <= RTOL * eta(level 0)")
    p.add_argument("--preset", choices=("auto", "direct", "iterative"), default=None,
                   help="linear solver preset for CG on the Jacobian: preconditioned by a MUMPS Cholesky "
                        "factorisation (direct) or BoomerAMG (iterative); auto (default) picks one from the "
                        "mesh's dimension and size")
    p.add_argument("--load-steps", type=_whole, default=None,
                   help="increments of the loads on level 0 (not with [[steps]]: give their increments)")
    p.add_argument("--write-every", type=_whole, default=None, metavar="N",
                   help="write the files of every N-th state only (output.write_every; each step's last "
                        "state always)")
    p.add_argument("--compare-uniform", action="store_true",
                   help="with --refine adaptive: also run uniform refinement (same level and dof limits) and "
                        "plot both in convergence.png (history_uniform.csv)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a problem-file entry, e.g. --set contact.m_n=2 (repeatable)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace the earlier nc_dolfinx run in --out (the folder is emptied when the new run "
                        "writes its first level); a folder nc_dolfinx did not write is never emptied")
    p.add_argument("--allow-unused-petsc-options", action="store_true",
                   help="accept PETSc options that no solver reads (a warning instead of an error)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    p.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    return p


def petsc_options(tokens, ours=()):
    """['-ksp_type', 'cg', '-snes_monitor'] -> {'ksp_type': 'cg', 'snes_monitor': None}.

    A single-dash spelling of one of our own options (``-levels 3``) is refused with a suggestion, as is
    an unknown ``--option``: neither may silently become a PETSc option."""
    options, i = {}, 0
    while i < len(tokens):
        key = tokens[i]
        if not key.startswith("-") or len(key) < 2:
            raise InputError(f"unexpected argument '{brief_text(key)}' (PETSc options look like -ksp_type cg)")
        name = key.lstrip("-")
        if key.startswith("--") or name.replace("_", "-") in ours:
            close = difflib.get_close_matches("--" + name.replace("_", "-"), [f"--{o}" for o in ours], n=1)
            hint = f" (did you mean {close[0]}?)" if close else " (see --help)"
            raise InputError(f"unknown option '{brief_text(key)}'{hint}")
        value = None
        if i + 1 < len(tokens) and (not tokens[i + 1].startswith("-") or _is_number(tokens[i + 1])):
            value, i = tokens[i + 1], i + 1
        options[name] = value
        i += 1
    return options


def _is_number(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


def _program_name():
    name = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else ""
    return name if name in ("run_cases.py", "nc-dolfinx") else "python3 -m nc_dolfinx"


def main(argv=None):
    """The command line; returns the exit status (see the module's docstring)."""
    comm = MPI.COMM_WORLD
    say = (lambda text: print(text, flush=True)) if comm.rank == 0 else (lambda text: None)
    current = []  # the run under way (for the interruption's record)

    def leave(signal_name):  # rank 0 of a parallel run, in its signal handler (see interrupt.py)
        if current:
            current[0].stopped(KeyboardInterrupt(signal_name))
        _say_interrupted(current, say)
        sys.stdout.flush()
        os._exit(EXIT_INTERRUPTED)

    handlers = interrupt.install(comm, leave)
    try:
        return _main(argv, comm, current, say)
    finally:
        interrupt.restore(handlers)


def _main(argv, comm, current, say):
    args = None
    try:
        args, rest = parser().parse_known_args(argv)
        if args.list:
            for name, title in nc.case_titles().items():
                say(f"{name:14s} {title}")
            return 0
        ours = [a.option_strings[-1].lstrip('-') for a in parser()._actions if a.option_strings]
        cli_options = petsc_options(rest, ours)
        runs = prepare_runs(args, cli_options, comm, say)
        for run in runs:
            current[:] = [run]
            run_case(run, args, comm, say)
        return 0
    except KeyboardInterrupt:
        return _interrupted(current, comm, say)
    except InputError as err:
        if interrupt.received():
            return _interrupted(current, comm, say)
        run = current[0] if current else None
        say(f"nc_dolfinx: error: {run.stage_name + ': ' if run and run.history else ''}{err}")
        if run and run.kept:
            say(f"nc_dolfinx: {run.kept}")
        return EXIT_INPUT
    except Exception as err:  # anything else is our bug or the system's: still one line unless --debug
        if interrupt.received():  # e.g. KeyboardInterrupt inside a PETSc callback, re-raised as PETSc.Error
            return _interrupted(current, comm, say)
        return _internal_error(err, args, comm)


def _say_interrupted(current, say):
    run = current[0] if current else None
    if run and run.reason:
        say(f"nc_dolfinx: {run.reason}; {run.kept or 'no level was finished'}")
    else:
        say("nc_dolfinx: interrupted")


def _interrupted(current, comm, say):
    _say_interrupted(current, say)
    if comm.size > 1 and comm.rank == 0 and not isinstance(sys.exc_info()[1], interrupt.CollectiveInterrupt):
        # The other ranks carry on (see interrupt.py) and may wait in a collective for this one:
        # MPI_Finalize would wait for them. mpirun ends them once this rank has gone.
        sys.stdout.flush()
        os._exit(EXIT_INTERRUPTED)
    return EXIT_INTERRUPTED


def _internal_error(err, args, comm):
    """Print one line (a traceback with --debug) and, under MPI, abort every rank: the others may be
    waiting in a collective for this one. Rank 0 speaks first; another rank speaks only if rank 0 has
    not aborted the job within half a second (then the error is that rank's alone)."""
    if args is not None and args.debug:
        import traceback
        traceback.print_exc()
    line = f"nc_dolfinx: internal error: {type(err).__name__}: {err} (rerun with --debug for details)"
    if comm.size == 1:
        print(line, flush=True)
        return EXIT_INTERNAL
    if comm.rank != 0:
        time.sleep(0.5)
        line = line.replace("internal error:", f"internal error on rank {comm.rank}:")
    print(line, flush=True)
    sys.stderr.flush()
    comm.Abort(EXIT_INTERNAL)


def prepare_runs(args, cli_options, comm, say):
    """Every case's problem, settings and output folder, checked before the first one runs."""
    from pathlib import Path

    from .run import CaseRun
    names = args.cases or [nc.DEFAULT_CASE]
    runs, outs = [], set()
    for case in names:
        problem = nc.load_problem(case, args.set)
        changes = {"solver.preset": args.preset, "solver.load_steps": args.load_steps,  # --preset, --load-steps,
                   "output.write_every": args.write_every}                              # --write-every
        changes = {key: value for key, value in changes.items() if value is not None}
        if changes:
            problem = problem.replace(changes)
        check_path_options(problem, args)
        settings = nc.AdaptSettings.from_problem(
            problem, refine=args.refine, levels=args.levels, theta=args.theta, marking=args.marking,
            max_dofs=args.max_dofs, tol=args.tol, rtol=args.rtol)
        if args.compare_uniform and settings.refine != "adaptive":
            raise InputError(f"--compare-uniform compares with adaptive refinement, but refine = '{settings.refine}'")
        if args.out and len(names) > 1:
            out = Path(args.out) / problem.name
        else:
            out = Path(args.out or f"results/{problem.name}")
        if out.absolute() in outs:
            raise InputError(f"two cases would write to '{out}' (case '{case}' given twice?)")
        outs.add(out.absolute())
        run = CaseRun(problem, settings, out, args, cli_options, comm, say)
        run.folder.check()
        runs.append(run)
    return runs


def check_path_options(problem, args):
    """Options that a load path ([[steps]]) changes the meaning of. ``--load-steps`` (solver.load_steps)
    splits the loads of level 0's solve: on a path it would split the first increment alone, so it is
    refused there (a path's increments are [[steps]].increments). ``output.load_path_x`` must be
    ``load_time`` or a parameter the steps set."""
    steps = problem["steps"]
    if steps and problem["solver.load_steps"] != 1:
        given = "--load-steps" if args.load_steps is not None else "solver.load_steps"
        raise InputError(f"{given} = {problem['solver.load_steps']} splits the loads of a single solve, and "
                         "this problem is a load path: give its steps more increments instead "
                         "([[steps]].increments, e.g. increments = 3)")
    x = problem["output.load_path_x"]
    moved = list(dict.fromkeys(name for step in steps for name in step["set"]))
    if x != "load_time" and x not in moved:
        where = f"the parameters its steps set: {', '.join(moved)}" if moved else "it has no [[steps]]"
        raise InputError(f"output.load_path_x = '{x}' is neither 'load_time' nor a parameter of the load path "
                         f"({where})")


def run_case(run, args, comm, say):
    from ..log import logger, show_progress
    problem, settings = run.problem, run.settings
    handler = None if args.quiet else show_progress(comm=comm)
    say(f"{problem.name}: {problem.title} [{comm.size} rank(s), refine={settings.refine}, "
        f"levels={settings.levels}] -> {run.out}")
    try:
        result = run.run()
    finally:
        if handler:
            logger.removeHandler(handler)
    for quantity, computed, ref in nc.compare_with_reference(problem, result.history[-1]):
        say(f"  {quantity}: computed {computed:.5g}, reference {ref:.5g} "
            f"({100 * (computed - ref) / ref:+.2f} %)")
    say(f"  stopped: {run.reason}")
    plots = "convergence.png, load_path.png" if problem["steps"] else "convergence.png"
    say(f"  wrote {run.out}/ (summary.json, history.csv, solution.xdmf, solution.pvd, levels/, {plots}) "
        f"in {time.perf_counter() - run.start:.1f} s")
