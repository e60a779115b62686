"""The single exception type a user ever sees."""


class InputError(Exception):
    """Bad input or a failed solve, raised on every rank together: its message names the problem in one
    line (the command line prints it as ``nc_dolfinx: error: …`` and exits with status 1)."""


class UnsupportedDolfinx(ImportError):
    """The installed DOLFINx is not one nc_dolfinx runs on (raised by ``import nc_dolfinx``; the message
    names the version found and the supported ones)."""
