"""What a result was computed with: versions of the stack and the command line."""
import importlib
import importlib.util
import os
import platform
import re
import sys

PACKAGES = ("nc_dolfinx", "dolfinx", "petsc4py", "mpi4py", "ufl", "ffcx", "basix", "gmsh", "numpy")
# Packages whose version is read from a variable of their source while a run has not imported them: gmsh's
# import takes 0.4 s, and Debian's python3-gmsh has no package metadata.
VERSION_IN_SOURCE = {"gmsh": "GMSH_API_VERSION"}


def _version(module_name):
    if module_name in VERSION_IN_SOURCE and module_name not in sys.modules:
        return _version_from_source(module_name, VERSION_IN_SOURCE[module_name])
    try:
        module = importlib.import_module(module_name)
    except Exception:  # a missing or broken optional package is recorded, not fatal
        return None
    version = getattr(module, "__version__", None)
    if version is None:
        from importlib import metadata
        try:
            version = metadata.version(module_name)
        except metadata.PackageNotFoundError:
            return None
    return str(version)


def _version_from_source(module_name, variable):
    """The string assigned to ``variable`` at the start of a line of the module's source (``GMSH_API_VERSION
    = "4.8.0"``), without importing it."""
    try:
        spec = importlib.util.find_spec(module_name)
        with open(spec.origin, encoding="utf-8", errors="replace") as source:
            found = re.search(rf'^{variable}\s*=\s*["\']([^"\']+)', source.read(), re.MULTILINE)
    except Exception:  # not installed, or not a source file: recorded as missing, not fatal
        return None
    return found.group(1) if found else None


def versions():
    """{package: version} of the stack, PETSc and the MPI library included."""
    from mpi4py import MPI
    from petsc4py import PETSc
    found = {name: _version(name) for name in PACKAGES}
    found["petsc"] = ".".join(map(str, PETSc.Sys.getVersion()))
    found["mpi"] = MPI.Get_library_version().splitlines()[0].strip("\x00 ")
    found["python"] = platform.python_version()
    return found


def command_line(comm):
    """The command as given (``sys.argv``), the interpreter, the working directory and the ranks."""
    return {"argv": list(sys.argv), "executable": sys.executable, "cwd": os.getcwd(), "ranks": comm.size}
