"""Sphinx configuration of the nc_dolfinx documentation site.

Build it with ``/usr/bin/python3 docs/build.py`` (not sphinx-build directly): the build copies docs/src into
a staging directory, generates the key table, the demo pages and the verification report there, and runs
sphinx-build with ``-c docs/src`` (this file) and ``-W``.
"""
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
os.environ.setdefault("OMP_NUM_THREADS", "1")

import nc_dolfinx  # noqa: E402

# The API page documents every public name as ``nc_dolfinx.NAME``, never by the module that defines it.
# The one public module, nc_dolfinx.dolfinx_versions, is documented by that name too: registering it under
# that name keeps ``automodule`` working wherever the package keeps the module.
sys.modules.setdefault("nc_dolfinx.dolfinx_versions", nc_dolfinx.dolfinx_versions)

project = "nc_dolfinx"
author = "nc_dolfinx authors"
copyright = "nc_dolfinx authors"
version = release = nc_dolfinx.__version__

# No napoleon: the docstrings are prose (reST roles and literals), and napoleon would read "the X: ..." in an
# attribute's docstring as a type.
extensions = ["myst_parser", "sphinx.ext.autodoc", "sphinx.ext.mathjax"]
source_suffix = {".md": "markdown"}
root_doc = "index"
# _generated/ holds files that pages include (the key table, the verification report): not pages themselves
exclude_patterns = ["_generated", "_build", "Thumbs.db", ".DS_Store"]

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3          # [text](#a-heading) links within a page

autodoc_member_order = "bysource"
autodoc_typehints = "signature"

html_theme = "furo"
html_title = f"nc_dolfinx {release}"
html_show_sourcelink = False
