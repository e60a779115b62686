"""Write docs/api.md, the API reference of nc_dolfinx, from the docstrings of the names in ``__all__``.

    /usr/bin/python3 docs/make_api.py            # rewrite docs/api.md
    /usr/bin/python3 docs/make_api.py --check    # exit 1 if docs/api.md is not what this script writes

Each public name is listed in its group with its signature and docstring; a class also lists its public
methods and properties. A constant's docstring is the string literal that follows its assignment in
``nc_dolfinx/__init__.py`` (the Sphinx convention). Names that no group below claims are listed under
"Other names", so a name added to ``__all__`` appears after a rerun without editing this file.
``tests/test_api.py`` checks that the committed page is the generated one.
"""
import ast
import dataclasses
import inspect
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import nc_dolfinx as nc  # noqa: E402

OUTPUT = ROOT / "docs" / "api.md"
GROUPS = [
    ("Problems", "A problem of the paper's §2 — model (1)–(4) and its data — validated and independent of "
                 "any mesh: from a built-in case, a TOML file or a dict.",
     ["Problem", "load_problem", "case_names", "case_titles", "case_path", "DEFAULT_CASE"]),
    ("Meshes", "A `Domain` is a DOLFINx mesh with named boundary groups (Γ_D, Γ_N, Γ_C, symmetry planes) and "
               "material regions, kept through refinement. 2D triangles and 3D tetrahedra.",
     ["Domain", "build_domain", "rectangle", "box", "from_gmsh", "from_gmsh_model", "from_dolfinx"]),
    ("Solving", "Bind a problem to a mesh and solve the discrete problem (7).",
     ["Fields", "bind", "Solution", "solve"]),
    ("Estimating, marking, refining", "One step of SOLVE → ESTIMATE → MARK → REFINE by hand: the "
                                      "indicators of Definition 5, Dörfler marking, refinement and the "
                                      "transfer of the solution to the refined mesh.",
     ["Estimate", "estimate", "mark", "refine", "transfer"]),
    ("The adaptive loop", "All levels at once, with a callback per level.",
     ["AdaptSettings", "Level", "Result", "adapt"]),
    ("Quantities", "Numbers and UFL expressions of a solution: the law (4), stresses, forces, errors, and the "
                   "building blocks of the estimator; closed-form Hertz references.",
     ["solution_quantities", "errors", "integrate", "contact_projection", "lame", "sigma", "normal_stress",
      "contact_pressure", "contact_measure", "assemble_cellwise", "patch_sum", "hertz_line_contact", "compare_with_reference",
      "hertz_sphere_contact"]),
    ("Utilities", "Errors, logging, constants, and what differs between the supported DOLFINx versions.",
     ["InputError", "UnsupportedDolfinx", "dolfinx_versions", "quiet_compilers", "show_progress",
      "QUADRATURE_DEGREES"]),
]
OTHER = "Other names"


def grouped_names():
    """[(title, intro, names)] over every name of ``__all__`` (unclaimed names in OTHER)."""
    claimed = {name for _, _, names in GROUPS for name in names}
    groups = [(title, intro, [n for n in names if n in nc.__all__]) for title, intro, names in GROUPS]
    other = [n for n in nc.__all__ if n not in claimed]
    return groups + ([(OTHER, "Public names not yet placed in a group by docs/make_api.py.", other)]
                     if other else [])


# --- docstrings ---------------------------------------------------------------------------------------

def constant_docstrings(module_file):
    """{name: docstring} of the ``NAME = …`` assignments followed by a string literal in ``module_file``."""
    body = ast.parse(Path(module_file).read_text()).body
    docs = {}
    for statement, following in zip(body, body[1:]):
        if (isinstance(statement, ast.Assign) and isinstance(following, ast.Expr)
                and isinstance(following.value, ast.Constant) and isinstance(following.value.value, str)):
            for target in statement.targets:
                if isinstance(target, ast.Name):
                    docs[target.id] = inspect.cleandoc(following.value.value)
    return docs


def own_docstring(obj):
    """The docstring written for ``obj`` itself: not inherited, not the one dataclasses generate."""
    doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else getattr(obj, "__doc__", None)
    if not doc:
        return None
    if inspect.isclass(obj) and dataclasses.is_dataclass(obj) and doc.startswith(f"{obj.__name__}("):
        return None  # dataclasses write "Name(field, ...)" when the class has no docstring
    return inspect.cleandoc(doc)


def docstring(name):
    """The docstring of a public name (a constant's from ``__init__.py``), or None."""
    obj = getattr(nc, name)
    if inspect.isclass(obj) or callable(obj) or inspect.ismodule(obj):
        return own_docstring(obj)
    return constant_docstrings(nc.__file__).get(name)


def markdown(doc):
    """Docstring (reST-flavoured) to Markdown: roles and ``literals`` to code, indented blocks and
    doctests to code blocks."""
    doc = re.sub(r":(?:func|class|meth|mod|attr|data):`~?([\w.]+)`",
                 lambda m: f"`{m.group(1).split('.')[-1] if '~' in m.group(0) else m.group(1)}`", doc)
    doc = re.sub(r"``(.+?)``", r"`\1`", doc)
    out, block = [], False
    for line in doc.splitlines():
        code = line.startswith("    ") or line.startswith(">>>")
        if code and not block:
            out += ["", "```"] if out and out[-1] else ["```"]
            block = True
        elif not code and block and line.strip():
            while not out[-1].strip():
                out.pop()
            out += ["```", ""]
            block = False
        out.append(line[4:] if code and line.startswith("    ") else line)
    if block:
        while out and not out[-1].strip():
            out.pop()
        out.append("```")
    return "\n".join(out).strip()


# --- signatures ---------------------------------------------------------------------------------------

def signature(name, obj):
    if inspect.isclass(obj):
        kind = "exception" if issubclass(obj, Exception) else "class"
        try:
            return f"{kind} {name}{inspect.signature(obj)}".removesuffix(" -> None")
        except (TypeError, ValueError):
            return f"{kind} {name}"
    if callable(obj):
        return f"{name}{inspect.signature(obj)}"
    if inspect.ismodule(obj):
        return f"module {obj.__name__}"
    return f"{name} = {obj!r}"


def members(cls):
    """Public methods and properties defined by ``cls`` itself, as (heading, docstring)."""
    rows = []
    for attr, value in cls.__dict__.items():
        if attr.startswith("_") and attr != "__getitem__":
            continue
        if isinstance(value, property):
            rows.append((f"{cls.__name__}.{attr}", value.__doc__))
        elif isinstance(value, (classmethod, staticmethod)):
            rows.append((f"{cls.__name__}.{attr}{inspect.signature(value.__func__)}".replace("(cls, ", "(")
                         .replace("(cls)", "()"), value.__func__.__doc__))
        elif inspect.isfunction(value):
            text = f"{cls.__name__}.{attr}{inspect.signature(value)}".replace("(self, ", "(").replace("(self)", "()")
            if attr == "__getitem__":
                text = f"{cls.__name__.lower()}[key]"
            rows.append((text, value.__doc__))
    return rows


def entry(name):
    obj = getattr(nc, name)
    lines = [f"### `{name}`", "", "```python", signature(name, obj), "```", ""]
    doc = docstring(name)
    lines += [markdown(doc) if doc else "*(no docstring)*", ""]
    if inspect.isclass(obj) and not issubclass(obj, Exception):
        rows = members(obj)
        if rows:
            lines += ["Members:", ""]
            for heading, text in rows:
                summary = markdown(inspect.cleandoc(text)).replace("\n", "\n  ") if text else ""
                lines.append(f"- `{heading}`" + (f" — {summary}" if summary else ""))
            lines.append("")
    return lines


def anchor(title):
    return re.sub(r"[^\w\- ]", "", title.lower()).replace(" ", "-")


def render():
    """The text of docs/api.md."""
    lines = ["# nc_dolfinx API reference", "",
             f"*Generated from the docstrings of nc_dolfinx {nc.__version__} by `docs/make_api.py`; do not edit: "
             "rerun `/usr/bin/python3 docs/make_api.py` after changing a public docstring. "
             "Equation and definition numbers refer to Fernández & Hild, "
             "\"A posteriori error analysis for the normal compliance problem\". "
             "Literate examples: [demos/](../demos/).*", "",
             "```python", "import nc_dolfinx as nc", "```", "",
             markdown(inspect.cleandoc(nc.__doc__)), ""]
    groups = grouped_names()
    lines += ["## Contents", ""]
    for title, _, names in groups:
        lines.append(f"- [{title}](#{anchor(title)}): " + ", ".join(f"`{n}`" for n in names))
    lines.append("")
    for title, intro, names in groups:
        lines += [f"## {title}", "", intro, ""]
        for name in names:
            lines += entry(name)
    # Python 3.13 names pathlib's classes after their private module: the page is the same on every Python
    return "\n".join(lines).rstrip().replace("pathlib._local.", "pathlib.") + "\n"


def main(argv):
    text = render()
    if "--check" in argv:
        if not OUTPUT.is_file() or OUTPUT.read_text() != text:
            print(f"{OUTPUT.relative_to(ROOT)} is out of date: run /usr/bin/python3 docs/make_api.py")
            return 1
        return 0
    OUTPUT.write_text(text)
    print(f"wrote {OUTPUT.relative_to(ROOT)} ({len(nc.__all__)} names)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
