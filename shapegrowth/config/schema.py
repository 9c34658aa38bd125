"""A small declarative schema on frozen dataclasses.

Each config section is a frozen dataclass whose fields carry their help text
and allowed values in ``metadata`` (see :func:`option`).  :func:`build` turns a
YAML mapping into the dataclass, appending one line per problem to ``errors``
instead of stopping at the first, so that ``shapegrowth validate`` can report
everything at once.  The same metadata drives the generated config reference.
"""

from __future__ import annotations

import dataclasses
import difflib
import re
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, Union

MISSING = dataclasses.MISSING
_FLOAT_LITERAL = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


def option(help: str, default: Any = MISSING, *, choices: Sequence[Any] | None = None,
           gt: float | None = None, ge: float | None = None, le: float | None = None,
           lt: float | None = None) -> Any:
    """A dataclass field with its help text and allowed range or values."""
    meta = {"help": help, "choices": tuple(choices) if choices else None,
            "gt": gt, "ge": ge, "le": le, "lt": lt}
    if default is MISSING:
        return dataclasses.field(metadata=meta)
    if isinstance(default, (dict, list)) or dataclasses.is_dataclass(default):
        return dataclasses.field(default_factory=lambda: _copy(default), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _copy(value: Any) -> Any:
    if isinstance(value, dict):
        return dict(value)
    if isinstance(value, list):
        return list(value)
    return value


def describe(tp: Any) -> str:
    """Human words for a type annotation, used in error messages."""
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if tp is float:
        return "a number"
    if tp is int:
        return "an integer"
    if tp is bool:
        return "true or false"
    if tp is str:
        return "a string"
    if tp is type(None):
        return "null"
    if dataclasses.is_dataclass(tp):
        return "a mapping"
    if origin in (Union, types.UnionType):
        return " or ".join(describe(a) for a in args)
    if origin is tuple:
        if len(args) == 2 and args[1] is Ellipsis:
            return f"a list of {_plural(describe(args[0]))}"
        return f"a list of {len(args)} {_plural(describe(args[0]))}"
    if origin is dict:
        return f"a mapping of names to {_plural(describe(args[1]))}"
    return str(tp)


def _plural(words: str) -> str:
    for article in ("a ", "an "):
        if words.startswith(article):
            words = words[len(article):]
    if words.startswith("list of "):
        return "lists of " + words[len("list of "):]
    if words in ("true or false", "null"):
        return words
    return words.replace("number", "numbers").replace("integer", "integers").replace(
        "string", "strings").replace("mapping", "mappings")


def _show(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


class _Invalid(Exception):
    pass


def convert(value: Any, tp: Any, path: str, errors: list[str]) -> Any:
    """Convert a YAML value to ``tp``; on failure append a line and return None."""
    try:
        return _convert(value, tp, path, errors)
    except _Invalid:
        errors.append(f"{path}: expected {describe(tp)}, got {_show(value)}")
        return None


def _convert(value: Any, tp: Any, path: str, errors: list[str]) -> Any:
    origin, args = typing.get_origin(tp), typing.get_args(tp)
    if dataclasses.is_dataclass(tp):
        if not isinstance(value, dict):
            raise _Invalid
        return build(tp, value, path, errors)
    if origin in (Union, types.UnionType):
        if value is None and type(None) in args:
            return None
        first: tuple[Any, list[str]] | None = None  # a member that took it with problems
        for member in args:
            if member is type(None):
                continue
            trial: list[str] = []
            try:
                result = _convert(value, member, path, trial)
            except _Invalid:
                continue
            if not trial:
                return result
            first = first or (result, trial)  # a later member may take it cleanly
        if first is not None:
            errors.extend(first[1])
            return first[0]
        raise _Invalid
    if tp is float:
        if isinstance(value, str) and _FLOAT_LITERAL.fullmatch(value.strip()):
            return float(value)  # YAML 1.1 reads 1e-7 (no dot) as a string
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise _Invalid
        return float(value)
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            if isinstance(value, float) and value.is_integer():
                return int(value)
            raise _Invalid
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise _Invalid
        return value
    if tp is str:
        if not isinstance(value, str):
            raise _Invalid
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)):
            raise _Invalid
        if len(args) == 2 and args[1] is Ellipsis:
            item_types = [args[0]] * len(value)
        else:
            if len(value) != len(args):
                raise _Invalid
            item_types = list(args)
        items = [convert(item, item_tp, f"{path}[{i}]", errors)
                 for i, (item, item_tp) in enumerate(zip(value, item_types))]
        if any(item is None and not _accepts_none(item_tp)
               for item, item_tp in zip(items, item_types)):
            return None  # an item's problem is recorded; no rule sees the broken whole
        return tuple(items)
    if origin is dict:
        if not isinstance(value, dict):
            raise _Invalid
        entries = {str(k): convert(v, args[1], f"{path}.{k}", errors) for k, v in value.items()}
        if not _accepts_none(args[1]) and any(v is None for v in entries.values()):
            return None
        return entries
    raise TypeError(f"unsupported annotation {tp!r} at {path}")  # a schema bug, not user input


def build(cls: Any, raw: dict[str, Any], path: str, errors: list[str]) -> Any:
    """Build dataclass ``cls`` from mapping ``raw``, collecting problems in ``errors``."""
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    prefix = f"{path}." if path else ""
    for key in raw:
        if key not in fields:
            close = difflib.get_close_matches(str(key), fields, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else f" (allowed: {', '.join(fields)})"
            errors.append(f"{prefix}{key}: unknown key{hint}")
    values: dict[str, Any] = {}
    for name, f in fields.items():
        key_path = f"{prefix}{name}"
        if name not in raw:
            if f.default is MISSING and f.default_factory is MISSING:
                errors.append(f"{key_path}: required ({f.metadata.get('help', '')})")
            continue
        value = convert(raw[name], hints[name], key_path, errors)
        if value is not None and not _check_range(value, f.metadata, key_path, errors):
            continue  # a value outside its choices is not kept: no later rule sees it
        values[name] = value
    try:
        return cls(**{k: v for k, v in values.items() if v is not None or _accepts_none(hints[k])})
    except TypeError:
        return None  # a required field failed; its problem is already recorded


def _accepts_none(tp: Any) -> bool:
    return typing.get_origin(tp) in (Union, types.UnionType) and type(None) in typing.get_args(tp)


def _check_range(value: Any, meta: Mapping[str, Any], path: str, errors: list[str]) -> bool:
    """Append ``value``'s problems with its choices or bounds; False where it is not one of
    its choices (the rules that depend on a choice, e.g. a geometry kind's parameters, must
    not see it)."""
    choices = meta.get("choices")
    if choices and value not in choices:
        allowed = ", ".join(map(str, choices))
        errors.append(f"{path}: {_show(value)} is not allowed (allowed: {allowed})")
        return False
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return True
    checks = (("gt", lambda a, b: a > b, ">"), ("ge", lambda a, b: a >= b, ">="),
              ("lt", lambda a, b: a < b, "<"), ("le", lambda a, b: a <= b, "<="))
    for key, ok, sign in checks:
        bound = meta.get(key)
        if bound is not None and not ok(value, bound):
            errors.append(f"{path}: {_show(value)} must be {sign} {bound}")
    return True


def field_paths(cls: Any, prefix: str = "") -> dict[str, Any]:
    """Every dotted key of the schema with its annotation (for ``--set`` checks)."""
    hints = typing.get_type_hints(cls)
    paths: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        tp = hints[f.name]
        key = f"{prefix}{f.name}"
        paths[key] = tp
        inner = [a for a in typing.get_args(tp) if a is not type(None)] or [tp]
        for candidate in inner:
            if dataclasses.is_dataclass(candidate):
                paths.update(field_paths(candidate, key + "."))
    return paths


def reference_markdown(cls: type, title: str, intro: str) -> str:
    """The config reference as Markdown, one table per section, from the fields' metadata
    (docs/CONFIG.md is this text; a test keeps them equal)."""
    lines = [f"# {title}", "", intro, ""]
    _reference_section(cls, "", lines)
    return "\n".join(lines).rstrip() + "\n"


def _reference_section(cls: Any, prefix: str, lines: list[str]) -> None:
    hints = typing.get_type_hints(cls)
    rows, sections = [], []
    for f in dataclasses.fields(cls):
        tp, meta = hints[f.name], f.metadata
        key = f"{prefix}{f.name}"
        inner = [a for a in typing.get_args(tp) if a is not type(None)] or [tp]
        nested = next((a for a in inner if dataclasses.is_dataclass(a)), None)
        if nested is not None:
            sections.append((key, nested, meta.get("help", "")))
            continue
        if f.default is not MISSING:
            default = f"`{_yaml(f.default)}`"
        elif f.default_factory is not MISSING:
            default = f"`{_yaml(f.default_factory())}`"
        else:
            default = "required"
        allowed = describe(tp)
        if meta.get("choices"):
            allowed = "one of " + ", ".join(f"`{c}`" for c in meta["choices"])
        bounds = [f"{sign} {meta[k]}" for k, sign in (("gt", ">"), ("ge", ">="), ("lt", "<"),
                                                      ("le", "<=")) if meta.get(k) is not None]
        if bounds:
            allowed += " (" + ", ".join(bounds) + ")"
        rows.append(f"| `{key}` | {allowed} | {default} | {meta.get('help', '')} |")
    if rows:
        title = f"`{prefix.rstrip('.')}`" if prefix else "Top level"
        lines += [f"## {title}", "",
                  "| key | allowed | default | meaning |", "| --- | --- | --- | --- |", *rows, ""]
    for key, nested, help_text in sections:
        lines_before = len(lines)
        _reference_section(nested, key + ".", lines)
        if len(lines) > lines_before and help_text:
            lines.insert(lines_before + 2, f"{help_text[0].upper()}{help_text[1:]}.\n")


def _yaml(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_yaml(v)}" for k, v in value.items()) + "}"
    return str(value)
