"""Hypothesis strategies for fuzzing the command line's error contract (issue 31, item 5), and its check.

Every input is a small VALID problem file (a 2D ``mesh.rectangle`` of at most 8x6 cells or a 3D ``mesh.box``
of at most 3x2x2 cubes, one or two levels) with at most ONE mutation (:func:`fuzz_inputs`, one strategy per
family in :data:`FAMILIES`): a wrong type or range for a key of the schema (:data:`nc_dolfinx.problem.schema.KEYS`),
a misspelt key or section, a hostile name (key, section, parameter, group, region), a hostile expression, a
hostile title, thousands-deep TOML nesting, a huge ``mesh.cells``, a hostile ``mesh.file`` or problem file,
a bad command-line or PETSc option; or none (valid variations of the numbers and options). Each input
says what it expects:

- ``ok``: a valid problem, exit 0 expected;
- ``error``: bad input, exit 1 expected, with one error line naming one of ``words`` (any line if empty);
- ``either``: exit 0 or a clean exit 1 (a valid-looking input the solver may still refuse, e.g. a load
  of 20000 terms, or a hostile title that may or may not be refused).

:func:`run_input` runs one input through ``run_cases.py`` in a fresh temporary folder and
:func:`contract_breaks` lists what broke the contract (module ``cli``'s docstring):

- exit 0: ``OUT/summary.json`` says ``completed`` and every number of ``OUT/history.json`` is finite;
- exit 1: stdout's last non-empty line is the ONE line ``nc_dolfinx: error: …`` (only the line
  ``nc_dolfinx: levels 0–N kept in OUT …`` may follow it), no other line of stdout or stderr contains
  "error", and the line names one of the input's ``words``; once on 2 ranks;
- never: exit 3 or any other status, ``internal error``, a traceback, a hang (``NC_FUZZ_TIMEOUT``, 240 s),
  a file created outside OUT, nor the CANARY file that every hostile payload would create if it ran.

Each run is limited to ``NC_FUZZ_MEMORY_GB`` (4) GB of address space per process, so that a hostile input
that makes the program allocate without bound fails fast instead of taking the machine's memory.

Used by tests/test_fuzz.py (a quick, derandomised profile) and benchmarks/fuzz_long.py (random seeds for
a time budget).
"""
import json
import math
import os
import re
import resource
import shlex
import shutil
import signal
import subprocess
import tempfile
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from hypothesis import HealthCheck
from hypothesis import strategies as st

from conftest import PYTHON, ROOT, mpirun_prefix
from nc_dolfinx.problem.schema import KEYS, SECTIONS, find_key

CANARY = "@CANARY@"  # replaced by the absolute path of TMP/CANARY when the input is written
DIR = "@DIR@"        # replaced by the example's temporary folder
ERROR = "nc_dolfinx: error:"
TIMEOUT = float(os.environ.get("NC_FUZZ_TIMEOUT", 240))
MEMORY_GB = float(os.environ.get("NC_FUZZ_MEMORY_GB", 4))
NAN, INF = float("nan"), float("inf")
SPOOF = "bogus\nnc_dolfinx: error: spoofed second line"  # printed raw, the error would take two lines
# Health checks to suppress: every input is a slow subprocess and some are large on purpose. Named one by
# one (not list(HealthCheck)): newer Hypothesis warns about suppressing its deprecated members.
SUPPRESS = [getattr(HealthCheck, name) for name in ("too_slow", "filter_too_much", "data_too_large",
                                                    "large_base_example") if hasattr(HealthCheck, name)]
WILDCARD_NAMES = {"parameters": "pfuzz", "material.regions": "soft", "loads.g": "top", "loads.u_D": "left",
                  "solver.petsc_options": "snes_rtol", "steps.set": "pfuzz"}


@dataclass(frozen=True)
class FuzzInput:
    family: str                  # the mutation's family (wrong-type, hostile-expression, cli, ...)
    note: str                    # what exactly was mutated, for the report
    toml: str = None             # the problem file's text (None: not written, e.g. a missing file)
    data: object = None          # the table the text was written from (None for raw text), for the self-check
    args: tuple = ()             # extra command-line arguments, after FILE --out OUT --quiet
    files: tuple = ()            # (name, bytes, or None for a folder) written next to the problem file
    problem_file: str = "problem.toml"
    problem_arg: str = None      # the CASE_OR_FILE argument (default: problem_file)
    expect: str = "ok"           # ok | error | either
    words: frozenset = frozenset()  # the error line names one of these (any line if empty)
    out: str = "out"             # OUT, relative to the example's folder

    def __repr__(self):
        text = self.toml if self.toml is None or len(self.toml) < 300 else self.toml[:300] + "…"
        return (f"FuzzInput({self.family}: {self.note!r}, expect={self.expect}, args={_short(self.args)}, "
                f"words={sorted(self.words)}, toml={text!r})")


def _short(value, n=120):
    text = repr(value)
    return text if len(text) <= n else text[:n] + "…"


# --- TOML writing -------------------------------------------------------------------------------------

_BARE = re.compile(r"[A-Za-z0-9_-]+")


def toml_string(text):
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    out = []
    for ch in text:
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_key(name):
    return name if _BARE.fullmatch(name) else toml_string(name)


def toml_value(value):
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        text = repr(value)
        return text if any(c in text for c in ".en") else text + ".0"
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{toml_key(k)} = {toml_value(v)}" for k, v in value.items()) + " }"
    raise TypeError(f"no TOML for {value!r}")


def toml_document(data):
    """A problem file: top-level values first, then one [section] per table (nested tables inline)."""
    lines = [f"{toml_key(k)} = {toml_value(v)}" for k, v in data.items() if not isinstance(v, dict)]
    for name, table in data.items():
        if isinstance(table, dict):
            lines += ["", f"[{toml_key(name)}]"]
            lines += [f"{toml_key(k)} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


def same(a, b):
    """Equality of parsed TOML, NaN equal to NaN, int and float and bool told apart."""
    if type(a) is not type(b):
        return False
    if isinstance(a, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    if isinstance(a, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return a == b


def self_check(fi):
    """The fuzzer's own check: a problem file written from a table reads back as that table."""
    if fi.data is not None:
        parsed = tomllib.loads(fi.toml)
        assert same(parsed, fi.data), f"the TOML written is not the table meant:\n{fi.toml}\n{parsed!r}\n{fi.data!r}"


# --- the valid base problem ---------------------------------------------------------------------------

C_N_2D = ["{K}", "{K}*(1 + x)", "{K}*(1 + x*x)", "{K}*(2 + sin(pi*x))", "max({K}, {K}*x)", "{K}*exp(-x)"]
C_N_3D = ["{K}", "{K}*(1 + x)*(1 + 0.5*y)"]


def _number(draw, low, high, log=False):
    if log:
        return float(f"{10 ** draw(st.floats(math.log10(low), math.log10(high))):.4g}")
    return float(f"{draw(st.floats(low, high)):.4g}")


@st.composite
def base_problems(draw, dim=None):
    """A small valid problem (a dict): a rectangle of at most 8x6 cells or a box of at most 3x2x2 cubes,
    clamped on the left, on the foundation along the bottom, pushed down by its weight (and a traction on
    top), with mild numbers (the load at most 2 % of E); no refinement, or 2 levels of uniform or adaptive
    refinement."""
    dim = dim or draw(st.sampled_from([2, 2, 2, 3]))
    E = _number(draw, 1e2, 1e4, log=True)
    if dim == 2:
        mesh = {"rectangle": [[0.0, 0.0], [draw(st.sampled_from([1.0, 2.0])), 1.0]],
                "cells": [draw(st.integers(4, 8)), draw(st.integers(2, 6))]}
        if draw(st.booleans()):
            mesh["diagonal"] = draw(st.sampled_from(["left", "right", "crossed"]))
    else:
        mesh = {"box": [[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]],
                "cells": draw(st.sampled_from([[2, 2, 2], [2, 1, 1], [3, 2, 2]]))}
    mesh.update({"dirichlet": ["left"], "contact": ["bottom"], "neumann": ["top"]})
    weight = _number(draw, 1e-3, 2e-2, log=True) * E
    loads = {"f": ["0"] * (dim - 1) + [f"-{weight:.4g}"]}
    if draw(st.booleans()):
        traction = _number(draw, 1e-3, 1e-2, log=True) * E
        loads["g"] = {"top": ["0"] * (dim - 1) + [f"-{traction:.4g}*x"]}
    K = _number(draw, 0.1, 10, log=True) * E
    c_n = draw(st.sampled_from(C_N_2D if dim == 2 else C_N_3D)).format(K=f"{K:.4g}")
    contact = {"c_n": float(K) if c_n == f"{K:.4g}" and draw(st.booleans()) else c_n,
               "m_n": float(draw(st.sampled_from([1, 1.5, 2, 3]))) if draw(st.booleans())
               else _number(draw, 1.0, 3.0)}
    if draw(st.booleans()):
        contact["gap"] = draw(st.sampled_from([0.0, 1e-4, 1e-3, "1e-3*x"]))
    if draw(st.integers(0, 3)) == 0:  # Coulomb friction, now and then
        contact["friction"] = draw(st.sampled_from([0.0, 0.1, 0.3, "0.2*(1 + x)"]))
    refine = draw(st.sampled_from(["none", "uniform", "adaptive"]))
    adapt = {"refine": refine} if refine == "none" else {"refine": refine, "levels": 2}
    if refine == "adaptive" and draw(st.booleans()):
        adapt["theta"] = _number(draw, 0.2, 1.0)
    problem = {"mesh": mesh, "material": {"E": E, "nu": _number(draw, 0.0, 0.45)}, "loads": loads,
               "contact": contact, "adapt": adapt}
    if draw(st.booleans()):
        problem = {"title": draw(st.sampled_from(["fuzz", "a fuzzed problem", "Ω ∂ σ_n ≥ 0"])), **problem}
    return problem


def input_key(fi):
    """What makes two inputs the same for the fuzzer: the mutation (or, for a valid input, the file)."""
    if fi.family in ("valid", "hostile-title"):
        return (fi.family, fi.note, fi.toml, fi.args)
    return (fi.family, fi.note, fi.args, fi.problem_arg)


def dimension(problem):
    return 2 if "rectangle" in problem["mesh"] else 3


def _from(problem, family, note, expect="error", words=(), **kw):
    return FuzzInput(family, note, toml_document(problem), problem, expect=expect, words=frozenset(words), **kw)


def _set(problem, path, value):
    table = problem
    *head, last = path.split(".")
    for part in head:
        table = table.setdefault(part, {})
    table[last] = value


@st.composite
def valid_inputs(draw):
    """Valid variations: exit 0 expected (numbers of the law and material in range, valid options)."""
    problem = draw(base_problems())
    extra = draw(st.sampled_from([(), (), ("-snes_rtol", "1e-10"), ("-snes_max_it", "100"),
                                  ("--preset", "direct"), ("--set", "contact.m_n=2")]))
    if extra == ("--set", "contact.m_n=2") or draw(st.booleans()):
        return _from(problem, "valid", f"valid {extra or ''}", expect="ok", args=extra)
    solver = draw(st.sampled_from([{"petsc_options": {"snes_rtol": 1e-10}}, {"preset": "direct"},
                                   {"load_steps": 2}, {"petsc_options": {"snes_max_it": 50}}]))
    problem["solver"] = solver
    return _from(problem, "valid", f"valid [solver] {solver}", expect="ok", args=extra)


# --- wrong types and ranges of schema keys ------------------------------------------------------------

_NON_STRINGS = [1, 1.5, [1], {"a": 1}, True]


def _range_violations(key):
    check = getattr(key.check, "__name__", "")
    return {"_positive": [0, 0.0, -1.0, -1e-300, "-1"], "_poisson": [0.5, -1.0, 0.7, 2],
            "_at_least_one": [0.5, 0, -3], "_fraction": [0, -0.5, 1.5],
            "_non_negative": [-1]}.get(check, [])


def wrong_values(key, path, dim):
    """Values of ``path`` (a schema key) that the program must refuse (in a valid base problem of ``dim``)."""
    kind, wrong = key.kind, []
    other = 3 if dim == 2 else 2
    if kind == "number":
        wrong = ["abc", "nan", "inf", "-inf", "NaN", "1e999", "", " ", [1, 2], {"a": 1}, True, False,
                 10 ** 400, -10 ** 400, NAN, INF, -INF, "1e999-1e999", "x", "9" * 5000]
        wrong += _range_violations(key)
        if path == "contact.m_n" and dim == 3:
            wrong += [3.5, 10]
    elif kind == "expression":
        wrong = [[1], {"a": 1}, True, "abc", "nan", "inf", NAN, INF, -INF, "", "1e999", 10 ** 400, "-1", -1.0,
                 "-1 - x*x"] + (["z"] if dim == 2 else [])
    elif kind == "integer":
        wrong = ["abc", 1.5, 2.0, True, [1], {"a": 1}, 0, -5, NAN, "3", ""]
        if path.startswith("estimator."):
            wrong += [10 ** 400, 2 ** 64]
    elif kind == "choice":
        wrong = ["bogus", "", 1, True, [], {"a": 1}, key.choices[0].upper() + "X"]
    elif kind == "groups":
        wrong = [1.5, True, {"a": 1}, [[1]], [True], [1.5], "nosuch", ["nosuch"], 10 ** 400, ""]
    elif kind == "corners":
        if (path == "mesh.rectangle") != (dim == 2):  # the other kind of built-in mesh: any value clashes
            wrong = [[[0.0] * other, [1.0] * other], "abc"]
        else:
            wrong = ["abc", [1, 2], [[0, 0], [0, 0]], [[0, 0], [1]], [[0, 0], [1, "a"]], [[1, 1], [0, 0]],
                     [[0, 0], [1, 1], [2, 2]], [[0, 0], [NAN, 1]], [[0, 0], [INF, 1]], [[0, 0], [10 ** 400, 1]],
                     [[0.0] * other, [1.0] * other]]
    elif kind == "cells":
        wrong = [[0, 2], [-1, 2], [1.5, 2], "4", [4], [4, 2, 2, 2], [True, 2], [], 4, [[4], [2]], [NAN, 2],
                 [2] * other]
    elif kind == "vector":
        wrong = ["0", 0, [1], ["0"] * 4, {"a": 1}, [True, False], [[1], [2]], [NAN, 0], ["abc", "0"], ["0"] * other]
    elif kind == "traction":
        wrong = ["abc", 1, [True, "0"], {"nosuch": ["0"] * dim}, {"top": "0"}, True]
    elif kind == "displacement":  # loads.u_D: the base's only Dirichlet group is 'left'
        wrong = ["abc", 1, [True, "0"], {"nosuch": ["0"] * dim}, {"top": ["0"] * dim}, {"left": "0"}, True,
                 ["free"] * dim, {"left": ["fre"] + ["0"] * (dim - 1)}]
    elif kind == "prescribed":  # loads.u_D.left
        wrong = ["0", 0, [1], ["0"] * 4, ["free"] * dim, ["fre"] + ["0"] * (dim - 1), [NAN] + ["0"] * (dim - 1),
                 ["1/(x-x)"] + ["0"] * (dim - 1), ["0"] * other]
    elif kind == "boolean":
        wrong = ["yes", 1, [], "true", 0, {"a": 1}, True]  # True: from_exact without [exact] u
    elif kind == "string":
        wrong = list(_NON_STRINGS)
    elif kind == "table":
        wrong = ["abc", [1], 1, True]
    elif kind == "option":
        wrong = [[1], {"a": 1}, [[1]], "abc"]
    if kind != "string":  # a string that would print as a second, spoofed error line
        wrong.append(SPOOF)
    return wrong


def concrete(path):
    """A schema path with its ``*`` replaced by a name (``parameters.*`` -> ``parameters.pfuzz``)."""
    for prefix, name in WILDCARD_NAMES.items():
        if path.startswith(prefix + ".*"):
            return path.replace("*", name, 1)
    return path


@st.composite
def wrong_type_inputs(draw):
    problem = draw(base_problems())
    dim = dimension(problem)
    key = draw(st.sampled_from(KEYS))
    path = concrete(key.path)
    value = draw(st.sampled_from(wrong_values(key, path, dim)))
    if path.startswith("material.regions.soft."):  # a region needs both numbers: the other one valid
        problem["material"]["regions"] = {"soft": {"E": 100.0, "nu": 0.3}}
    if path == "loads.g.top":
        problem["loads"]["g"] = {}
    if path == "mesh.file" or path in ("mesh.rectangle", "mesh.box", "mesh.cells"):
        pass  # the base's own mesh stays: two kinds of mesh clash, or the key is replaced
    if path.startswith("steps."):  # [[steps]] is an array of tables: one step, setting the parameter pfuzz
        problem.setdefault("parameters", {})["pfuzz"] = 1.0
        step = {"set": {"pfuzz": 2.0}}
        step["set" if path == "steps.set.pfuzz" else "increments"] = \
            {"pfuzz": value} if path == "steps.set.pfuzz" else value
        problem["steps"] = [step]
        path = path.replace("steps.", "steps[1].", 1)
    else:
        _set(problem, path, value)
    words = {path, path.split(".")[-1]}
    if value in ("nosuch", ["nosuch"]):
        words.add("nosuch")
    if path.startswith("material.regions"):
        words.add("soft")
    if path == "loads.from_exact" and value is True:
        words.add("exact")
    return _from(problem, "wrong-type", f"{path} = {_short(value, 60)}", words=words)


# --- misspelt keys and sections -----------------------------------------------------------------------

def _typos(name):
    """Misspellings of ``name``: a letter dropped, doubled, swapped, replaced, or the case changed."""
    out = []
    for i in range(len(name)):
        out.append(name[:i] + name[i + 1:])
        out.append(name[:i] + name[i] + name[i:])
        if i + 1 < len(name):
            out.append(name[:i] + name[i + 1] + name[i] + name[i + 2:])
        out.append(name[:i] + ("q" if name[i] != "q" else "z") + name[i + 1:])
    out += [name.upper(), name.capitalize(), name + "s", name + "_"]
    return sorted({t for t in out if t and t != name and _BARE.fullmatch(t)})


def _is_known(path):
    parts = path.split(".")
    if len(parts) == 1:
        return path in SECTIONS
    if find_key(path) is not None:
        return True
    return any(len(k.path.split(".")) > len(parts)
               and all(p in ("*", q) for p, q in zip(k.path.split(".")[:len(parts)], parts)) for k in KEYS)


@st.composite
def unknown_key_inputs(draw):
    problem = draw(base_problems())
    what = draw(st.sampled_from(["section", "key", "new-section", "new-key"]))
    if what in ("section", "new-section"):
        if what == "section":
            section = draw(st.sampled_from([s for s in problem if isinstance(problem[s], dict)]))
            typo = draw(st.sampled_from([t for t in _typos(section) if not _is_known(t)]))
            problem = {(typo if k == section else k): v for k, v in problem.items()}
        else:
            typo = draw(st.sampled_from(["extra", "meshes", "options", "petsc", "boundary", "Mesh"]))
            problem[typo] = {"a": 1}
        return _from(problem, "unknown-key", f"section [{typo}]", words={typo})
    keys = [k for k in KEYS if "*" not in k.path and k.path.count(".") == 1]
    key = draw(st.sampled_from(keys))
    section, name = key.path.split(".")
    if what == "key":
        typo = draw(st.sampled_from([t for t in _typos(name) if not _is_known(f"{section}.{t}")]))
    else:
        typo = draw(st.sampled_from(["cn", "youngs_modulus", "poisson", "penalty", "levels_max", "x"]))
        if _is_known(f"{section}.{typo}"):
            typo += "_extra"
    table = problem.setdefault(section, {})
    value = table.pop(name, 1.0)
    table[typo] = value
    path = f"{section}.{typo}"
    return _from(problem, "unknown-key", f"key {path} (for {key.path})", words={path, typo})


# --- hostile expressions ------------------------------------------------------------------------------

INJECTION = f"__import__('os').system('touch {CANARY}')"


@st.composite
def hostile_expressions(draw, coordinates=True, max_terms=30000):
    """(label, text, expect): expressions that are huge, deep, malformed, non-finite or hostile."""
    n = draw(st.integers(1000, max_terms))
    v = "x" if coordinates else "1"
    choices = [
        ("long-sum", "+".join([v] * n), "either"),
        ("long-sum-numbers", "+".join(["1e-3"] * n), "either"),
        ("unary-minus", "-" * (2 * (n // 2)) + v, "either"),
        ("deep-parentheses", "(" * (n // 10) + v + ")" * (n // 10), "either"),
        ("power-tower", "**".join([v] * (n // 10)), "either"),
        ("nul-byte", f"{v}\x00+1", "error"),
        ("control-character", f"{v}{draw(st.sampled_from(chr(1) + chr(7) + chr(8) + chr(27) + chr(127)))}+1",
         "error"),
        ("newline", f"{v}\n+1", "either"),  # whitespace, as a space is (issue 48): "1 +1"
        ("tab", f"{v}\t+1", "either"),
        ("newline-in-parentheses", f"({v}\n+1)", "either"),
        ("zero-width-space", f"{v}\u200b+1", "error"),
        ("injection", INJECTION, "error"),
        ("injection-lambda", f"(lambda: {INJECTION})()", "error"),
        ("injection-attribute", "().__class__.__base__.__subclasses__()", "error"),
        ("injection-fstring", f'f"{{{INJECTION}}}"', "error"),
        ("huge-product", "1e308*1e308", "error"),
        ("huge-power", "10**400", "error"),
        ("huge-literal", "9" * 5000, "error"),
    ]
    if coordinates:
        choices += [("overflow-exp", "exp(1000*(x+2))", "error"), ("overflow-power", "(2+x*x)**1e9", "error"),
                    ("division-by-zero", "1/(x-x)", "error"), ("log-of-negative", "log(x-10)", "error"),
                    ("sqrt-of-negative", "sqrt(-1-x*x)", "error"), ("huge-exponent", "x**123456789", "either")]
    else:
        choices += [("overflow-exp", "exp(1000)", "error"), ("overflow-power", "(2+1)**1e9", "error"),
                    ("division-by-zero", "1/(1-1)", "error"), ("log-of-negative", "log(-10)", "error"),
                    ("sqrt-of-negative", "sqrt(-1)", "error")]
    return draw(st.sampled_from(choices))


EXPRESSION_SITES = ["contact.c_n", "contact.gap", "contact.friction", "loads.f", "loads.g.top", "loads.u_D.left", "exact.u", "material.E",
                    "parameters.pfuzz", "--set contact.c_n"]


@st.composite
def hostile_expression_inputs(draw):
    problem = draw(base_problems())
    dim = dimension(problem)
    site = draw(st.sampled_from(EXPRESSION_SITES))
    number = site in ("material.E", "parameters.pfuzz")
    # an argument holds at most 128 KiB (MAX_ARG_STRLEN): fewer terms through --set
    max_terms = 15000 if site.startswith("--set") else 30000
    label, text, expect = draw(hostile_expressions(coordinates=not number, max_terms=max_terms))
    if site == "--set contact.c_n":
        if "\x00" in text:  # a NUL cannot be in an argument
            text = text.replace("\x00", "\x01")
        args = ("--set", f"contact.c_n={toml_string(text)}")
        return _from(problem, "hostile-expression", f"{label} via --set contact.c_n", expect=expect,
                     words={"contact.c_n", "c_n", "--set"}, args=args)
    path = site
    if site in ("loads.f", "loads.g.top", "loads.u_D.left", "exact.u"):
        value = ["0"] * (dim - 1) + [text]
        if site == "loads.g.top":
            problem["loads"]["g"] = {}
    else:
        value = text
    _set(problem, path, value)
    if site == "contact.gap" and label in ("long-sum", "long-sum-numbers", "unary-minus", "huge-exponent"):
        expect = "either"
    return _from(problem, "hostile-expression", f"{label} at {site}", expect=expect,
                 words={path, path.split(".")[-1]})


# --- hostile names: keys, sections, parameters, groups, regions -------------------------------------------

HOSTILE_NAMES = [SPOOF, "k" * 5000, "a\x00b", "\x1b[2J\x1b[31m", "\u202ekey", "", " ", "a.b", "x" * 201,
                 "__import__", "pi", "x"]


@st.composite
def hostile_name_inputs(draw):
    """A name that is long, empty, dotted, reserved, or holds control characters, where the file names
    something: an unknown key or section, a parameter, a boundary group, a material region."""
    problem = draw(base_problems())
    where = draw(st.sampled_from(["key", "section", "parameter", "group", "region"]))
    name = draw(st.sampled_from(HOSTILE_NAMES))
    if where == "key":
        problem["contact"][name] = 1.0
        words = {"contact"}
    elif where == "section":
        problem[name] = {"a": 1}
        words = set()
    elif where == "parameter":
        problem["parameters"] = {name: 1.0}
        words = {"parameter"}
    elif where == "group":
        problem["mesh"]["dirichlet"] = [name]
        words = {"dirichlet", "group"}
    else:
        problem["material"]["regions"] = {name: {"E": 100.0, "nu": 0.3}}
        words = {"region"}
    shown = name if len(name) < 40 else f"{len(name)} characters"
    # a parameter may be named __import__: a name like any other, since nothing is eval'd
    expect = "either" if (where, name) == ("parameter", "__import__") else "error"
    return _from(problem, "hostile-name", f"{where} named {shown!r}", expect=expect, words=words)


# --- hostile titles -----------------------------------------------------------------------------------

@st.composite
def hostile_title_inputs(draw):
    problem = draw(base_problems())
    key = draw(st.sampled_from(["title", "description"]))
    label, text = draw(st.sampled_from([
        ("5000 characters", "t" * 5000), ("100000 characters", "d" * 100000), ("newline", "first\nsecond"),
        ("carriage return", "first\rsecond"), ("escape sequence", "\x1b[31mred\x1b[0m\x1b[2J"),
        ("NUL", "a\x00b"), ("bell and backspace", "a\x07\x08b"), ("right-to-left override", "\u202efuzz"),
        ("only spaces", "   "), ("empty", ""), ("format string", "{0} %s %(x)s {__class__}"),
        ("fake output", "fuzz\n  stopped: never\nnc_dolfinx: nothing")]))
    problem = {key: text, **{k: v for k, v in problem.items() if k != key}}
    return _from(problem, "hostile-title", f"{key}: {label}", expect="either", words={key})


# --- deep nesting, written as raw TOML ----------------------------------------------------------------

SENTINEL = "@@RAW@@"


@st.composite
def deep_nesting_inputs(draw):
    problem = draw(base_problems())
    depth = draw(st.integers(300, 5000))
    what = draw(st.sampled_from(["array", "inline-table", "petsc-table", "dotted-header", "dotted-key"]))
    if what in ("array", "inline-table", "petsc-table"):
        path = {"array": "loads.f", "inline-table": "contact.c_n", "petsc-table": "solver.petsc_options"}[what]
        raw = ("[" * depth + '"0"' + "]" * depth) if what == "array" else "{ a = " * depth + "1" + " }" * depth
        _set(problem, path, SENTINEL)
        text = toml_document(problem)
        assert text.count(toml_string(SENTINEL)) == 1
        text = text.replace(toml_string(SENTINEL), raw)
        words = {path, path.split(".")[-1], "problem.toml"}
    else:
        text = toml_document(problem)
        dotted = ".".join(["deep"] * depth)
        text += f"\n[{dotted}]\nx = 1\n" if what == "dotted-header" else ""
        if what == "dotted-key":  # a top-level dotted key must come before the first [section]
            text = f"{dotted} = 1\n" + text
        words = {"deep", "problem.toml"}
    return FuzzInput("deep-nesting", f"{what} {depth} deep", text, None, expect="error", words=frozenset(words))


# --- huge mesh.cells ----------------------------------------------------------------------------------

@st.composite
def huge_cells_inputs(draw):
    problem = draw(base_problems())
    dim = dimension(problem)
    huge = draw(st.sampled_from([10 ** 22, 2 ** 64, 2 ** 64 + 4, -10 ** 22, 10 ** 400]))
    where = draw(st.integers(0, dim - 1))
    cells = list(problem["mesh"]["cells"])
    cells[where] = huge
    problem["mesh"]["cells"] = cells
    shown = [c if abs(c) < 10 ** 30 else f"{'-' if c < 0 else ''}10**{len(str(abs(c))) - 1}" for c in cells]
    return _from(problem, "huge-cells", f"mesh.cells = {shown}".replace("'", ""), words={"mesh.cells", "cells"})


# --- hostile mesh files -------------------------------------------------------------------------------

GEO_PAYLOAD = f'SystemCall "touch {CANARY}";\nPoint(1) = {{0, 0, 0}};\n'.encode()
PY_PAYLOAD = f"import os\nos.system('touch {CANARY}')\n".encode()
LONG_NAME = "m" * 296 + ".msh"


@st.composite
def hostile_mesh_file_inputs(draw):
    problem = draw(base_problems())
    for key in ("rectangle", "box", "cells", "diagonal"):
        problem["mesh"].pop(key, None)
    junk = draw(st.binary(min_size=1, max_size=2000))
    name, content = draw(st.sampled_from([
        ("x.msh", GEO_PAYLOAD), ("x.geo", GEO_PAYLOAD), ("x.py", PY_PAYLOAD), ("x", GEO_PAYLOAD),
        ("x.txt", GEO_PAYLOAD), ("empty.msh", b""), ("junk.msh", junk), (LONG_NAME, "absent"),
        ("d.msh", None), ("missing.msh", "absent"), ("/dev/null", "absent"), ("../../../../../etc/passwd", "absent"),
        ("header.msh", b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n"),
        ("nodes.msh", b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n$Nodes\n1 1000000000000 1 1000000000000\n"),
        ("geo.msh", b"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n" + GEO_PAYLOAD)]))
    problem["mesh"]["file"] = name
    files = () if content == "absent" else ((name, content),)
    label = name if len(name) < 40 else f"{len(name)}-character name"
    base = Path(name).name
    return _from(problem, "hostile-mesh-file", f"mesh.file = {label}" + (" (a folder)" if content is None else ""),
                 words={"mesh.file", base[:20]}, files=files)


# --- hostile problem files (the CASE_OR_FILE argument) ------------------------------------------------

@st.composite
def problem_file_inputs(draw):
    problem = draw(base_problems())
    text = toml_document(problem)
    what = draw(st.sampled_from(["long-name", "folder", "missing", "empty", "junk", "nul", "bad-utf8",
                                 "syntax", "duplicate-section", "bom", "passwd", "case-typo", "dev-zero",
                                 "no-suffix", "comment-only"]))
    junk = draw(st.binary(min_size=1, max_size=2000))
    if what == "long-name":
        name = "p" * 295 + ".toml"
        return FuzzInput("problem-file", "a 300-character file name", None, None, problem_arg=name,
                         expect="error", words=frozenset({name[:20]}))
    if what in ("passwd", "dev-zero", "case-typo", "missing"):
        arg = {"passwd": "../../../../../etc/passwd", "dev-zero": "/dev/zero", "case-typo": "blokc",
               "missing": "missing.toml"}[what]
        return FuzzInput("problem-file", what, None, None, problem_arg=arg, expect="error",
                         words=frozenset({Path(arg).name}))
    if what == "folder":
        return FuzzInput("problem-file", "a folder", None, None, files=(("dir.toml", None),),
                         problem_arg="dir.toml", expect="error", words=frozenset({"dir.toml"}))
    contents = {"empty": b"", "junk": junk, "nul": text.encode().replace(b"\n[", b"\n\x00[", 1),
                "bad-utf8": text.encode() + b"# \xff\xfe\xc3\x28\n", "syntax": text.encode() + b"[mesh\n",
                "duplicate-section": text.encode() + b"\n[mesh]\ncells = [2, 2]\n",
                "bom": "\ufeff".encode() + text.encode(), "no-suffix": text.encode(),
                "comment-only": b"# nothing here\n"}[what]
    name = "problem" if what == "no-suffix" else f"{what}.toml"
    expect, words = "error", {name}
    if what in ("empty", "comment-only"):  # missing keys: the error may name a key instead of the file
        words = set()
    if what in ("bom", "no-suffix"):
        expect = "either"
    return FuzzInput("problem-file", what, None, None, files=((name, contents),), problem_file=name,
                     expect=expect, words=frozenset(words))


# --- command-line options -----------------------------------------------------------------------------

PETSC_BAD_VALUES = [("ksp_type", "bogus"), ("ksp_type", SPOOF), ("snes_type", "newtontr2"), ("snes_rtol", "abc"), ("pc_type", "nosuch"),
                    ("snes_max_it", "-5"), ("snes_atol", "-1"), ("ksp_max_it", "abc"),
                    ("snes_linesearch_type", "nosuch"), ("pc_factor_mat_solver_type", "nosuch"),
                    ("ksp_rtol", "1e999")]
PETSC_MISSPELT = [("snes_rtoll", "1e-8"), ("ksp_typ", "cg"), ("snes_monitr", None), ("pc_typee", "lu"),
                  ("nc_snes_rtol", "1e-8"), ("log_view", f"ascii:{DIR}/log.txt"), ("options_file", f"{DIR}/opts")]
OUR_BAD = [("--levels", "abc"), ("--levels", "0"), ("--levels", "-1"), ("--levels", "1.5"), ("--levels", "1e400"),
           ("--levels", "nan"), ("--theta", "2"), ("--theta", "0"), ("--theta", "nan"), ("--theta", "-inf"),
           ("--tol", "-1"), ("--tol", "nan"), ("--rtol", "0"), ("--max-dofs", "0"), ("--max-dofs", "abc"),
           ("--load-steps", "0"), ("--load-steps", "abc"), ("--refine", "bogus"), ("--marking", "bogus"),
           ("--preset", "bogus"), ("--levls", "2"), ("--frobnicate", None), ("-levels", "2"),
           ("--theta", "1e999"), ("--levels", "")]
SET_BAD = [("nosuch.key=1", {"nosuch"}), ("contact.c_n", {"--set"}), ("=1", {"--set"}),
           ("contact.c_nn=1", {"contact.c_nn", "c_nn"}), ("mesh.cells=[1e22, 2]", {"mesh.cells", "cells"}),
           ("contact=1", {"contact", "--set"}), ("contact.c_n.x=1", {"contact.c_n", "c_n"}),
           ("material.E=[[[[[[1]]]]]]", {"material.E", "E"}), ("adapt.levels=1e400", {"adapt.levels", "levels"}),
           ("loads.f=" + "[" * 3000 + "]" * 3000, {"loads.f", "--set"}),
           ("loads.f=" + "{a=" * 3000 + "1" + "}" * 3000, {"loads.f", "--set"}),
           (".".join(["contact"] * 3000) + "=1", {"contact", "--set"}),
           ("contact.c_n=" + toml_string(SPOOF), {"contact.c_n", "c_n"}),
           ("contact.c_n\nnc_dolfinx: error: spoofed=1", {"contact.c_n", "--set"})]


@st.composite
def command_line_inputs(draw):
    problem = draw(base_problems())
    what = draw(st.sampled_from(["petsc-value", "petsc-misspelt", "ours", "set", "long-out", "newline-out"]))
    files = ()
    if what == "petsc-value":
        name, value = draw(st.sampled_from(PETSC_BAD_VALUES))
        args, words = (f"-{name}", value), {name}
    elif what == "petsc-misspelt":
        name, value = draw(st.sampled_from(PETSC_MISSPELT))
        args, words = (f"-{name}",) + ((value,) if value else ()), {name}
        if name == "options_file":
            files = (("opts", b"-on_error_attach_debugger\n-nc_snes_type bogus\n"),)
    elif what == "ours":
        name, value = draw(st.sampled_from(OUR_BAD))
        bare = name.lstrip("-")
        args, words = (name,) + ((value,) if value is not None else ()), {name, bare, bare.replace("-", "_")}
    elif what == "set":
        item, words = draw(st.sampled_from(SET_BAD))
        args = ("--set", item)
    elif what == "long-out":
        out = "o" * 300
        return _from(problem, "cli", "--out with a 300-character name", args=("--out", f"{DIR}/{out}"),
                     words={"--out", out[:20]}, out=out)
    else:
        out = "out\nx"
        return _from(problem, "cli", "--out with a newline", args=("--out", f"{DIR}/{out}"), expect="either",
                     out=out)
    return _from(problem, "cli", " ".join(a if len(a) < 60 else a[:60] + "…" for a in args), args=args,
                 words=words, files=files)


@st.composite
def petsc_table_inputs(draw):
    problem = draw(base_problems())
    name, value = draw(st.sampled_from(PETSC_BAD_VALUES + [(n, v) for n, v in PETSC_MISSPELT[:4]]))
    value = True if value is None else (int(value) if re.fullmatch(r"-?\d+", value) else value)
    problem["solver"] = {"petsc_options": {name: value}}
    return _from(problem, "petsc-table", f"[solver] petsc_options {name} = {value!r}",
                 words={name, f"solver.petsc_options.{name}"})


FAMILIES = {"valid": valid_inputs, "wrong-type": wrong_type_inputs, "unknown-key": unknown_key_inputs,
            "hostile-name": hostile_name_inputs,
            "hostile-expression": hostile_expression_inputs, "hostile-title": hostile_title_inputs,
            "deep-nesting": deep_nesting_inputs, "huge-cells": huge_cells_inputs,
            "hostile-mesh-file": hostile_mesh_file_inputs, "problem-file": problem_file_inputs,
            "cli": command_line_inputs, "petsc-table": petsc_table_inputs}


def fuzz_inputs(families=None):
    """One valid problem with at most one mutation, from every family (or those named)."""
    return st.one_of(*(FAMILIES[name]() for name in (families or FAMILIES)))


# --- running one input and checking the contract ------------------------------------------------------

@dataclass
class Outcome:
    fi: FuzzInput
    nprocs: int
    command: list
    returncode: int = None
    stdout: str = ""
    stderr: str = ""
    seconds: float = 0.0
    timed_out: bool = False
    timeout: float = TIMEOUT
    breaks: list = field(default_factory=list)
    folder: Path = None

    @property
    def last_line(self):
        lines = [line for line in self.stdout.splitlines() if line.strip()]
        return lines[-1] if lines else "(no output on stdout)"


def _substitute(value, folder):
    canary = str(folder / "CANARY")
    if isinstance(value, bytes):
        return value.replace(CANARY.encode(), canary.encode()).replace(DIR.encode(), str(folder).encode())
    return value.replace(CANARY, canary).replace(DIR, str(folder))


def write_input(fi, folder):
    """Write the problem file and the other files of ``fi`` into ``folder``."""
    folder = Path(folder)
    if fi.toml is not None:
        (folder / fi.problem_file).write_bytes(_substitute(fi.toml, folder).encode("utf-8", "surrogatepass"))
    for name, content in fi.files:
        path = folder / name
        if content is None:
            path.mkdir(parents=True, exist_ok=True)
        else:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(_substitute(content, folder))


def command(fi, folder, nprocs=1):
    args = [_substitute(a, folder) for a in fi.args]
    return (mpirun_prefix(nprocs) + [PYTHON, str(ROOT / "run_cases.py"), fi.problem_arg or fi.problem_file,
                                     "--out", str(folder / "out"), "--quiet", *args])


def _limit_memory():
    limit = int(MEMORY_GB * 2 ** 30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))


def _snapshot(folder):
    return {str(p.relative_to(folder)) for p in Path(folder).rglob("*")}


def run_input(fi, nprocs=1, timeout=TIMEOUT, keep=False):
    """Run ``fi`` in a fresh temporary folder on ``nprocs`` ranks; the Outcome lists the contract's breaks.
    The folder is removed unless ``keep`` (then ``outcome.folder``; the caller removes it)."""
    folder = Path(tempfile.mkdtemp(prefix="ncfuzz-"))
    try:
        write_input(fi, folder)
        before = _snapshot(folder)
        cmd = command(fi, folder, nprocs)
        env = dict(os.environ, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1", PYTHONDONTWRITEBYTECODE="1")
        outcome = Outcome(fi, nprocs, cmd, folder=folder, timeout=timeout)
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, cwd=folder, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                stdin=subprocess.DEVNULL, start_new_session=True, preexec_fn=_limit_memory)
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            outcome.timed_out = True
        outcome.seconds = time.perf_counter() - start
        outcome.returncode = proc.returncode
        outcome.stdout = out.decode("utf-8", "replace")
        outcome.stderr = err.decode("utf-8", "replace")
        outcome.breaks = contract_breaks(outcome, folder, before)
        return outcome
    finally:
        if not keep:
            shutil.rmtree(folder, ignore_errors=True)


_KEPT = re.compile(r"^nc_dolfinx: levels 0.\d+ kept in ")


def contract_breaks(o, folder, before):
    """What in the outcome ``o`` of a run in ``folder`` breaks the contract (empty: kept)."""
    fi, breaks = o.fi, []
    text = o.stdout + "\n" + o.stderr
    out = folder / fi.out
    if (folder / "CANARY").exists():
        breaks.append("CANARY created: a hostile input ran a command")
    outside = sorted(p for p in _snapshot(folder) - before
                     if p != fi.out and not p.startswith(fi.out + "/") and p != "CANARY")
    if outside:
        breaks.append(f"files created outside OUT: {outside[:5]}")
    if o.timed_out:
        return breaks + [f"hang: no exit within {o.timeout:g} s"]
    if "Traceback (most recent call last)" in text:
        breaks.append("a Python traceback")
    if "internal error" in text:
        breaks.append("an internal error line")
    if o.returncode not in (0, 1):
        breaks.append(f"exit status {o.returncode}")
    if o.returncode == 0:
        if fi.expect == "error":
            breaks.append("bad input accepted (exit 0)")
        breaks += _completed_run_breaks(out)
    elif o.returncode == 1:
        if fi.expect == "ok":
            breaks.append("a valid input refused (exit 1)")
        breaks += _error_line_breaks(o, fi)
    return breaks


def _completed_run_breaks(out):
    try:
        summary = json.loads((out / "summary.json").read_text())
        history = json.loads((out / "history.json").read_text())
    except (OSError, ValueError) as err:
        return [f"exit 0 without readable OUT/summary.json and history.json ({type(err).__name__}: {err})"]
    breaks = []
    if summary.get("status") != "completed":
        breaks.append(f"exit 0 but summary.json status {summary.get('status')!r}")
    bad = sorted(set(_non_finite(history)))
    if bad:
        breaks.append(f"exit 0 with non-finite numbers in history.json: {bad[:6]}")
    return breaks


def _non_finite(value, where=""):
    if isinstance(value, float) and not math.isfinite(value):
        yield where or "?"
    elif isinstance(value, dict):
        for k, v in value.items():
            yield from _non_finite(v, k)
    elif isinstance(value, list):
        for v in value:
            yield from _non_finite(v, where)


# Open MPI 5's launcher (trixie), not the program: after a rank exits with status 1 it now and then prints
# "[host:pid] PMIX ERROR: PMIX_ERR_UNREACH in file ../src/server/pmix_server.c ..." (seen in 1 of 6 runs of a
# plain mpi4py script that calls sys.exit(1) on both ranks after a barrier).
LAUNCHER_NOISE = re.compile(r"^\[[^\]]*\] PMIX ERROR: ")


def _error_line_breaks(o, fi):
    breaks = []
    lines = [line for line in o.stdout.splitlines() if line.strip()]
    errors = [i for i, line in enumerate(lines) if line.startswith(ERROR)]
    if len(errors) != 1:
        breaks.append(f"{len(errors)} lines start with {ERROR!r} (expected 1)")
    if not errors:
        return breaks
    i = errors[-1]
    line = lines[i]
    if not all(_KEPT.match(after) for after in lines[i + 1:]):
        breaks.append(f"the error line is not the last line of stdout (then: {_short(lines[i + 1:], 200)})")
    others = [x for x in lines[:i] + lines[i + 1:] + o.stderr.splitlines()
              if "error" in x.lower() and not LAUNCHER_NOISE.match(x)]
    if others:
        breaks.append(f"other lines mention 'error': {_short(others[:3], 300)}")
    if fi.words and not any(word in line for word in fi.words):
        breaks.append(f"the error line names none of {sorted(fi.words)}")
    return breaks


# --- reports ------------------------------------------------------------------------------------------

def signature(o):
    """What kind of break (for deduplication): the family and the kinds of its breaks."""
    kinds = [re.sub(r"[:(].*", "", b).strip() for b in o.breaks] or ["kept"]
    return f"{o.fi.family} / {', '.join(kinds)}"


def describe(o, width=240):
    line = o.last_line if len(o.last_line) <= width else o.last_line[:width] + "…"
    note = o.fi.note if len(o.fi.note) <= width else o.fi.note[:width] + "…"
    return (f"[{o.nprocs} rank(s)] {o.fi.family}: {note} (expect {o.fi.expect}) -> exit "
            f"{'TIMEOUT' if o.timed_out else o.returncode}, last line: {line!r}"
            + (f"\n    breaks: {'; '.join(o.breaks)}" if o.breaks else ""))


def save(o, folder):
    """Copy a failing example (its inputs, output folder, command and output) into ``folder``."""
    folder = Path(folder)
    if o.folder is not None and Path(o.folder).exists():
        shutil.copytree(o.folder, folder, symlinks=True, dirs_exist_ok=True)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "command.txt").write_text(" ".join(map(shlex.quote, map(str, o.command))) + "\n")
    if o.folder is not None:  # the same command in the saved folder (the inputs still name the original one)
        here = str(o.folder)
        words = [shlex.quote(str(a)).replace(here, '"$HERE"') for a in o.command]
        (folder / "repro.sh").write_text(f'#!/bin/sh\nHERE="$(cd "$(dirname "$0")" && pwd)"\ncd "$HERE" && '
                                         f'rm -rf out CANARY && {" ".join(words)}\necho "exit $?"\n')
    (folder / "stdout.txt").write_text(o.stdout)
    (folder / "stderr.txt").write_text(o.stderr)
    (folder / "breaks.txt").write_text(describe(o, width=10 ** 6) + "\n" + repr(o.fi) + "\n")
    (folder / "input.json").write_text(json.dumps({
        "family": o.fi.family, "note": o.fi.note, "expect": o.fi.expect, "words": sorted(o.fi.words),
        "args": list(o.fi.args), "problem_file": o.fi.problem_file, "problem_arg": o.fi.problem_arg,
        "nprocs": o.nprocs, "returncode": o.returncode, "timed_out": o.timed_out, "breaks": o.breaks},
        indent=1, ensure_ascii=True))
