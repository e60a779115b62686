"""The user's PETSc options: their values checked before any solve, the ones no solver read, the ones in
effect.

Values (:func:`check_petsc_option`, :func:`together`): PETSc reads an option when its object is configured
or set up and refuses a bad value with a traceback (or, for some numbers, not at all), so numbers and the
late-read type names are checked first, and what PETSc refuses while the solver is configured becomes one
line naming the user's option, on every rank together (the block comment below says which and why).

Unread names: every PETSc object reads its options from the global database (``setFromOptions``, and the
factorisation and preconditioner set-up during the first solve) and PETSc marks each option it has read;
``PetscOptionsLeftGet`` lists the unmarked ones. petsc4py 3.18 does not wrap it, so it is called through
ctypes on the very ``libpetsc`` that petsc4py has loaded (found in the process's memory map, so that a real
or complex build, whichever petsc4py uses, answers). After the first level's solve every option the solver
reads has been read: an option the user gave that is still unread was misspelt or does not apply.
"""
import ctypes
import difflib
import math
import re

import numpy as np
from petsc4py import PETSc

from .. import dolfinx_versions as versions
from ..dolfinx_versions import libpetsc
from ..errors import InputError, brief_text

PREFIX = "nc_"  # the solver's options prefix: -ksp_type on the command line is -nc_ksp_type in PETSc

ALLOW_FLAG = "--allow-unused-petsc-options"


# --- the user's PETSc option values, checked before any solve ------------------------------------------------
# PETSc reads an option when the object it belongs to is configured (setFromOptions) or set up (the first
# Krylov solve) and refuses a bad value there with a traceback, or, for some bad numbers, not at all (a
# negative snes_max_it ended PETSc 3.18's SNESSolve with "Internal error"). So the values are checked first:
# numbers (by the end of the option's name, also behind a sub-solver's prefix: ksp_rtol, mg_levels_ksp_max_it)
# and the names of the types that are read only at the set-up or not at all with the solver in force
# (pc_factor_mat_solver_type, pc_hypre_type, ksp_norm_type). What PETSc refuses beyond that (the names of
# KSP, PC, SNES and line search types, which PETSc registers per build, flags, sub-solvers) it refuses when
# the solver is configured and its set-up rehearsed (NonlinearSolver._create_snes), and the message names
# the user's option.

def _at_least(low):
    return (lambda v: v >= low), f">= {low:g}"


def _within(low, high, closed_high=False):
    return ((lambda v: low <= v <= high) if closed_high else (lambda v: low <= v < high),
            f">= {low:g} and {'<=' if closed_high else '<'} {high:g}")


ANY = (lambda v: True), ""
# name ending -> (whole number, (test, the test in words))
NUMERIC_OPTIONS = {
    "rtol": (False, _within(0, 1)), "atol": (False, _at_least(0)), "stol": (False, _at_least(0)),
    "divtol": (False, ANY), "divergence_tolerance": (False, ANY),  # (-1: no divergence test)
    "max_it": (True, _at_least(0)), "max_funcs": (True, _at_least(0)), "max_fail": (True, _at_least(0)),
    "max_linear_solve_fail": (True, _at_least(0)), "lag_jacobian": (True, ANY), "lag_preconditioner": (True, ANY),
    # Eisenstat–Walker's parameters, applied by Forcing (versions 1–3), in PETSc's ranges
    "ew_version": (True, ((lambda v: 1 <= v <= 3), "1, 2 or 3")), "ew_rtol0": (False, _within(0, 1)),
    "ew_rtolmax": (False, _within(0, 1)), "ew_gamma": (False, _within(0, 1, closed_high=True)),
    "ew_alpha": (False, ((lambda v: 0 < v <= 2), "> 0 and <= 2")), "ew_alpha2": (False, ANY),
    "ew_threshold": (False, ((lambda v: 0 < v < 1), "> 0 and < 1")),
    "gmres_restart": (True, _at_least(1)), "esteig_steps": (True, _at_least(1)),
    "boomeramg_max_iter": (True, _at_least(1)), "boomeramg_tol": (False, _at_least(0)),
    "boomeramg_strong_threshold": (False, _within(0, 1, closed_high=True)), "boomeramg_agg_nl": (True, _at_least(0)),
    "boomeramg_agg_num_paths": (True, _at_least(1)), "boomeramg_p_max": (True, _at_least(0)),
    "boomeramg_max_levels": (True, _at_least(2)), "boomeramg_truncfactor": (False, _at_least(0)),
    "gamg_agg_nsmooths": (True, _at_least(0)),
}
MUMPS_CONTROLS = {"mat_mumps_icntl_": True, "mat_mumps_cntl_": False}  # ICNTL(i) integers, CNTL(i) reals
NORM_TYPES = ("none", "preconditioned", "unpreconditioned", "natural")  # KSP.NormType's, as PETSc spells them


def _type_names(listing):
    """The names of a petsc4py type list (PETSc.KSP.Type, ...)."""
    return sorted({v for k, v in vars(listing).items() if not k.startswith("_") and isinstance(v, str)})


def _named(key, *endings):
    """Whether option ``key`` is one of ``endings`` itself or behind a sub-solver's prefix."""
    return any(key == end or key.endswith("_" + end) for end in endings)


def _shown(key, value):
    """An option as the user would write it on the command line."""
    if value is None:
        return f"-{key}"
    return f"-{key} {brief_text(str(value).lower() if isinstance(value, bool) else value)}"


def _numeric_rule(key):
    """(whole number, (test, in words)) of a numeric option, or None."""
    for start, whole in MUMPS_CONTROLS.items():
        if key.startswith(start) and key[len(start):].isdigit():
            return whole, ANY
    return next((rule for end, rule in NUMERIC_OPTIONS.items() if _named(key, end)), None)


def check_petsc_option(key, value):
    """The value of the user's PETSc option ``key`` (no dash, no prefix) as PETSc gets it, or InputError (one
    line naming the option and its value): numbers parsed (a whole number where PETSc reads an integer,
    ``1e3`` and TOML's 1000.0 included) and within the range PETSc and the solver accept; the solver type of a
    factorisation, the hypre type and the norm type one of their names."""
    lower = key.lower()
    rule = _numeric_rule(lower)
    if rule is not None:
        whole, (test, allowed) = rule
        try:
            number = float(value) if not isinstance(value, bool) and value is not None else math.nan
        except (TypeError, ValueError):
            number = math.nan
        what = f"{'a whole number' if whole else 'a number'} {allowed}".strip()
        if value is None:
            raise InputError(f"PETSc option -{key} needs a value: {what}")
        if not math.isfinite(number):
            raise InputError(f"PETSc option {_shown(key, value)}: not a number (expected {what})")
        if (whole and not number.is_integer()) or not test(number):
            raise InputError(f"PETSc option {_shown(key, value)}: must be {what}")
        return int(number) if whole else number
    names = None
    if _named(lower, "pc_factor_mat_solver_type"):
        names, what = _type_names(PETSc.Mat.SolverType), "solver type of a factorisation"
    elif _named(lower, "pc_hypre_type"):
        names, what = sorted(versions.hypre_types()), "hypre type"
    elif _named(lower, "ksp_norm_type"):
        names, what = list(NORM_TYPES), "norm type"
    if names is not None and (not isinstance(value, str) or value.lower() not in names):
        raise InputError(f"PETSc option {_shown(key, value)}: unknown {what} (known: {', '.join(names)})")
    return value


# PETSc's messages for a bad value (the value in quotes in PETSc 3.25) -> what they mean, for the user's option
_PETSC_REFUSALS = [
    (re.compile(r"Unable to find requested (?P<kind>.+?) type (?P<value>\S*)$"), None),
    (re.compile(r'Unknown option "?(?P<value>.*?)"? for -(?P<key>\S+?)\.? Available options: (?P<known>.*)$'), None),
    (re.compile(r"Input string (?P<value>.*?) has no (numeric|integer) value"), "not a number"),
    (re.compile(r"Unknown logical value: (?P<value>.*)$"), "not true or false"),
]
_TYPE_LISTS = {"KSP": ("ksp_type", lambda: _type_names(PETSc.KSP.Type)),
               "PC": ("pc_type", lambda: _type_names(PETSc.PC.Type)),
               "SNES": ("snes_type", lambda: _type_names(PETSc.SNES.Type)),
               "Line Search": ("linesearch_type", versions.line_search_types)}


def petsc_refusal(message, user, prefix=PREFIX):
    """The InputError for PETSc's ``message`` (a refusal while it read the options), naming the user's option
    it refused if the message tells which (``user``: {name: value} of the user's PETSc options), else all of
    them."""
    def given(value, ending=None):
        return [k for k, v in user.items() if v is not None and str(v).lower() == value.lower()
                and (ending is None or _named(k.lower(), ending))]

    for pattern, meaning in _PETSC_REFUSALS:
        match = pattern.search(message)
        if not match:
            continue
        value = match["value"]
        if "kind" in pattern.groupindex:  # an unknown or unbuilt type
            ending, names = _TYPE_LISTS.get(match["kind"], (None, None))
            keys = given(value, ending)
            if keys:
                known = names() if names else []
                if value in known:
                    return InputError(f"PETSc option {_shown(keys[0], user[keys[0]])}: {match['kind']} type '{value}' "
                                      "is not available in this PETSc build")
                close = difflib.get_close_matches(value, known, n=1, cutoff=0.75)
                hint = f"did you mean {close[0]}? " if close else ""
                kind = match["kind"] if match["kind"].isupper() else match["kind"].lower()  # KSP, line search
                return InputError(f"PETSc option {_shown(keys[0], user[keys[0]])}: unknown {kind} type "
                                  f"({hint}known: {', '.join(known)})")
        elif "key" in pattern.groupindex:  # a value not among the listed ones
            key = match["key"][len(prefix):] if match["key"].startswith(prefix) else match["key"]
            keys = [k for k in user if k.lower() == key.lower()]
            if keys:
                known = ", ".join(match["known"].split())
                return InputError(f"PETSc option {_shown(keys[0], user[keys[0]])}: not one of {known}")
        else:
            keys = given(value)
            if keys:
                return InputError(f"PETSc option {_shown(keys[0], user[keys[0]])}: {meaning}")
    keys = [k for k, v in user.items() if isinstance(v, str) and len(v) > 1 and re.search("[a-zA-Z]", v)
            and re.search(rf"(?<![\w.-]){re.escape(v)}(?![\w.-])", message)]
    if len(keys) == 1:
        return InputError(f"PETSc option {_shown(keys[0], user[keys[0]])}: PETSc refused it: {message}")
    options = ", ".join(_shown(k, v) for k, v in user.items())
    return InputError(f"PETSc refused the options {options}: {message}")


def together(comm, attempt, user):
    """Run ``attempt`` on every rank of ``comm``. A PETSc error on any rank is, on every rank together, an
    InputError naming the user's options (``user``; the options are the same on every rank) or, when the user
    gave none, an error of ours (re-raised)."""
    error = None
    try:
        attempt()
    except PETSc.Error as err:
        error = err
    messages = comm.allgather(None if error is None else versions.petsc_error_message(error))
    message = next((m for m in messages if m is not None), None)
    if message is None:
        return
    if user:
        raise petsc_refusal(message, user) from None
    if error is not None:
        raise error
    raise RuntimeError(f"PETSc failed on another rank: {message}")


_OPTIONS_SET = {}  # prefix -> keys set by the last call: PETSc's options database is global


def set_petsc_options(options, prefix=PREFIX):
    """Replace the options under ``prefix`` (those a previous solver set are removed first, so that one
    process can run several solvers with different settings)."""
    db = PETSc.Options(prefix)
    for key in _OPTIONS_SET.pop(prefix, ()):
        db.delValue(key)
    _OPTIONS_SET[prefix] = [key.lstrip("-") for key in options]
    for key, value in options.items():
        key = key.lstrip("-")
        if value is None or value is True:
            db[key] = None if value is None else "true"
        elif value is False:
            db[key] = "false"
        else:
            db[key] = value


def unread_options():
    """Names (without the dash, prefix included) of the options in PETSc's database that nothing read."""
    lib = libpetsc()
    count = (ctypes.c_int64 if np.dtype(PETSc.IntType).itemsize == 8 else ctypes.c_int32)(0)
    names, values = ctypes.POINTER(ctypes.c_char_p)(), ctypes.POINTER(ctypes.c_char_p)()
    args = (None, ctypes.byref(count), ctypes.byref(names), ctypes.byref(values))
    if lib.PetscOptionsLeftGet(*args) != 0:
        raise OSError("PetscOptionsLeftGet failed")
    try:
        return {names[i].decode().lower() for i in range(count.value)}
    finally:
        lib.PetscOptionsLeftRestore(*args)


def unused_user_options(user_options, prefix=PREFIX):
    """The options among ``user_options`` (names, dash optional) that no solver read; None if PETSc
    cannot be asked."""
    try:
        unread = unread_options()
    except OSError:
        return None
    return [name for name in dict.fromkeys(n.lstrip("-") for n in user_options)
            if (prefix + name).lower() in unread]


def check_user_options(user_options, allow=False):
    """Raise InputError naming the user's options that no solver read, unless ``allow``; return the
    warnings to record (unused options allowed, or a check that could not be made)."""
    unused = unused_user_options(user_options)
    if unused is None:
        return ["could not ask PETSc which options were used (PetscOptionsLeftGet): misspelt PETSc options "
                "would go unnoticed"]
    if not unused:
        return []
    names = ", ".join(f"-{name}" for name in unused)
    if not allow:
        one = len(unused) == 1
        raise InputError(f"PETSc option{'' if one else 's'} {names} {'was' if one else 'were'} not used by any "
                         f"solver (misspelt?); {ALLOW_FLAG} accepts {'it' if one else 'them'}")
    return [f"PETSc option{'s' if len(unused) > 1 else ''} {names} not used by any solver (allowed by "
            f"{ALLOW_FLAG})"]


def options_in_effect(prefix=PREFIX):
    """{name: value} of the options set under ``prefix`` now (the solver's, with the prefix stripped)."""
    return {name[len(prefix):]: value for name, value in sorted(PETSc.Options().getAll().items())
            if name.startswith(prefix)}
