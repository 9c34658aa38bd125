"""Named boundaries (``geometry.boundaries``): what a selector means, and the names a config's
body has before any mesh is read.

A selector is one of

* a physical group's name in the body's ``.msh`` (its facets, as the file tags them);
* ``face N`` or ``face N, M, ...``: faces of a CAD part, numbered as gmsh's OpenCASCADE
  kernel imports them (each face's facets are tagged N in the mesh made of it);
* a condition on the reference coordinates in the expression language of the configs, with
  comparisons and ``and``, ``or``, ``not`` besides (``x1 < 1e-6``, ``r > 0.99 and x1 > 5``):
  a boundary facet is selected when the condition holds at its centre, the mean of its
  corners (so a facet that only touches a face with one edge is not on it), the facets of a
  curved face included where the condition allows for the chords' sag (``abs(r - 1) <
  1e-2``, not ``r == 1``).

The built-in bodies' boundaries (``x1_min``, ``inner_rim``, ...) are predefined names; the
mesh's own tags of them are used.
"""

from __future__ import annotations

import ast
import operator
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ExpressionError
from .expressions import COORDINATES, Env, Expression

_COMPARE: dict[type, Callable[[Any, Any], Any]] = {
    ast.Lt: operator.lt, ast.LtE: operator.le, ast.Gt: operator.gt, ast.GtE: operator.ge,
    ast.Eq: operator.eq, ast.NotEq: operator.ne,
}
_FACES = re.compile(r"^\s*faces?\s+(\d+(\s*,\s*\d+)*)\s*$")


class Condition(Expression):
    """An :class:`Expression` that may also compare and combine: its value is a boolean
    array (or a number, which is true where nonzero)."""

    def _compile(self, node: ast.AST) -> Callable[[Env], Any]:
        if isinstance(node, ast.Compare):
            terms = [self._compile(node.left), *(self._compile(c) for c in node.comparators)]
            ops = [_COMPARE[type(op)] for op in node.ops if type(op) in _COMPARE]
            if len(ops) != len(node.ops):
                raise ExpressionError("only <, <=, >, >=, == and != compare")

            def compare(env: Env) -> Any:
                values = [t(env) for t in terms]
                out = np.bool_(True)
                for op, a, b in zip(ops, values, values[1:]):
                    out = np.logical_and(out, op(a, b))
                return out
            return compare
        if isinstance(node, ast.BoolOp):
            parts = [self._compile(v) for v in node.values]
            combine = np.logical_and if isinstance(node.op, ast.And) else np.logical_or

            def boolean(env: Env) -> Any:
                out = np.asarray(parts[0](env)) != 0
                for part in parts[1:]:
                    out = combine(out, np.asarray(part(env)) != 0)
                return out
            return boolean
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            operand = self._compile(node.operand)
            return lambda env: np.logical_not(np.asarray(operand(env)) != 0)
        return super()._compile(node)


@dataclass(frozen=True)
class Selector:
    """What a named boundary is: ``kind`` 'group' (``group``, a physical group's name),
    'faces' (``faces``, CAD face numbers) or 'condition' (``condition``)."""

    name: str
    text: str
    kind: str
    group: str | None = None
    faces: tuple[int, ...] = ()
    condition: Condition | None = None


def parse_selector(name: str, text: str, groups: Iterable[str],
                   params: Iterable[str]) -> Selector:
    """The selector ``text`` of boundary ``name``: a name in ``groups``, ``face N, ...``, or
    a condition over the coordinates and ``params``.  Raises ExpressionError."""
    if not isinstance(text, str) or not text.strip():
        raise ExpressionError("an empty selector")
    if text.strip() in set(groups):
        return Selector(name, text, "group", group=text.strip())
    faces = _FACES.match(text)
    if faces:
        numbers = tuple(int(n) for n in re.split(r"\s*,\s*", faces.group(1).strip()))
        return Selector(name, text, "faces", faces=numbers)
    return Selector(name, text, "condition",
                    condition=Condition(text, [*COORDINATES, *params]))


def msh_physical_names(path: Path) -> dict[str, tuple[int, int]]:
    """The physical groups a gmsh ``.msh`` names, name -> (dimension, tag), read from its
    ``$PhysicalNames`` section (written as text in every version and in binary files)
    without reading the mesh."""
    names: dict[str, tuple[int, int]] = {}
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"$PhysicalNames"):
                count = int(f.readline())
                for _ in range(count):
                    dim, tag, quoted = f.readline().decode(errors="replace").split(None, 2)
                    names[quoted.strip().strip('"')] = (int(dim), int(tag))
                break
            if line.startswith((b"$Nodes", b"$Elements")):
                break  # the names come before the mesh, when there are any
    return names
