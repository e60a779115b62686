#!/bin/sh
# Installs what nc_dolfinx needs on Debian trixie (DOLFINx 0.9), sid (0.11) or bookworm (0.5.2), as root,
# and nothing that is already there. The same package names serve all three releases (checked in CI, which
# runs this script in root file systems of trixie and sid: .ci/rootfs). Used by the README quickstart,
# .ci/run and the Dockerfile alike. Idempotent.
# python3-pytest-xdist: `pytest -n auto` runs the tests in as many processes as cores (CI does).
# libopenblas0-serial replaces the reference BLAS under MUMPS (LU/Cholesky about 2x faster, measured).
# python3-sphinx, python3-myst-parser, furo: the documentation site (docs/build.py); chromium, chromium-driver,
#   python3-selenium: tests/test_docs.py opens the built site in headless Chromium (pictures really render).
# python3-venv and python3-setuptools: `pip install .` into a venv on top of these packages
#   /usr/bin/python3 -m venv --system-site-packages VENV && VENV/bin/pip install --no-build-isolation .
# (tests/test_packaging.py does exactly that).
#   sh install.sh              the solver, its tests and plots
#   sh install.sh --paraview   also ParaView (pvpython) and Xvfb, to render the README picture
set -eu
PACKAGES="python3-dolfinx python3-petsc4py python3-mpi4py python3-ufl python3-gmsh python3-h5py
python3-numpy python3-scipy python3-sympy python3-matplotlib python3-pytest python3-pytest-xdist python3-hypothesis
openmpi-bin gcc python3-dev
libopenblas0-serial python3-venv python3-setuptools
python3-sphinx python3-myst-parser furo chromium chromium-driver python3-selenium"
if [ "${1:-}" = "--paraview" ]; then
    PACKAGES="$PACKAGES paraview python3-paraview xvfb xauth"
fi
if [ -r /etc/os-release ]; then
    . /etc/os-release
    case "${VERSION_CODENAME:-}" in
        bookworm|trixie|forky|sid|"") ;;
        *) echo "install.sh: Debian ${VERSION_CODENAME} is untested: nc_dolfinx is tested on bookworm, trixie and sid" ;;
    esac
fi
missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
    echo "install.sh: installing$missing"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q
    apt-get install -y -q --no-install-recommends $missing
fi
