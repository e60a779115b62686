"""Safe parsing of the expressions written in problem files.

A problem file gives loads, c_n, the gap and exact solutions as strings such as ``"100*(1 + x)"``.
They are parsed with :mod:`ast` and evaluated by walking the tree, never by ``eval``: only numbers,
``+ - * / **``, unary signs, the names ``x``, ``y``, ``pi`` and the file's ``[parameters]``, and the
functions below are accepted. The same walker builds a UFL expression (coordinates from
``ufl.SpatialCoordinate``) or a float (for parameters and material constants).
"""
import ast
import math
import operator

import ufl

from .errors import InputError


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
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
           ast.Div: operator.truediv, ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}


def _walk(node, names, functions, text):
    if isinstance(node, ast.Expression):
        return _walk(node.body, names, functions, text)
    if isinstance(node, ast.Constant) and type(node.value) in (int, float):
        return float(node.value)
    if isinstance(node, ast.Name):
        if node.id not in names:
            raise InputError(f"unknown name '{node.id}' in expression '{text}'")
        return names[node.id]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        left = _walk(node.left, names, functions, text)
        right = _walk(node.right, names, functions, text)
        return _BINARY[type(node.op)](left, right)
    if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
        return _UNARY[type(node.op)](_walk(node.operand, names, functions, text))
    if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name)
            and node.func.id in functions and not node.keywords):
        args = [_walk(a, names, functions, text) for a in node.args]
        return functions[node.func.id](*args)
    raise InputError(f"malformed expression '{text}': '{ast.unparse(node)}' is not allowed")


def _parse(text):
    if isinstance(text, (int, float)) and not isinstance(text, bool):
        return ast.Expression(body=ast.Constant(float(text)))
    if not isinstance(text, str):
        raise InputError(f"malformed expression {text!r}: expected a string or a number")
    try:
        return ast.parse(text.strip(), mode="eval")
    except SyntaxError:
        raise InputError(f"malformed expression '{text}'") from None


def to_float(text, parameters=None):
    """Evaluate an expression with no coordinates (parameters, material constants) to a float."""
    names = {"pi": math.pi, **(parameters or {})}
    try:
        value = _walk(_parse(text), names, _FLOAT_FUNCTIONS, text)
        if isinstance(value, complex):
            raise ValueError("the value is complex")
        return float(value)
    except (ValueError, ZeroDivisionError, OverflowError, TypeError) as err:
        raise InputError(f"cannot evaluate expression '{text}': {err}") from None


def to_ufl(text, mesh, parameters=None):
    """UFL expression of x, y (``ufl.SpatialCoordinate(mesh)``) for a problem-file string."""
    tree = _parse(text)
    if not {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)} & {"x", "y"}:
        # No coordinates: evaluate to a number (with the float checks) and keep it attached to the mesh,
        # as dolfinx Expressions need a domain.
        from dolfinx import fem
        return fem.Constant(mesh, to_float(text, parameters))
    x = ufl.SpatialCoordinate(mesh)
    names = {"x": x[0], "y": x[1], "pi": math.pi, **(parameters or {})}
    try:
        return _walk(tree, names, _UFL_FUNCTIONS, text)
    except (ufl.UFLException, TypeError, ValueError, ZeroDivisionError, OverflowError) as err:
        raise InputError(f"cannot evaluate expression '{text}': {err}") from None


def to_ufl_vector(texts, mesh, parameters=None, what="vector"):
    """A 2-vector of expressions, e.g. ``["0", "-1 - y"]``."""
    if not isinstance(texts, (list, tuple)) or len(texts) != 2:
        raise InputError(f"{what} must be a list of two expressions, got {texts!r}")
    return ufl.as_vector([to_ufl(t, mesh, parameters) for t in texts])
