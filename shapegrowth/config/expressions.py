"""Safe arithmetic expressions over reference coordinates.

A config may give a growth field or a target map as text such as
``"x3 + 0.15*sin(2*pi*x1/length)"``.  The text is parsed with :mod:`ast` and
every node is checked against a short whitelist (numbers, names, + - * / **,
unary minus and calls of a few numpy functions); the accepted tree is turned
into nested closures.  Nothing is ever passed to ``eval``/``exec``, attribute
access and subscripts are refused, and numbers are floats, so an expression can
neither call Python nor hang on a huge integer power.
"""

from __future__ import annotations

import ast
import operator
from collections.abc import Callable, Iterable, Mapping
from typing import Any

import numpy as np

from ..errors import ExpressionError

FUNCTIONS: dict[str, Callable[..., np.ndarray]] = {
    "sin": np.sin,
    "cos": np.cos,
    "tan": np.tan,
    "exp": np.exp,
    "log": np.log,
    "sqrt": np.sqrt,
    "arctan2": np.arctan2,
    "abs": np.abs,
}
_ARITY = {name: 2 if name == "arctan2" else 1 for name in FUNCTIONS}
CONSTANTS: dict[str, float] = {"pi": float(np.pi)}
COORDINATES = ("x1", "x2", "x3", "r", "theta")

_BINARY = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_UNARY: dict[type, Callable[[Any], Any]] = {ast.USub: operator.neg, ast.UAdd: operator.pos}

Env = Mapping[str, Any]


class Expression:
    """A parsed expression; call it with a mapping of names to arrays."""

    def __init__(self, text: str, names: Iterable[str],
                 functions: Mapping[str, Callable[..., Any]] | None = None):
        """``functions``: what the calls of ``FUNCTIONS``' names stand for (numpy's by
        default; UFL's for a strain-energy density, where numbers stay Python floats)."""
        if not isinstance(text, str) or not text.strip():
            raise ExpressionError("empty expression")
        self.text = text
        self._allowed = set(names) | set(CONSTANTS)
        self._functions = FUNCTIONS if functions is None else functions
        self._number: Callable[[float], Any] = np.float64 if functions is None else float
        try:
            tree = ast.parse(text.strip(), mode="eval")
        except SyntaxError as err:
            raise ExpressionError(f"cannot parse {text!r}: {err.msg}") from None
        self.names: set[str] = set()
        self._fn = self._compile(tree.body)

    def __call__(self, env: Env) -> Any:
        with np.errstate(all="ignore"):
            return self._fn(env)

    def __repr__(self) -> str:
        return f"Expression({self.text!r})"

    def _compile(self, node: ast.AST) -> Callable[[Env], Any]:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float)):
                raise ExpressionError(f"only numbers are allowed as constants, not {node.value!r}")
            # numpy floats overflow to inf, never raise
            value = self._number(node.value)
            return lambda env: value
        if isinstance(node, ast.Name):
            name = node.id
            if name in CONSTANTS:
                value = self._number(CONSTANTS[name])
                return lambda env: value
            if name not in self._allowed:
                allowed = ", ".join(sorted(self._allowed))
                raise ExpressionError(f"unknown name {name!r} (allowed: {allowed})")
            self.names.add(name)
            return lambda env: env[name]
        if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            binary = _BINARY[type(node.op)]
            left, right = self._compile(node.left), self._compile(node.right)
            return lambda env: binary(left(env), right(env))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            unary = _UNARY[type(node.op)]
            operand = self._compile(node.operand)
            return lambda env: unary(operand(env))
        if isinstance(node, ast.Call):
            if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
                allowed = ", ".join(FUNCTIONS)
                raise ExpressionError(f"only the functions {allowed} may be called")
            if node.keywords or len(node.args) != _ARITY[node.func.id]:
                raise ExpressionError(
                    f"{node.func.id} takes {_ARITY[node.func.id]} positional argument(s)"
                )
            fn = self._functions[node.func.id]
            args = [self._compile(a) for a in node.args]
            return lambda env: fn(*(a(env) for a in args))
        raise ExpressionError(f"{type(node).__name__} is not allowed in an expression")


def coordinate_env(x: np.ndarray, axis: int = 3) -> dict[str, np.ndarray]:
    """Names ``x1, x2, x3, r, theta`` for points ``x`` of shape (3, n).

    ``r, theta`` are cylindrical about X3 (``axis=3``) or about X1 (``axis=1``,
    the tube), theta measured from X2 towards X3 in the latter case.
    """
    x1, x2, x3 = x[0], x[1], x[2]
    if axis == 1:
        r, theta = np.hypot(x2, x3), np.arctan2(x3, x2)
    else:
        r, theta = np.hypot(x1, x2), np.arctan2(x2, x1)
    return {"x1": x1, "x2": x2, "x3": x3, "r": r, "theta": theta}


def evaluate(expr: float | str | Expression, x: np.ndarray, params: Mapping[str, float],
             axis: int = 3) -> np.ndarray:
    """A number or an expression evaluated at points ``x`` (3, n) -> (n,)."""
    n = x.shape[1]
    if isinstance(expr, (int, float)):
        return np.full(n, float(expr))
    if isinstance(expr, str):
        expr = Expression(expr, [*COORDINATES, *params])
    env: dict[str, np.ndarray | float] = dict(params)
    env.update(coordinate_env(x, axis))
    return np.broadcast_to(np.asarray(expr(env), dtype=float), (n,)).copy()
