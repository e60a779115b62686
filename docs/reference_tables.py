"""The reference tables of the documentation, generated at build time from the tables the code uses.

    /usr/bin/python3 docs/reference_tables.py FOLDER   # write FOLDER/keys.md and FOLDER/columns.md

The reference pages include them (docs/src/reference/keys.md: ``{include} ../_generated/keys.md``;
reference/output.md: ``../_generated/columns.md``):
- ``keys.md``: one table per problem-file section, every key with its type, default and meaning, from the
  one table the TOML reader and ``Problem.from_dict`` validate against (``nc_dolfinx.problem.schema``),
  and one example of it: the first place it is set in a tutorial's problem file (docs/src/tutorials) or a
  built-in case (nc_dolfinx/cases), else docs/key_examples.toml, written as a TOML line;
- ``columns.md``: every output column and field with its meaning and the sign conventions, from the one
  table ``summary.json`` is written from (``nc_dolfinx.output.columns``).
"""
import json
import re
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
from nc_dolfinx.output import columns  # noqa: E402  (where the tables live: the only lines naming them)
from nc_dolfinx.problem import schema  # noqa: E402


ROOT = Path(__file__).resolve().parent.parent
ARRAYS = ("steps", "pairs")  # arrays of tables: their keys are written inside a [[steps]] or [[pairs]] table
LONGEST = 70                 # characters of an example's value; a longer value is passed over for the next


def _toml(value):
    """A value as TOML (the subset problem files use)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + " }"
    return repr(value)


def _flatten(table, prefix=()):
    """(path, value) of every key of a TOML document, tables included; an array of tables' entries under
    its own name."""
    for key, value in table.items():
        path = prefix + (key,)
        yield path, value
        if isinstance(value, dict):
            yield from _flatten(value, path)
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for entry in value:
                yield from _flatten(entry, path)


def _sources():
    """(name, parsed TOML) of the tutorials' problem files, then the built-in cases'."""
    try:
        import tomllib
    except ImportError:  # Python < 3.11 (bookworm): the reader nc_dolfinx itself uses
        import tomli as tomllib
    for page in sorted((ROOT / "docs" / "src" / "tutorials").glob("*.md")):
        for name, body in re.findall(r"```\{code-block\} toml\n:caption: (\S+)\n\n(.*?)\n```", page.read_text(), re.S):
            yield f"tutorial {page.stem}: {name}", tomllib.loads(body)
    for case in sorted((ROOT / "nc_dolfinx" / "cases").glob("*.toml")):
        yield f"case {case.stem}", tomllib.loads(case.read_text())
    yield "docs/key_examples.toml", tomllib.loads((ROOT / "docs" / "key_examples.toml").read_text())


def examples():
    """{schema key (``mesh.shapes.*.circle.radius``): (TOML line, where it comes from)}."""
    found = {}
    for where, document in _sources():
        for path, value in _flatten(document):
            line = f"{'.'.join(path[1:]) if path[0] in ARRAYS else '.'.join(path)} = {_toml(value)}"
            if len(_toml(value)) > LONGEST:
                continue
            if path[0] in ARRAYS:
                line = f"[[{path[0]}]] {line}"
            for k in range(1 << len(path)):  # every way of writing components as *
                key = ".".join("*" if k >> i & 1 else part for i, part in enumerate(path))
                found.setdefault(key, (line, where))
    return found


def key_table():
    """The problem-file key table as MyST markdown, with an example of each key."""
    table, known = schema.reference_markdown().strip(), examples()
    out = []
    for line in table.splitlines():
        row = re.match(r"^\| `([^`]+)` \|", line)
        if line.startswith("| key |"):
            line += " example |"
        elif line.startswith("|---"):
            line += "---|"
        elif row:
            example = known.get(row.group(1))
            where = "" if example and example[1].startswith("docs/") else f" ({example[1]})" if example else ""
            line += f" `{example[0]}`{where} |" if example else " – |"
        out.append(line)
    return "\n".join(out) + "\n"


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
