"""The user's PETSc options that no solver read, and the options in effect.

Every PETSc object reads its options from the global database (``setFromOptions``, and the factorisation
and preconditioner set-up during the first solve) and PETSc marks each option it has read;
``PetscOptionsLeftGet`` lists the unmarked ones. petsc4py 3.18 does not wrap it, so it is called through
ctypes on the very ``libpetsc`` that petsc4py has loaded (found in the process's memory map, so that a real
or complex build, whichever petsc4py uses, answers). After the first level's solve every option the solver
reads has been read: an option the user gave that is still unread was misspelt or does not apply.
"""
import ctypes

import numpy as np
from petsc4py import PETSc

from .dolfinx_versions import libpetsc
from .errors import InputError
from .solver import PREFIX

ALLOW_FLAG = "--allow-unused-petsc-options"


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
