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


def test_bench_runs_times_a_whole_run_to_its_verified_error(tmp_path):
    """bench --runs: the free square on a coarse mesh, checked every 2 iterations: the time
    to a verified error is the run's clock at the first check below it (its verification
    time apart), the best verified error is the least of the checks and the end, and
    bench.json keeps the per-iteration part it already held."""
    from shapegrowth.io.along import read_checks

    (tmp_path / "bench.json").write_text('{"cases": []}')
    done = run_subprocess(["bench", "--runs", "square_circle_free", "--ranks", "1", "--out",
                           tmp_path, "-q", "--set", "optimizer.max_iterations=6",
                           "--set", "mesh.size=1.0", "--set", "verify.every=2"], timeout=600)
    assert done.returncode == 0, done.stderr
    bench = read_json(tmp_path / "bench.json")
    assert bench["cases"] == [] and len(bench["runs"]) == 1
    run = bench["runs"][0]
    folder = tmp_path / "runs" / "square_circle_free"
    checks = read_checks(folder / "verified.csv")
    summary = read_json(folder / "summary.json")
    assert [c.iteration for c in checks] == [1, 3, 5]
    verified = [c.verified_relative for c in checks] + [summary["verified"]["relative"]]
    assert run["best_verified"] == min(verified)
    assert run["final_verified"] == summary["verified"]["relative"]
    assert run["run_s"] == pytest.approx(summary["wall_time_s"]
                                         - checks[-1].verification_seconds)
    assert run["split"]["verification"] > checks[-1].verification_seconds
    assert run["peak_memory_mb"] == summary["peak_memory_mb"] > 50
    hit = next((c for c in checks if c.verified_relative <= 0.01), None)
    assert run["to_1pc_s"] == (hit.seconds if hit else None) or (
        hit is None and summary["verified"]["relative"] <= 0.01)
    # a named run that does not exist: one line naming the runs there are
    bad = run_subprocess(["bench", "--runs", "nothing", "--out", tmp_path, "-q"])
    assert bad.returncode == 2 and "bench --runs: no run named nothing" in bad.stderr
