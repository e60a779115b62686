"""Safe parsing of the expressions written in problem files.

A problem file gives loads, c_n, the gap and exact solutions as strings such as ``"100*(1 + x)"``.
They are parsed with :mod:`ast` and evaluated by walking the tree, never by ``eval``: only numbers,
``+ - * / **``, unary signs, the coordinates ``x``, ``y`` (and ``z`` on a 3D mesh), ``pi``, the file's
``[parameters]`` and the functions below are accepted.

The same walker gives a float (:func:`to_float`: parameters, material constants) or a UFL expression
(:func:`to_ufl`). In UFL every *coordinate-free* subtree — a number, a parameter, ``2*p + 1`` — is folded
into one ``fem.Constant`` holding its value. The compiled forms therefore do not depend on the values
written in a problem file: a new c_n, m_n, load or parameter reuses them (no JIT compilation), while
every quadrature degree that UFL estimates stays what it is for literal numbers (a Constant, like a
literal, has degree 0). The one exception is an exponent (``x**2``, ``pos(x)**(3*m)``): it stays a literal,
because UFL's degree estimate and its simplifications (``a**1`` → ``a`` in the derivatives of ``a**3``)
depend on its value; a new exponent in an expression of the coordinates compiles that form again.
"""
import ast
import math
import operator

import numpy as np
import ufl

from .. import dolfinx_versions as versions
from ..errors import InputError, brief, brief_text

COORDINATES = ("x", "y", "z")


def positive_part(a):
    """(a)_+ for UFL expressions; written with a conditional so its derivative is a Heaviside."""
    return ufl.conditional(ufl.gt(a, 0), a, 0)


_UFL_FUNCTIONS = {
    "sin": ufl.sin, "cos": ufl.cos, "tan": ufl.tan, "exp": ufl.exp, "log": ufl.ln,
    "sqrt": ufl.sqrt, "abs": abs, "max": ufl.max_value, "min": ufl.min_value, "pos": positive_part,
}
_FLOAT_FUNCTIONS = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "exp": math.exp, "log": math.log,
    "sqrt": math.sqrt, "abs": abs, "max": max, "min": min, "pos": lambda a: max(a, 0.0),
}
FUNCTIONS = tuple(sorted(_FLOAT_FUNCTIONS))
_ARRAY_FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log, "sqrt": np.sqrt,
    "abs": np.abs, "max": np.maximum, "min": np.minimum, "pos": lambda a: np.maximum(a, 0.0),
}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}


_WHITESPACE = str.maketrans("\t\n\r\f\v", "     ")
MAX_LENGTH = 20000  # characters of an expression
MAX_DEPTH = 500     # nesting of its tree (a sum of n terms nests n deep): UFL and FFCx recurse over it


def _parse(text):
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return ast.Expression(body=ast.Constant(float(text)))
    if not isinstance(text, str):
        raise InputError(f"malformed expression {brief(text)}: expected a string or a number")
    if len(text) > MAX_LENGTH:
        raise InputError(f"expression '{brief_text(text)}' is longer than {MAX_LENGTH} characters")
    text = text.translate(_WHITESPACE)  # a tab or a line break is whitespace, as a space is
    if not text.isprintable():
        raise InputError(f"expression '{brief_text(text)}' contains a control character")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except (SyntaxError, ValueError):  # (ValueError: an integer of more digits than Python converts)
        raise InputError(f"malformed expression '{brief_text(text)}'") from None
    except (RecursionError, MemoryError):
        raise InputError(f"expression '{brief_text(text)}' is nested more than {MAX_DEPTH} deep") from None
    if _depth(tree.body) > MAX_DEPTH:
        raise InputError(f"expression '{brief_text(text)}' is nested more than {MAX_DEPTH} deep (a sum of "
                         f"more than {MAX_DEPTH} terms, or as many signs or brackets): write it with parameters")
    return tree


def _depth(node):
    """The depth of an expression's tree, found without recursion."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((child, depth + 1) for child in ast.iter_child_nodes(node) if isinstance(child, ast.expr))
    return deepest


def _check_node(node, text):
    """Only numbers, names, + - * / **, unary signs and calls of the known functions."""
    allowed = (isinstance(node, ast.Constant) and type(node.value) in (int, float)) \
        or isinstance(node, ast.Name) \
        or (isinstance(node, ast.BinOp) and type(node.op) in _BINARY) \
        or (isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY) \
        or (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
            and node.func.id in _FLOAT_FUNCTIONS and not node.keywords)
    if not allowed:
        raise InputError(f"malformed expression '{brief_text(text)}': '{brief_text(ast.unparse(node))}' is not allowed")


def _evaluate(node, names, functions, text):
    """Walk the tree with ``names`` and ``functions`` (floats or UFL)."""
    _check_node(node, text)
    if isinstance(node, ast.Constant):
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id not in names:
            raise InputError(f"unknown name '{brief_text(node.id)}' in expression '{brief_text(text)}'")
        return names[node.id]
    if isinstance(node, ast.BinOp):
        return _BINARY[type(node.op)](_evaluate(node.left, names, functions, text),
                                      _evaluate(node.right, names, functions, text))
    if isinstance(node, ast.UnaryOp):
        return _UNARY[type(node.op)](_evaluate(node.operand, names, functions, text))
    return functions[node.func.id](*(_evaluate(a, names, functions, text) for a in node.args))


def names_in(text):
    """The names an expression uses (coordinates, parameters, functions excluded)."""
    tree = _parse(text)
    called = {n.func.id for n in ast.walk(tree) if isinstance(n, ast.Call) and isinstance(n.func, ast.Name)}
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} - called


def uses_coordinates(text):
    return bool(names_in(text) & set(COORDINATES))


def to_float(text, parameters=None):
    """Evaluate an expression with no coordinates (parameters, material constants) to a finite float."""
    tree = _parse(text)
    return _float_of(tree.body, {"pi": math.pi, **(parameters or {})}, text)


def _float_of(node, names, text):
    try:
        value = _evaluate(node, names, _FLOAT_FUNCTIONS, text)
        if isinstance(value, complex):
            raise ValueError("the value is complex")
        value = float(value)
    except (ValueError, ZeroDivisionError, OverflowError, TypeError) as err:
        raise InputError(f"cannot evaluate expression '{brief_text(text)}': {err}") from None
    if not math.isfinite(value):
        raise InputError(f"expression '{brief_text(text)}' is not a finite number ({value})")
    return value


def values_at(text, points, parameters=None):
    """The expression's values at ``points`` (n, gdim) as an array of n floats, computed in double
    precision as the forms will: inf or NaN where it overflows or divides by zero (no error raised). The
    same walker as :func:`to_ufl`, with NumPy's functions: no form is compiled."""
    points = np.asarray(points, dtype=float)
    names = {"pi": math.pi, **(parameters or {}),
             **{name: points[:, i] for i, name in enumerate(COORDINATES[:points.shape[1]])}}
    with np.errstate(all="ignore"):
        try:
            value = _evaluate(_parse(text).body, names, _ARRAY_FUNCTIONS, text)
            value = np.asarray(value, dtype=float)
        except (ZeroDivisionError, OverflowError, ValueError, TypeError):
            value = np.asarray(np.nan)
    return np.broadcast_to(value, (len(points),))


def to_sympy(text, coordinates, parameters=None):
    """A sympy expression of the problem-file expression ``text`` (``coordinates``: name → sympy symbol),
    by the same checked walker as :func:`to_ufl`: what sympy then derives (an implicit surface's gradient,
    :class:`~nc_dolfinx.mesh.surfaces.Implicit`) is derived from what the file wrote, never from ``eval``."""
    import sympy
    functions = {"sin": sympy.sin, "cos": sympy.cos, "tan": sympy.tan, "exp": sympy.exp, "log": sympy.log,
                 "sqrt": sympy.sqrt, "abs": sympy.Abs, "max": sympy.Max, "min": sympy.Min,
                 "pos": lambda a: sympy.Max(a, 0)}
    names = {"pi": sympy.pi, **{k: sympy.Float(v) for k, v in (parameters or {}).items()}, **coordinates}
    try:
        return sympy.sympify(_evaluate(_parse(text).body, names, functions, text))
    except (TypeError, ValueError, ZeroDivisionError, OverflowError) as err:
        raise InputError(f"cannot evaluate expression '{brief_text(text)}': {err}") from None


def check(text, parameters=None, coordinates=COORDINATES):
    """Validate an expression without a mesh: syntax, names and, with coordinates set to 0.5, arithmetic
    that fails everywhere (``1/0``). Raises InputError naming the problem."""
    tree = _parse(text)
    for node in ast.walk(tree.body):
        if isinstance(node, ast.expr):
            _check_node(node, text)
    known = set(coordinates) | {"pi"} | set(parameters or {})
    unknown = sorted(names_in(text) - known)
    if unknown:
        raise InputError(f"unknown name '{brief_text(unknown[0])}' in expression '{brief_text(text)}'")
    _fold_constant_subtrees(tree.body, parameters or {}, text)


def _fold_constant_subtrees(node, parameters, text):
    """Evaluate every maximal coordinate-free subtree (so that ``1/0`` fails here, not in a form)."""
    if not {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} & set(COORDINATES):
        _float_of(node, {"pi": math.pi, **parameters}, text)
        return
    _check_node(node, text)
    for child in (node.args if isinstance(node, ast.Call) else ast.iter_child_nodes(node)):
        if isinstance(child, ast.expr):
            _fold_constant_subtrees(child, parameters, text)


class _ConstantFolder:
    """Builds a UFL expression; every coordinate-free subtree becomes ``fold(value)``."""

    def __init__(self, coordinates, parameters, text, fold):
        self.coordinates, self.parameters, self.text, self.fold = coordinates, parameters, text, fold

    def visit(self, node):
        if _coordinate_free(node):
            return self.fold(_float_of(node, {"pi": math.pi, **self.parameters}, self.text))
        _check_node(node, self.text)
        if isinstance(node, ast.Name):
            if node.id not in self.coordinates:
                raise InputError(f"unknown name '{brief_text(node.id)}' in expression '{brief_text(self.text)}' "
                                 f"(the coordinates of this mesh are {', '.join(self.coordinates)})")
            return self.coordinates[node.id]
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and _coordinate_free(node.right):
            # An exponent stays a literal: UFL's degree estimate and simplifications (a**1 -> a in the
            # derivatives of a**3) depend on its value, and the quadrature degrees must not move.
            return self.visit(node.left) ** _float_of(node.right, {"pi": math.pi, **self.parameters}, self.text)
        if isinstance(node, ast.BinOp):
            return _BINARY[type(node.op)](self.visit(node.left), self.visit(node.right))
        if isinstance(node, ast.UnaryOp):
            return _UNARY[type(node.op)](self.visit(node.operand))
        return _UFL_FUNCTIONS[node.func.id](*(self.visit(a) for a in node.args))


def _coordinate_free(node):
    return not {n.id for n in ast.walk(node) if isinstance(n, ast.Name)} & set(COORDINATES)


def to_ufl(text, mesh, parameters=None):
    """UFL expression of the mesh coordinates for a problem-file expression (values as fem.Constants)."""
    from dolfinx import fem
    x = ufl.SpatialCoordinate(mesh)
    coordinates = {name: x[i] for i, name in enumerate(COORDINATES[:mesh.geometry.dim])}
    fold = lambda value: fem.Constant(mesh, np.float64(value))  # noqa: E731
    try:
        return _ConstantFolder(coordinates, parameters or {}, text, fold).visit(_parse(text).body)
    except (*versions.UFL_ERRORS, TypeError, ValueError, ZeroDivisionError, OverflowError) as err:
        raise InputError(f"cannot evaluate expression '{brief_text(text)}': {err}") from None


def to_ufl_vector(texts, mesh, parameters=None, what="vector"):
    """A vector with one expression per coordinate, e.g. ``["0", "-1 - y"]`` on a 2D mesh."""
    dim = mesh.geometry.dim
    if not isinstance(texts, (list, tuple)) or len(texts) != dim:
        count = len(texts) if isinstance(texts, (list, tuple)) else "not a list of"
        raise InputError(f"{what} has {count} components but the mesh is {dim}D: give {dim} expressions")
    return ufl.as_vector([to_ufl(t, mesh, parameters) for t in texts])
