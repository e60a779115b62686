"""The problem-file key table of the documentation, generated from the schema at build time.

    /usr/bin/python3 docs/keys.py OUT.md      # write the table (docs/build.py writes _generated/keys.md)

The user guide includes it (``{include} _generated/keys.md``): one table per section, every key with its
type, default and meaning, from the one table the TOML reader and ``Problem.from_dict`` validate against.
"""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from nc_dolfinx.problem import schema  # noqa: E402  (the one line that names where the schema lives)


def key_table():
    """The key table as MyST markdown."""
    return schema.reference_markdown().strip() + "\n"


def write(path):
    """Write the key table to ``path`` unless it already holds it (Sphinx then keeps its cached page)."""
    path = Path(path)
    text = key_table()
    if not path.is_file() or path.read_text() != text:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


if __name__ == "__main__":
    write(sys.argv[1])
