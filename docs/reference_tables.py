"""The reference tables of the documentation, generated at build time from the tables the code uses.

    /usr/bin/python3 docs/reference_tables.py FOLDER   # write FOLDER/keys.md and FOLDER/columns.md

The user guide includes them (``{include} _generated/keys.md`` and ``_generated/columns.md``):
- ``keys.md``: one table per problem-file section, every key with its type, default and meaning, from the
  one table the TOML reader and ``Problem.from_dict`` validate against (``nc_dolfinx.problem.schema``);
- ``columns.md``: every output column and field with its meaning and the sign conventions, from the one
  table ``summary.json`` is written from (``nc_dolfinx.output.columns``).
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from nc_dolfinx.output import columns  # noqa: E402  (where the tables live: the only lines naming them)
from nc_dolfinx.problem import schema  # noqa: E402


def key_table():
    """The problem-file key table as MyST markdown."""
    return schema.reference_markdown().strip() + "\n"


def column_table():
    """The output columns, fields and sign conventions as MyST markdown."""
    return columns.markdown()


def write(folder):
    """Write both tables into ``folder``, each only if it changed (Sphinx then keeps its cached pages)."""
    for name, text in (("keys.md", key_table()), ("columns.md", column_table())):
        path = Path(folder) / name
        if not path.is_file() or path.read_text() != text:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)


if __name__ == "__main__":
    write(sys.argv[1])
