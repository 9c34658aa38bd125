"""The package's layers: every import points downwards, nothing imports in a circle, the flat
API resolves, and ``import shapegrowth`` has no side effects.

Layers, bottom to top: base modules (blas, compat, heap, logs, status, timing, version) < config < physics and
shape (side by side, neither imports the other) < optim < io < commands < the package root.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest
from conftest import ROOT

PACKAGE = ROOT / "shapegrowth"
LAYERS = {"blas": 0, "compat": 0, "errors": 0, "heap": 0, "logs": 0, "status": 0, "timing": 0, "version": 0, "config": 1, "physics": 2,
          "shape": 2, "io": 3, "optim": 4, "commands": 5, "": 6, "__main__": 6}


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _imports(name: str, path: Path) -> set[str]:
    """Package modules that ``name`` imports, at module level or inside functions, outside
    ``if TYPE_CHECKING:`` blocks."""
    tree = ast.parse(path.read_text())
    typing_only = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
                   and getattr(node.test, "id", None) == "TYPE_CHECKING"
                   for n in ast.walk(node)}
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    package = [p for p in package if p]
    found = set()
    for node in ast.walk(tree):
        if id(node) in typing_only or not isinstance(node, ast.ImportFrom):
            continue
        if node.level:
            base = package[:len(package) - (node.level - 1)]
        elif node.module and node.module.split(".")[0] == "shapegrowth":
            base = []
            node = ast.ImportFrom(module=node.module.partition(".")[2] or None,
                                  names=node.names, level=0)
        else:
            continue
        stem = base + (node.module.split(".") if node.module else [])
        for alias in node.names:  # ``from . import compat``: the module itself
            candidate = ".".join(stem + [alias.name])
            found.add(candidate if candidate in MODULES else ".".join(stem))
    return {m for m in found if m != name}


def _layer(module: str) -> int:
    return LAYERS[module.split(".")[0]] if module else LAYERS[""]


MODULES = _modules()
LAYERS_BASE = {"blas", "compat", "errors", "logs", "status", "timing", "version", "__main__"}
GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def test_every_module_has_a_layer():
    assert not [m for m in MODULES if m.split(".")[0] not in LAYERS and m]


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_point_downwards(module):
    """A module imports its own subpackage's modules or lower layers, never higher ones;
    physics and shape, on one layer, never import each other."""
    for target in GRAPH[module]:
        same = module and module.split(".")[0] == target.split(".")[0] and module not in LAYERS_BASE
        assert same or _layer(target) < _layer(module), f"{module} imports {target}"


def test_no_import_circle():
    state: dict[str, int] = {}

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in GRAPH.get(node, ()):
            if state.get(nxt) == 1:
                raise AssertionError(" -> ".join(path + [node, nxt]))
            if nxt not in state:
                visit(nxt, path + [node])
        state[node] = 2

    for module in MODULES:
        if module not in state:
            visit(module, [])


def test_the_flat_api_resolves_and_import_has_no_side_effects():
    """Every name of ``shapegrowth.__all__`` resolves; the import itself loads neither
    FEniCSx nor numpy, and sets no environment variable and no logging handler."""
    code = ("import logging, os, sys; env = dict(os.environ); import shapegrowth; "
            "assert 'dolfinx' not in sys.modules and 'numpy' not in sys.modules; "
            "assert dict(os.environ) == env; "
            "assert not logging.getLogger('shapegrowth').handlers; "
            "[getattr(shapegrowth, n) for n in shapegrowth.__all__]; "
            "assert set(shapegrowth.__all__) == {'__version__', *shapegrowth._API}; "
            "assert shapegrowth.load_config.__module__ == 'shapegrowth.config.loading'")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT)
    assert done.returncode == 0, done.stderr


def test_importing_every_module_under_mpi_changes_nothing():
    """Under ``mpirun -n 2`` (where the package does set threads, at first use), importing
    every module leaves the environment, numba's thread count and the package logger as
    they were."""
    modules = sorted(m for m in MODULES if m and m != "__main__")
    code = ("import logging, os, numba; env = dict(os.environ); n = numba.get_num_threads(); "
            f"import importlib; [importlib.import_module('shapegrowth.' + m) for m in {modules}]; "
            "assert dict(os.environ) == env, 'environment'; "
            "assert numba.get_num_threads() == n, 'numba threads'; "
            "assert not logging.getLogger('shapegrowth').handlers, 'handlers'")
    from shapegrowth.commands.launch import launch

    # unbound ranks: bound to one core each, numba would start with one thread anyway
    done = launch(["-c", code], 2, program=[sys.executable], one_thread=False,
                  env={"OMPI_MCA_hwloc_base_binding_policy": "none"}, capture_output=True,
                  text=True, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
