"""Logging: progress goes to the ``nc_dolfinx`` logger; compiler chatter is silenced unless asked for.

When FFCx compiles a form, setuptools logs every compiler command at INFO on the *root* logger (and
resets its level), so any program that imports DOLFINx prints ``INFO:root: x86_64-linux-gnu-gcc …`` lines.
Importing nc_dolfinx installs a filter on the root logger that drops INFO and DEBUG records coming from
setuptools, distutils, FFCx and UFL only; everything else, your own root logging included, passes.
"""
import logging
import sys

logger = logging.getLogger("nc_dolfinx")
_BUILD_TOOLS = ("/setuptools/", "/distutils/", "/ffcx/", "/ufl/", "/_distutils/")


class _QuietBuildTools(logging.Filter):
    def filter(self, record):
        return record.levelno >= logging.WARNING or not any(t in record.pathname for t in _BUILD_TOOLS)


_FILTER = _QuietBuildTools()


def quiet_compilers(quiet=True):
    """Drop (``True``, the default on import) or show (``False``) the INFO lines that FFCx, UFL and
    setuptools log on the root logger while compiling forms; warnings always pass."""
    root = logging.getLogger()
    if quiet:
        if _FILTER not in root.filters:
            root.addFilter(_FILTER)
    else:
        root.removeFilter(_FILTER)


def show_progress(stream=sys.stdout, level=logging.INFO, comm=None):
    """Print the ``nc_dolfinx`` logger's records (one line per level of the loop) on rank 0 of ``comm``
    (COMM_WORLD by default). Returns the handler (``logger.removeHandler`` undoes it)."""
    from mpi4py import MPI
    handler = logging.StreamHandler(stream)
    handler.setFormatter(logging.Formatter("%(message)s"))
    if (comm or MPI.COMM_WORLD).rank != 0:
        handler.addFilter(lambda record: False)
    logger.addHandler(handler)
    logger.setLevel(level)
    logger.propagate = False
    return handler
