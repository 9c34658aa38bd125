"""Reachable targets (scripts/reachable.py): a target that a known growth produces is found
again from no growth with the optimiser's defaults, within 3x the known growth's own shape
error on the same mesh (or 0.1 % of the size where the known growth is exact there).  The
short cases run here; the whole set, with every algorithm, is the benchmark
(docs/REACHABLE.md)."""

from __future__ import annotations

import importlib.util
import sys

import pytest
from conftest import ROOT

SHORT = {  # case: settings that make it short
    "bend_1": ("mesh.size=0.1", "optimizer.max_iterations=40"),
    "swell": (),
    "shear": (),
}


def _reachable():
    spec = importlib.util.spec_from_file_location("reachable", ROOT / "scripts" / "reachable.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["reachable"] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
@pytest.mark.parametrize("name", list(SHORT))
def test_the_defaults_find_a_reachable_target(name, tmp_path):
    reachable = _reachable()
    case = next(c for c in reachable.CASES if c.name == name)
    row = reachable.measure(case, None, tmp_path, 1, list(SHORT[name]))
    assert row["algorithm"] == "lbfgs"  # the default
    assert row["final"] <= row["bound"], row


def test_the_bound_is_three_times_the_known_error_or_the_floor():
    reachable = _reachable()
    assert reachable.bound(0.01) == pytest.approx(0.03)
    assert reachable.bound(1e-12) == reachable.FLOOR
