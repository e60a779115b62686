"""The problem-file schema: every key with its type, meaning, whether it is required and its default.

One table (:data:`KEYS`) serves the TOML reader, the ``--set`` overrides, :meth:`Problem.from_dict` and the
key reference in the README (:func:`reference_markdown`; ``docs/update_readme_keys.py`` rewrites it there). Nothing about the physics has a
silent default: E, ν, c_n and m_n are required, unknown sections and keys are errors that name the key
(with a "did you mean" suggestion), and loads default to zero only where the reference says so.

A key path ``a.*.b`` matches any name in place of ``*`` (material regions, Neumann groups of a traction
table, parameters, PETSc options).
"""
import difflib
import math
from dataclasses import dataclass

from ..errors import InputError, brief, brief_text
from . import expressions

REQUIRED = object()  # the default of a required key
NONE = None          # the default of an optional key that is simply absent


@dataclass(frozen=True)
class Key:
    path: str
    kind: str
    doc: str
    default: object = NONE
    choices: tuple = ()
    check: object = None  # (value) -> error text or None

    @property
    def required(self):
        return self.default is REQUIRED


def _positive(v):
    return None if v > 0 else "must be > 0"


def _at_least_one(v):
    return None if v >= 1 else "must be >= 1"


def _non_negative(v):
    return None if v >= 0 else "must be >= 0"


def _poisson(v):
    return None if -1 < v < 0.5 else "must lie in (-1, 0.5)"


def _fraction(v):
    return None if 0 < v <= 1 else "must lie in (0, 1]"


def _at_most(limit, why):
    """A check: value <= limit (larger values could only exhaust the machine)."""
    return lambda v: None if v <= limit else f"must be <= {limit} ({why})"


def _all(*checks):
    return lambda v: next((text for text in (check(v) for check in checks) if text), None)


def _title(v):
    if len(v) > MAX_TITLE or not v.isprintable():
        return f"must be one printable line of at most {MAX_TITLE} characters"
    return None


MAX_TITLE = 200        # characters of a title (one line: it heads the plot and the summary)
MAX_NAME = 200         # characters of a group, region, parameter or option name
MAX_LEVELS = 1000
MAX_LOAD_STEPS = 10000
MAX_QUADRATURE_DEGREE = 30


KEYS = [
    Key("title", "string", f"one line naming the problem, at most {MAX_TITLE} characters (default: the file's "
        "name)", check=_title),
    Key("description", "string", "free text"),
    Key("parameters.*", "number", "a named number, or an expression of the parameters above it; usable in "
        "every expression and number of the file"),
    # [mesh]
    Key("mesh.file", "string", "gmsh `.msh` file (linear triangles in 2D, tetrahedra in 3D) with physical "
        "groups, relative to the problem file; one of `file`, `rectangle`, `box` (or none, when the Python API is given "
        "the mesh as a Domain)"),
    Key("mesh.rectangle", "corners", "built-in 2D mesh `[[x0, y0], [x1, y1]]` with the groups "
        "`left`/`right` (x = x0/x1), `bottom`/`top` (y = y0/y1)"),
    Key("mesh.box", "corners", "built-in 3D tetrahedral mesh `[[x0, y0, z0], [x1, y1, z1]]` with the "
        "groups `left`/`right` (x), `front`/`back` (y), `bottom`/`top` (z)"),
    Key("mesh.cells", "cells", "cells per direction of `rectangle` (2 numbers) or `box` (3 numbers); "
        "required with them"),
    Key("mesh.diagonal", "choice", "diagonal of the rectangle's cells", "right",
        ("left", "right", "crossed", "left_right", "right_left")),
    Key("mesh.dirichlet", "groups", "boundary groups (names or integer tags) of Γ_D, clamped (u = 0)",
        REQUIRED),
    Key("mesh.contact", "groups", "boundary groups of Γ_C, on the foundation", REQUIRED),
    Key("mesh.neumann", "groups", "boundary groups of Γ_N with a traction g; a boundary facet in no group, "
        "or in a group in no role, is Γ_N with g = 0 (a group in no role is named in a warning)", []),
    Key("mesh.symmetry", "groups", "boundary groups on a symmetry plane normal to a coordinate axis: "
        "u·ν = 0, tangential traction free", []),
    # [material]
    Key("material.E", "number", "Young's modulus E > 0", REQUIRED, check=_positive),
    Key("material.nu", "number", "Poisson's ratio ν in (−1, 0.5)", REQUIRED, check=_poisson),
    Key("material.regions.*.E", "number", "E of a cell group (material region) of the mesh", REQUIRED,
        check=_positive),
    Key("material.regions.*.nu", "number", "ν of that cell group", REQUIRED, check=_poisson),
    # [loads]
    Key("loads.f", "vector", "body force f, one expression per coordinate (default: none)"),
    Key("loads.g", "traction", "traction g on Γ_N: one vector for every listed `neumann` group, or a table "
        "`{group = [...]}` (default: none)"),
    Key("loads.g.*", "vector", "traction on one `neumann` group"),
    Key("loads.from_exact", "boolean", "f = −div σ(u), g = σ(u)ν from `[exact] u` (instead of f and g)",
        False),
    # [contact]
    Key("contact.c_n", "expression", "foundation stiffness c_n ≥ 0 of the law σ_n = −c_n (u_n − g_0)_+^m_n "
        "(a number or an expression of the coordinates)", REQUIRED),
    Key("contact.m_n", "number", "exponent m_n ≥ 1 of the law (≤ 3 in 3D)", REQUIRED, check=_at_least_one),
    Key("contact.gap", "expression", "initial normal gap g_0 ≥ 0 (0: the paper's setting)", 0.0),
    # [exact]
    Key("exact.u", "vector", "exact displacement: errors and effectivity indices are reported"),
    # [adapt]
    Key("adapt.refine", "choice", "refinement between levels", "none", ("none", "uniform", "adaptive")),
    Key("adapt.levels", "integer", "number of levels (solves) with `uniform`/`adaptive`", 6,
        check=_all(_at_least_one, _at_most(MAX_LEVELS, "levels, each a solve"))),
    Key("adapt.theta", "number", "marking parameter θ in (0, 1] (`adaptive` only)", 0.5, check=_fraction),
    Key("adapt.marking", "choice", "marking strategy (`adaptive` only)", "doerfler", ("doerfler", "maximum")),
    Key("adapt.max_dofs", "integer", "stop once a level has this many dofs (default: no limit)",
        check=_at_least_one),
    Key("adapt.tol", "number", "stop once η ≤ tol (default: none)", check=_positive),
    Key("adapt.rtol", "number", "stop once η ≤ rtol·η(level 0) (default: none)", check=_positive),
    # [solver]
    Key("solver.preset", "choice", "linear solver inside Newton: chosen from the problem (`auto`), MUMPS "
        "Cholesky (`direct`) or BoomerAMG (`iterative`)", "auto", ("auto", "direct", "iterative")),
    Key("solver.preconditioner_matrix", "choice", "matrix the preconditioner is built from", "auto",
        ("auto", "bulk", "jacobian")),
    Key("solver.load_steps", "integer", "load increments on level 0", 1,
        check=_all(_at_least_one, _at_most(MAX_LOAD_STEPS, "increments, each a solve"))),
    Key("solver.petsc_options", "table", "PETSc options under the solver's prefix, e.g. "
        "`{ snes_rtol = 1e-12 }`; the command line's `-options` win", {}),
    Key("solver.petsc_options.*", "option", "one PETSc option (name without the dash)"),
    # [estimator]
    Key("estimator.contact_quadrature_degree", "integer", "Gauss degree of the Γ_C terms of η", NONE,
        check=_all(_at_least_one, _at_most(MAX_QUADRATURE_DEGREE, "a Gauss rule's degree"))),
    Key("estimator.cell_quadrature_degree", "integer", "Gauss degree of the cell and Γ_N terms of η and ζ",
        NONE, check=_all(_at_least_one, _at_most(MAX_QUADRATURE_DEGREE, "a Gauss rule's degree"))),
    # [reference]
    Key("reference.hertz", "choice", "print Hertz's contact size and peak pressure beside the computed ones: "
        "`line` (2D, a cylinder) or `sphere` (3D)", NONE, ("line", "sphere")),
    Key("reference.radius", "number", "radius R of the Hertz body", NONE, check=_positive),
    Key("reference.model_fraction", "number", "the part of the body that is modelled (0.25 for a quarter "
        "model): the Hertz force is the computed resultant divided by it", 1.0, check=_fraction),
]
SECTIONS = ("title", "description", "parameters", "mesh", "material", "loads", "contact", "exact", "adapt",
            "solver", "estimator", "reference")
_BY_PATH = {key.path: key for key in KEYS}
ROLES = ("dirichlet", "neumann", "contact", "symmetry")


def find_key(path):
    """The Key for a dotted path (``*`` entries match any name), or None."""
    if path in _BY_PATH:
        return _BY_PATH[path]
    parts = path.split(".")
    for key in KEYS:
        pattern = key.path.split(".")
        if len(pattern) == len(parts) and all(p in ("*", q) for p, q in zip(pattern, parts)):
            return key
    return None


def _suggest(name, candidates, show="{}"):
    close = difflib.get_close_matches(name, list(candidates), n=1, cutoff=0.6)
    if close:
        return f" (did you mean '{show.format(close[0])}'?)"
    return f" (known: {', '.join(show.format(c) for c in sorted(candidates))})" if candidates else ""


def _matches(pattern, parts):
    return len(pattern) == len(parts) and all(p in ("*", q) for p, q in zip(pattern, parts))


def _keys_below(prefix):
    """The keys one level below the table ``prefix`` (wildcards in the keys match any name)."""
    parts = prefix.split(".")
    return [k for k in KEYS if len(k.path.split(".")) == len(parts) + 1
            and _matches(k.path.split(".")[:-1], parts)]


def _children(prefix):
    """Names allowed directly below a table path (for suggestions)."""
    parts = prefix.split(".")
    below = {k.path.split(".")[len(parts)] for k in KEYS
             if len(k.path.split(".")) > len(parts) and _matches(k.path.split(".")[:len(parts)], parts)}
    return below - {"*"}


# --- one value of each kind ---------------------------------------------------------------------------

def _number(value, where, parameters):
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"{where} must be a number, got {brief(value)}")
    if not _finite_number(value):
        raise InputError(f"{where} must be a finite number, got {brief(value)}")
    with _naming(where):
        if isinstance(value, str) and expressions.uses_coordinates(value):
            raise InputError(f"must be a number (it cannot depend on the coordinates), got '{value}'")
        return expressions.to_float(value, parameters)


def _expression(value, where, parameters):
    if isinstance(value, bool) or not isinstance(value, (int, float, str)):
        raise InputError(f"{where} must be a number or an expression string, got {brief(value)}")
    if not _finite_number(value):
        raise InputError(f"{where} must be a finite number, got {brief(value)}")
    with _naming(where):
        expressions.check(value, parameters)
    return value


def _finite_number(value):
    """A string (an expression: checked where it is evaluated), or a number a float holds finitely
    (a TOML integer may have any number of digits)."""
    if isinstance(value, str):
        return True
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


class _naming:
    """Prefix the InputError raised inside with the key it concerns."""

    def __init__(self, where):
        self.where = where

    def __enter__(self):
        return self

    def __exit__(self, kind, err, tb):
        if isinstance(err, InputError) and not str(err).startswith(self.where):
            raise InputError(f"{self.where}: {err}") from None
        return False


def _vector(value, where, parameters):
    if not isinstance(value, list) or len(value) not in (2, 3):
        raise InputError(f"{where} must be a list of 2 (2D) or 3 (3D) expressions, got {brief(value)}")
    return [_expression(v, f"{where}[{i}]", parameters) for i, v in enumerate(value)]


def _groups(value, where, _):
    value = [value] if isinstance(value, (str, int)) and not isinstance(value, bool) else value
    if not isinstance(value, list) or not all(isinstance(v, (str, int)) and not isinstance(v, bool)
                                              for v in value):
        raise InputError(f"{where} must be a list of group names or integer tags, got {brief(value)}")
    for group in value:
        if isinstance(group, str) and not _is_name(group):
            raise InputError(f"{where}: group name {brief(group)} must be printable and at most {MAX_NAME} "
                             "characters")
        if isinstance(group, int) and not 0 < group < 2**31:
            raise InputError(f"{where}: group tag {brief(group)} must lie in 1 … 2³¹ − 1 (gmsh's tags)")
    return value


def _is_name(text):
    return isinstance(text, str) and 0 < len(text) <= MAX_NAME and text.isprintable()


def _integer(value, where, _):
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError(f"{where} must be an integer, got {brief(value)}")
    return value


def _boolean(value, where, _):
    if not isinstance(value, bool):
        raise InputError(f"{where} must be true or false, got {brief(value)}")
    return value


def _string(value, where, _):
    if not isinstance(value, str):
        raise InputError(f"{where} must be a string, got {brief(value)}")
    if "\0" in value:
        raise InputError(f"{where} contains a NUL character")
    return value


def _corners(value, where, parameters):
    try:
        points = [[_number(c, where, parameters) for c in corner] for corner in value]
        assert len(points) == 2 and len(points[0]) == len(points[1]) in (2, 3)
    except (TypeError, AssertionError):
        raise InputError(f"{where} must be [[x0, y0], [x1, y1]] (or with z), got {brief(value)}") from None
    if not all(b > a for a, b in zip(*points)):
        raise InputError(f"{where} must have x1 > x0, y1 > y0 (and z1 > z0), got {brief(value)}")
    return points


def _cells(value, where, _):
    if not (isinstance(value, list) and len(value) in (2, 3)
            and all(isinstance(c, int) and not isinstance(c, bool) and c >= 1 for c in value)):
        raise InputError(f"{where} must be 2 (rectangle) or 3 (box) positive integers, got {brief(value)}")
    simplices = math.prod(value) * (2 if len(value) == 2 else 6)
    if simplices > MAX_BUILT_IN_CELLS:
        count = f"{simplices:.3g}" if simplices < 1e300 else "more than 1e300"
        raise InputError(f"{where} = {brief(value)} asks for {count} cells: a built-in mesh is made on "
                         f"one rank first, and DOLFINx indexes at most {MAX_BUILT_IN_CELLS:.3g} there (refine "
                         "adaptively, or give a mesh file)")
    return value


MAX_BUILT_IN_CELLS = 2**31 - 1  # DOLFINx's local indices are 32-bit; 0.5.2 builds the mesh on rank 0


def _option(value, where, _):
    if not isinstance(value, (str, int, float, bool)) or not _finite_number(value) \
            or isinstance(value, str) and not value.isprintable():
        raise InputError(f"{where} must be a printable string, a finite number or a boolean, got {brief(value)}")
    return value


_KINDS = {"number": _number, "expression": _expression, "vector": _vector, "groups": _groups,
          "integer": _integer, "boolean": _boolean, "string": _string, "corners": _corners,
          "cells": _cells, "option": _option}


def convert(path, value, where=None, parameters=None):
    """Check one value against the schema key ``path`` (type, choices, range) and return it converted;
    ``where`` names it in the error (default: the key)."""
    return _convert(find_key(path), value, where or path, parameters or {})


def _convert(key, value, where, parameters):
    if key.kind == "choice":
        if value not in key.choices:
            hint = _suggest(value, key.choices) if isinstance(value, str) else ""
            raise InputError(f"{where} must be one of {', '.join(map(repr, key.choices))}, got {brief(value)}"
                             + (hint if "did you mean" in hint else ""))
        return value
    value = _KINDS[key.kind](value, where, parameters)
    problem = key.check(value) if key.check else None
    if problem:
        raise InputError(f"{where} {problem}, got {brief(value)}")
    return value


# --- whole tables ---------------------------------------------------------------------------------------

def parameters_of(data):
    """[parameters]: numbers or expressions of the parameters defined above them."""
    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise InputError(f"[parameters] must be a table, got {table!r}")
    values = {}
    reserved = set(expressions.COORDINATES) | {"pi"} | set(expressions.FUNCTIONS)
    for name, text in table.items():
        if name in reserved or not name.isidentifier() or len(name) > MAX_NAME:
            raise InputError(f"parameter name '{brief_text(name)}' is not allowed (reserved or not an identifier)")
        values[name] = _number(text, f"parameters.{name}", values)
    return values


MAX_DEPTH = 8  # tables and arrays within one another: the deepest key, material.regions.NAME.E, is 4


def check_depth(data):
    """Refuse a problem table nested deeper than any key of the schema (TOML's dotted keys and headers
    nest without limit), found without recursion: copying or validating it would recurse that deep."""
    stack = [(data, ())]
    while stack:
        value, path = stack.pop()
        if len(path) > MAX_DEPTH:
            raise InputError(f"'{brief_text('.'.join(path[:MAX_DEPTH + 1]))}…' is nested more than {MAX_DEPTH} "
                             "tables or arrays deep: no key of a problem is")
        items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, list) else ()
        stack.extend((child, (*path, str(key))) for key, child in items)


def validate(data):
    """Check every key of a raw problem table against the schema.

    Returns ``(values, given)``: the table with every key converted and every default filled in, and the
    set of dotted keys that the table gave explicitly.
    """
    if not isinstance(data, dict):
        raise InputError("a problem must be a table")
    for section in data:
        if section not in SECTIONS:
            raise InputError(f"unknown section '[{brief_text(section)}]'" + _suggest(section, SECTIONS, "[{}]"))
    parameters = parameters_of(data)
    values, given = {"parameters": dict(parameters)}, {f"parameters.{name}" for name in parameters}
    for section in SECTIONS:
        if section == "parameters":
            continue
        if section in ("title", "description"):
            if section in data:
                values[section] = _convert(_BY_PATH[section], data[section], section, parameters)
                given.add(section)
            continue
        table = data.get(section, {})
        if not isinstance(table, dict):
            raise InputError(f"[{section}] must be a table, got {table!r}")
        values[section] = _section(section, table, parameters, given)
    return values, frozenset(given)


def _section(prefix, table, parameters, given):
    """Convert one table and fill the defaults of its keys."""
    out = {}
    for name, value in table.items():
        path = f"{prefix}.{name}"
        if not _is_name(name):
            raise InputError(f"key '{brief_text(path)}': a name must be printable and at most {MAX_NAME} characters")
        key = find_key(path)
        if key is None and _is_table_prefix(path):  # material.regions, material.regions.NAME
            if not isinstance(value, dict):
                raise InputError(f"{path} must be a table, got {brief(value)}")
            out[name] = _section(path, value, parameters, given)
            continue
        if key is None:
            raise InputError(f"unknown key '{brief_text(path)}'" + _suggest(name, _children(prefix), prefix + ".{}"))
        given.add(path)
        if key.kind == "traction":
            out[name] = _traction(value, path, parameters, given)
        elif key.kind == "table":
            if not isinstance(value, dict):
                raise InputError(f"{path} must be a table, got {brief(value)}")
            out[name] = _section(path, value, parameters, given)
        else:
            out[name] = _convert(key, value, path, parameters)
    for key in _keys_below(prefix):
        name = key.path.split(".")[-1]
        if name != "*" and name not in out:
            if key.required:
                where = f"'{prefix}.{name}'" if "*" in key.path else f"'{key.path}'"
                raise InputError(f"missing required key {where}" + _required_hint(key))
            out[name] = _copy(key.default)
    return out


def _is_table_prefix(path):
    """Whether ``path`` names a table of the schema (``material.regions``, ``material.regions.soft``)."""
    parts = path.split(".")
    return any(len(k.path.split(".")) > len(parts) and _matches(k.path.split(".")[:len(parts)], parts)
               and k.kind not in ("traction",) for k in KEYS) and find_key(path) is None


def _required_hint(key):
    return {"material.E": ": Young's modulus has no default", "material.nu": ": Poisson's ratio has no default",
            "contact.c_n": ": the foundation stiffness has no default",
            "contact.m_n": ": the exponent of the law has no default"}.get(key.path, "")


def _traction(value, path, parameters, given):
    if isinstance(value, list):
        return _vector(value, path, parameters)
    if not isinstance(value, dict):
        raise InputError(f"{path} must be a vector or a table {{group = [...]}}, got {brief(value)}")
    for group in value:
        if not _is_name(group):
            raise InputError(f"{path}: group name {brief(group)} must be printable and at most {MAX_NAME} "
                             "characters")
        given.add(f"{path}.{group}")
    return {group: _vector(vec, f"{path}.{group}", parameters) for group, vec in value.items()}


def _copy(value):
    return dict(value) if isinstance(value, dict) else list(value) if isinstance(value, list) else value


def reference_markdown():
    """The key reference as Markdown (for the README): one table per section."""
    lines = []
    groups = [("top level", ("title", "description"))] + [(f"[{s}]", (s,)) for s in SECTIONS[2:]]
    for heading, sections in groups:
        keys = [k for k in KEYS if k.kind != "table" and k.path.split(".")[0] in sections]
        lines += [f"**{heading}**", "", "| key | type | default | meaning |", "|---|---|---|---|"]
        for k in keys:
            default = "**required**" if k.required else "–" if k.default is None else f"`{_show(k.default)}`"
            kind = k.kind if k.kind != "choice" else " / ".join(f"`{c}`" for c in k.choices)
            lines.append(f"| `{k.path}` | {kind} | {default} | {k.doc} |")
        lines.append("")
    return "\n".join(lines)


def _show(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{}"
    return str(value)
