"""Loading a config: YAML, ``--set`` overrides, the schema's conversion and the
cross-field checks (checks.py, where expressions are parsed, never executed, so a bad
one is caught before any mesh is built).  Every problem found is collected and raised
together as one :class:`ConfigError` whose lines each name the key and what is allowed
(``shapegrowth validate``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml

from .root import Config, validated
from .schema import field_paths, reference_markdown
from .sections import ConfigError


def load(path: str | Path, overrides: list[str] | tuple[str, ...] = ()) -> Config:
    """Read, override and validate a config file; raise :class:`ConfigError` on any problem."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError([f"config: file '{path}' not found"])
    try:
        raw = yaml.safe_load(path.read_text())
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(err, "problem", None) or str(err).splitlines()[0]
        raise ConfigError([f"config: broken YAML in '{path}'{where}: {problem}"]) from None
    if not isinstance(raw, dict):
        raise ConfigError([f"config: '{path}' must hold a mapping of keys, "
                           f"not {type(raw).__name__}"])
    return from_dict(raw, overrides)


def from_dict(raw: dict[str, Any], overrides: list[str] | tuple[str, ...] = ()) -> Config:
    errors: list[str] = []
    raw = apply_overrides(raw, overrides, errors)
    cfg = validated(raw, errors)
    if errors or cfg is None:
        raise ConfigError(errors or ["config: not a valid config"])
    return cfg


_FREE_KEYS = ("parameters", "loads.traction", "solver.petsc_options")


def apply_overrides(raw: dict[str, Any], overrides: list[str] | tuple[str, ...],
                    errors: list[str]) -> dict[str, Any]:
    """Apply ``--set key.sub=value`` items (YAML-typed values) to a copy of ``raw``."""
    import copy

    raw = copy.deepcopy(raw)
    known = field_paths(Config)
    for item in overrides:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key:
            errors.append(f"--set {item}: expected KEY=VALUE, e.g. --set mesh.size=0.05")
            continue
        if key not in known and not any(key.startswith(free + ".") for free in _FREE_KEYS):
            import difflib

            close = difflib.get_close_matches(key, known, n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            errors.append(f"--set {key}: unknown key{hint}")
            continue
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError:
            errors.append(f"--set {key}: value {text!r} is not valid YAML")
            continue
        node = raw
        parts = key.split(".")
        for part in parts[:-1]:
            if not isinstance(node.get(part), dict):
                node[part] = {}
            node = node[part]
        node[parts[-1]] = value
    return raw


def reference_text() -> str:
    """docs/CONFIG.md: every key with its type, default, allowed values and meaning."""
    return reference_markdown(
        Config, "Config reference",
        "Generated from the schema in `shapegrowth/config/sections.py` and `numerics.py` by "
        "`scripts/config_reference.py` (a test fails when this file and the schema differ). "
        "Keys are dotted paths: `--set mesh.size=0.05` overrides one. Numbers may be written "
        "`1e-7`; growth initial values and target maps may be expressions (see README).")
