#!/usr/bin/env python3
"""Rewrite the problem-file key reference in README.md from nc_dolfinx/schema.py (between the markers).

    /usr/bin/python3 docs/update_readme_keys.py

tests/test_problem.py fails when the README's block differs from the schema.
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
from nc_dolfinx.problem.schema import reference_markdown  # noqa: E402

START, END = "<!-- schema:start -->", "<!-- schema:end -->"
readme = ROOT / "README.md"
text = readme.read_text()
head, rest = text.split(START)
_, tail = rest.split(END)
readme.write_text(f"{head}{START}\n{reference_markdown().strip()}\n{END}{tail}")
print(f"updated {readme}")
