"""A NumPy integrand from an expression string, without ``eval``.

A problem file's ``numpy`` field (and the translation of an OpenCL C
expression, :func:`mcocl.bench.numpy_baseline.translate_opencl`) is a Python
expression over ``x`` of shape ``(dim, n)``.  It comes from a file, so it must
not be able to run anything but arithmetic: the expression is parsed with
:mod:`ast` and every node is checked against a whitelist, then turned into a
tree of closures over NumPy functions.  Nothing is ever passed to ``eval``;
attribute access, names outside the tables below, keyword arguments, strings,
lambdas, comprehensions and everything else are refused with a message naming
what was found.

Allowed: number literals, ``x[k]`` with a literal ``0 <= k < dim``, the
operators ``+ - * / ** %`` (and ``& | ~`` for combining comparisons),
comparisons (chained ones too), ``a if c else b`` (``np.where``), the
functions of :data:`FUNCTIONS` called by their OpenCL name, their NumPy name
(``np.exp``, ``numpy.exp``) or ``math.`` name, and the constants of
:data:`CONSTANTS` (``M_PI``, ``np.pi``, ``math.e``, ...).
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable

import numpy as np

Evaluator = Callable[[np.ndarray], np.ndarray]

# OpenCL C built-ins and their NumPy twins (close enough for a baseline).
OPENCL_FUNCTIONS: dict[str, Callable[..., object]] = {
    "exp": np.exp, "exp2": np.exp2, "expm1": np.expm1, "log": np.log, "log2": np.log2, "log10": np.log10,
    "log1p": np.log1p, "sqrt": np.sqrt, "cbrt": np.cbrt, "rsqrt": lambda v: 1.0 / np.sqrt(v),
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan,
    "atan2": np.arctan2, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh, "pow": np.power, "powr": np.power,
    "pown": np.power, "fabs": np.abs, "fmin": np.minimum, "fmax": np.maximum, "floor": np.floor, "ceil": np.ceil,
    "hypot": np.hypot,
    "native_exp": np.exp, "native_log": np.log, "native_sqrt": np.sqrt, "native_sin": np.sin,
    "native_cos": np.cos, "native_recip": lambda v: 1.0 / v, "native_rsqrt": lambda v: 1.0 / np.sqrt(v),
    "half_exp": np.exp, "half_log": np.log, "half_sqrt": np.sqrt,
}
# NumPy (and math) names a hand-written twin may use after ``np.``, ``numpy.`` or ``math.``.
NUMPY_FUNCTIONS: dict[str, Callable[..., object]] = {
    name: getattr(np, name) for name in (
        "exp", "exp2", "expm1", "log", "log2", "log10", "log1p", "sqrt", "cbrt", "square", "sin", "cos", "tan",
        "arcsin", "arccos", "arctan", "arctan2", "sinh", "cosh", "tanh", "power", "abs", "absolute", "fabs",
        "minimum", "maximum", "floor", "ceil", "hypot", "where", "sign", "reciprocal", "logical_and",
        "logical_or", "logical_not", "heaviside",
    )
}
NUMPY_FUNCTIONS.update({"asin": np.arcsin, "acos": np.arccos, "atan": np.arctan, "atan2": np.arctan2,
                        "pow": np.power, "fmin": np.minimum, "fmax": np.maximum})
FUNCTIONS = {**OPENCL_FUNCTIONS, **NUMPY_FUNCTIONS}

CONSTANTS: dict[str, float] = {
    "M_PI": math.pi, "M_PI_F": math.pi, "M_E": math.e, "M_E_F": math.e, "M_SQRT2": math.sqrt(2),
    "M_SQRT2_F": math.sqrt(2), "M_LN2": math.log(2), "M_LN2_F": math.log(2),
}
MODULE_CONSTANTS = {"pi": math.pi, "e": math.e, "inf": math.inf}
MODULES = ("np", "numpy", "math")

# Far beyond any integrand a person writes; keeps the closure tree's recursion shallow enough.
MAX_LENGTH = 20_000
MAX_NODES = 5_000
MAX_DEPTH = 150

_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.Pow: np.power, ast.Mod: np.fmod, ast.BitAnd: np.logical_and, ast.BitOr: np.logical_or}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos, ast.Invert: np.logical_not, ast.Not: np.logical_not}
_COMPARE = {ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge,
            ast.Eq: operator.eq, ast.NotEq: operator.ne}


class ExpressionError(ValueError):
    """An expression outside the whitelist (the message says what was found)."""


def parse_numpy_expression(text: str, dim: int) -> Evaluator:
    """A function of ``x`` (shape ``(dim, n)``) for a whitelisted expression.

    Raises:
        ExpressionError: it does not parse, is too long, or uses anything but
            the arithmetic described in the module docstring.
    """
    if not isinstance(text, str):
        raise ExpressionError(f"expected a string, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression of {len(text)} characters; at most {MAX_LENGTH} are taken")
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as e:
        raise ExpressionError(f"not a Python expression: {e.msg}") from None
    except (RecursionError, MemoryError, ValueError):
        raise ExpressionError("the expression is nested too deeply to parse") from None
    nodes = sum(1 for _ in ast.walk(tree))
    if nodes > MAX_NODES:
        raise ExpressionError(f"expression of {nodes} syntax nodes; at most {MAX_NODES} are taken")
    if _depth(tree) > MAX_DEPTH:
        raise ExpressionError(f"the expression is nested more than {MAX_DEPTH} levels deep")
    return _build(tree.body, dim)


def _depth(tree: ast.AST) -> int:
    """The nesting depth of ``tree``, counted without recursion (evaluation recurses once per level)."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        stack.extend((c, d + 1) for c in ast.iter_child_nodes(node))
    return deepest


def _constant(value: float) -> Evaluator:
    v = np.float64(value)
    return lambda x: v


def _dotted(node: ast.expr) -> str:
    """The source text of ``node`` for a message (shortened)."""
    text = ast.unparse(node)
    return text if len(text) <= 60 else text[:57] + "..."


def _build(node: ast.expr, dim: int) -> Evaluator:
    """The closure for one whitelisted node (recursively)."""
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
            raise ExpressionError(f"the literal {node.value!r} is not a number")
        try:
            return _constant(float(node.value))
        except OverflowError:
            raise ExpressionError("a number literal too large for float64") from None
    if isinstance(node, ast.Name):
        if node.id in CONSTANTS:
            return _constant(CONSTANTS[node.id])
        if node.id == "x":
            raise ExpressionError("use x[k] (one coordinate), not x itself")
        raise ExpressionError(f"unknown name {node.id!r}")
    if isinstance(node, ast.Attribute):
        if isinstance(node.value, ast.Name) and node.value.id in MODULES and node.attr in MODULE_CONSTANTS:
            return _constant(MODULE_CONSTANTS[node.attr])
        raise ExpressionError(f"the attribute {_dotted(node)!r} is not allowed")
    if isinstance(node, ast.Subscript):
        return _coordinate(node, dim)
    if isinstance(node, ast.BinOp):
        op = _BINARY.get(type(node.op))
        if op is None:
            raise ExpressionError(f"the operator {type(node.op).__name__} is not allowed")
        a, b = _build(node.left, dim), _build(node.right, dim)
        return lambda x: op(a(x), b(x))
    if isinstance(node, ast.UnaryOp):
        uop = _UNARY[type(node.op)]
        a = _build(node.operand, dim)
        return lambda x: uop(a(x))
    if isinstance(node, ast.Compare):
        return _compare(node, dim)
    if isinstance(node, ast.BoolOp):
        parts = [_build(v, dim) for v in node.values]
        combine = np.logical_and if isinstance(node.op, ast.And) else np.logical_or

        def boolop(x: np.ndarray) -> np.ndarray:
            r = parts[0](x)
            for p in parts[1:]:
                r = combine(r, p(x))
            return r
        return boolop
    if isinstance(node, ast.IfExp):
        c, t, f = _build(node.test, dim), _build(node.body, dim), _build(node.orelse, dim)
        return lambda x: np.where(c(x), t(x), f(x))
    if isinstance(node, ast.Call):
        return _call(node, dim)
    raise ExpressionError(f"{type(node).__name__} is not allowed (only arithmetic over x[k] and numbers)")


def _coordinate(node: ast.Subscript, dim: int) -> Evaluator:
    if not (isinstance(node.value, ast.Name) and node.value.id == "x"):
        raise ExpressionError("only x can be indexed (x[k])")
    k = node.slice
    if not (isinstance(k, ast.Constant) and isinstance(k.value, int) and not isinstance(k.value, bool)):
        raise ExpressionError("an index of x must be a whole number literal, as in x[0]")
    i = k.value
    if not 0 <= i < dim:
        raise ExpressionError(f"x[{i}] is outside the dimension {dim} (indices 0..{dim - 1})")
    return lambda x: x[i]


def _compare(node: ast.Compare, dim: int) -> Evaluator:
    terms = [_build(node.left, dim)] + [_build(c, dim) for c in node.comparators]
    ops = []
    for o in node.ops:
        f = _COMPARE.get(type(o))
        if f is None:
            raise ExpressionError(f"the comparison {type(o).__name__} is not allowed")
        ops.append(f)

    def compare(x: np.ndarray) -> np.ndarray:
        vals = [t(x) for t in terms]
        r = ops[0](vals[0], vals[1])
        for j in range(1, len(ops)):
            r = np.logical_and(r, ops[j](vals[j], vals[j + 1]))
        return r
    return compare


def _call(node: ast.Call, dim: int) -> Evaluator:
    name = _dotted(node.func)
    if isinstance(node.func, ast.Name):
        fn = OPENCL_FUNCTIONS.get(node.func.id)
    elif isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name) \
            and node.func.value.id in MODULES:
        fn = FUNCTIONS.get(node.func.attr)
    else:
        fn = None
    if fn is None:
        raise ExpressionError(f"the function {name!r} is not allowed")
    if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
        raise ExpressionError(f"{name}(): only plain positional arguments are allowed")
    if not 1 <= len(node.args) <= 3:
        raise ExpressionError(f"{name}() takes 1 to 3 arguments here, got {len(node.args)}")
    args = [_build(a, dim) for a in node.args]
    return lambda x: fn(*(a(x) for a in args))


__all__ = ["CONSTANTS", "FUNCTIONS", "OPENCL_FUNCTIONS", "ExpressionError", "parse_numpy_expression"]
