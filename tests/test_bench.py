"""``shapegrowth bench``: bench.json holds every field the contract names, its ratios are
those of its cases, and the MPI run of the largest case computes the serial numbers."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_subprocess


def test_bench_writes_consistent_cases_ratios_and_mpi_run(tmp_path):
    done = run_subprocess(["bench", CONFIGS / "tiny" / "beam_wave.yaml", "--sizes", "0.2,0.1",
                           "--steps", "2", "--ranks", "2", "--out", tmp_path, "-q"],
                          timeout=600)
    assert done.returncode == 0, done.stderr
    bench = read_json(tmp_path / "bench.json")
    cases = bench["cases"]
    assert len(cases) == 2 and cases[0]["dofs"] < cases[1]["dofs"]
    for case in cases:
        for key in ("dofs", "points", "forward_s", "newton_iterations", "adjoint_s",
                    "filter_s", "hausdorff_s", "iteration_s", "peak_memory_mb"):
            assert case[key] >= 0, key
        assert case["points"] > 0 and case["peak_memory_mb"] > 50
        assert case["forward_s"] + case["hausdorff_s"] <= case["iteration_s"] * 1.05
        assert case["adjoint_refinements"] >= 0  # the state's factors were reused
    ratios = bench["ratios"]
    assert ratios["gradient_over_forward"] == max(c["gradient_over_forward"] for c in cases)
    assert ratios["hausdorff_over_iteration"] == pytest.approx(
        max(c["hausdorff_s"] / c["iteration_s"] for c in cases), rel=0.05)
    slope = np.polyfit(np.log([c["dofs"] for c in cases]),
                       np.log([c["iteration_s"] for c in cases]), 1)[0]
    assert bench["scaling_exponent"] == pytest.approx(slope, rel=1e-12)
    mpi = bench["mpi"]
    assert mpi["ranks"] == 2 and mpi["dofs"] == cases[1]["dofs"]
    assert mpi["speedup"] == pytest.approx(cases[1]["iteration_s"] / mpi["iteration_s"])
    assert mpi["case"]["objective"] == pytest.approx(cases[1]["objective"], rel=1e-9)
