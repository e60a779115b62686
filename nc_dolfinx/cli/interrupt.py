"""Ctrl-C and SIGTERM: stop a run cleanly, keeping the levels it has finished.

Serially, SIGINT (Ctrl-C) and SIGTERM raise ``KeyboardInterrupt`` where the program is. Under mpirun,
Open MPI turns Ctrl-C into SIGTERM to every rank and sends SIGKILL one second later (MCA parameter
``odls_base_sigkill_timeout``; checked with Open MPI 4.1). Were every rank to stop at once, rank 0 could be
left inside a collective that another rank no longer enters, and be killed before it had marked the
summary. So rank 0 alone stops at once: it records the interruption, removes staging files and leaves
without ``MPI_Finalize`` from inside its signal handler (``leave``), and mpirun then ends the other ranks,
which only note the signal and carry on meanwhile. Rank 0 must not raise instead: an exception raised in a
PETSc callback (a line search's pre-check, say) unwinds through PETSc while the other ranks wait in the
same solve's next reduction, and both then sit there until the SIGKILL (seen under load: the summary left
at 'running'). A signal that reaches some ranks only (``kill PID``) is noticed by all ranks together at the
next level (:func:`check`).
"""
import signal
import sys

from mpi4py import MPI

_SIGNALS = (signal.SIGINT, signal.SIGTERM)
_received = []


class CollectiveInterrupt(KeyboardInterrupt):
    """Raised on every rank together by :func:`check`: the ranks may still finish collectively."""


def install(comm, leave=None):
    """Handle SIGINT and SIGTERM as described above; returns the previous handlers (for :func:`restore`).
    ``leave(signal_name)``, called by rank 0 of a parallel run, records the interruption and must not
    return (``os._exit``); serially the signal raises :class:`KeyboardInterrupt` where the program is."""
    _received.clear()

    def handler(signum, frame):
        _received.append(signum)
        if comm.rank == 0:
            ignore()  # mpirun may signal again while rank 0 cleans up: that must not interrupt the cleanup
            if comm.size > 1 and leave is not None:
                leave(signal.Signals(signum).name)
            raise KeyboardInterrupt(signal.Signals(signum).name)

    _initialise_libraries_that_set_signals()
    previous = {sig: signal.getsignal(sig) for sig in _SIGNALS}
    for sig in _SIGNALS:
        signal.signal(sig, handler)
    previous["unraisable"] = _unraisable_before[0] = sys.unraisablehook
    sys.unraisablehook = _quiet_about_swallowed_interrupts
    gmsh = sys.modules.get("gmsh")
    if gmsh is not None and hasattr(gmsh, "oldsig"):
        gmsh.oldsig = handler  # gmsh.finalize() restores the SIGINT handler seen at import: ours
    return previous


def _initialise_libraries_that_set_signals():
    """PETSc installs C signal handlers when initialised: that must happen before ours are installed.
    gmsh is not imported here (0.4 s a run without gmsh need not pay): nc_dolfinx imports it on first use
    and keeps the handler in place through the import and each session (``mesh.gmsh_io.gmsh_session``)."""
    from petsc4py import PETSc  # noqa: F401


def _quiet_about_swallowed_interrupts(unraisable):
    """A signal that arrives while Python runs a finaliser or a weakref callback raises our
    KeyboardInterrupt there, where Python cannot raise it: it prints "Exception ignored in …" with a
    traceback (seen once in a full test run on 2 busy cores). The signal is recorded, and :func:`check`
    (at the next level) or the next one stops the run: the print is noise."""
    if issubclass(unraisable.exc_type, KeyboardInterrupt) and _received:
        return
    _unraisable_before[0](unraisable)


_unraisable_before = [sys.__unraisablehook__]


def restore(previous):
    previous = dict(previous)
    sys.unraisablehook = previous.pop("unraisable", sys.__unraisablehook__)
    for sig, handler in previous.items():
        signal.signal(sig, handler)


def ignore():
    for sig in _SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


def received():
    """The name of the first signal this rank received (None if none)."""
    return signal.Signals(_received[0]).name if _received else None


def check(comm):
    """Collective: raise :class:`CollectiveInterrupt` on every rank if any rank has been signalled."""
    if comm.allreduce(received(), MPI.LOR):
        ignore()
        raise CollectiveInterrupt("signal")
