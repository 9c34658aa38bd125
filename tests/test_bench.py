"""``shapegrowth bench``: bench.json holds every field the contract names, its ratios are
those of its cases, and the MPI run of the largest case computes the serial numbers."""

from __future__ import annotations

import os

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_subprocess

from shapegrowth import blas


@pytest.mark.slow
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
    # the kernels OpenBLAS ran: those named for this CPU, or the user's (shapegrowth/blas.py)
    asked = os.environ.get("OPENBLAS_CORETYPE") or blas.openblas_coretype()
    kernels = {c["blas_kernels"] for c in cases}
    assert kernels == {None} or asked is None or kernels == {asked}
    mpi = bench["mpi"]
    assert mpi["ranks"] == 2 and mpi["dofs"] == cases[1]["dofs"]
    assert mpi["speedup"] == pytest.approx(cases[1]["iteration_s"] / mpi["iteration_s"])
    assert mpi["case"]["objective"] == pytest.approx(cases[1]["objective"], rel=1e-9)
    # --scaling into the same folder: bench.json keeps the cases and gains the table
    done = run_subprocess(["bench", CONFIGS / "tiny" / "beam_wave.yaml", "--sizes", "0.2",
                           "--steps", "1", "--scaling", "2", "--out", tmp_path, "-q"],
                          timeout=600)
    assert done.returncode == 0, done.stderr
    bench = read_json(tmp_path / "bench.json")
    assert bench["cases"] == cases
    scaling = bench["scaling"]
    assert [r["ranks"] for r in scaling["rows"]] == [1, 2] and scaling["mesh_size"] == 0.2
    one, two = scaling["cases"]["1"], scaling["cases"]["2"]
    assert two["ranks"] == 2 and two["objective"] == pytest.approx(one["objective"], rel=1e-9)
    assert scaling["rows"][1]["speedup_iteration"] == pytest.approx(
        one["iteration_s"] / two["iteration_s"])


@pytest.mark.slow
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


def test_amdahls_serial_fraction_is_recovered_and_oversubscribed_runs_are_not_fitted():
    """A synthetic case set with T(p) = T(1) (f + (1 - f)/p) per part: the fit returns each
    part's f and the speedup it projects; a rank count beyond the cores is reported but
    left out of the fit (its time here is made ten times worse)."""
    from shapegrowth.commands.bench_scaling import amdahl, scaling_table, serial_fraction

    assert serial_fraction([1, 2, 4], [10.0, 10 * (0.2 + 0.8 / 2), 10 * (0.2 + 0.8 / 4)]) \
        == pytest.approx(0.2, rel=1e-12)
    assert amdahl(0.2, 16) == pytest.approx(1 / (0.2 + 0.8 / 16))
    fractions = {"forward_s": 0.3, "hausdorff_s": 0.05, "adjoint_s": 0.5}

    def case(p: int, worse: float = 1.0) -> dict:
        c = {k: worse * 2.0 * (f + (1 - f) / p) for k, f in fractions.items()}
        c.update({"sensitivities_s": 0.0, "filter_backward_s": 0.0, "dofs": 100,
                  "newton_iterations": 4.0})
        c["iteration_s"] = c["forward_s"] + c["hausdorff_s"] + c["adjoint_s"]
        return c

    table = scaling_table({1: case(1), 2: case(2), 4: case(4, worse=10.0)}, ncores=2)
    assert table["fitted_on"] == [1, 2]
    assert [r["oversubscribed"] for r in table["rows"]] == [False, False, True]
    assert table["amdahl"]["forward"]["serial_fraction"] == pytest.approx(0.3, rel=1e-9)
    assert table["amdahl"]["hausdorff"]["serial_fraction"] == pytest.approx(0.05, rel=1e-9)
    assert table["amdahl"]["gradient"]["speedup_64"] == pytest.approx(amdahl(0.5, 64))
    assert table["rows"][1]["speedup_forward"] == pytest.approx(1 / (0.3 + 0.7 / 2))


@pytest.mark.slow  # a bench process of its own compiling its forms (17.9 s on a fresh clone)
def test_a_bench_case_without_equilibrium_is_one_line(tmp_path):
    """A setting under which the bench's growth finds no equilibrium (here: one Newton
    iteration per step, no step cutting; measured the same with `solver.linear: gamg`, whose
    linear solve fails on the thin beam) ends the bench with one line naming the solve and
    the keys to look at, not a traceback."""
    done = run_subprocess(["bench", CONFIGS / "tiny" / "beam_wave.yaml", "--sizes", "0.2",
                           "--steps", "1", "--ranks", "1", "--out", tmp_path, "-q",
                           "--set", "solver.max_newton_iterations=1",
                           "--set", "solver.continuation.min_step=0.1"], timeout=600)
    assert done.returncode == 2
    err = done.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: bench: no equilibrium"), err
    assert "solver." in err[0]


@pytest.mark.parametrize("flag, value", [("--sizes", "0.1,x"), ("--sizes", "-1"),
                                         ("--scaling", "0,2"), ("--scaling", "two")])
def test_bad_sizes_and_rank_counts_name_their_flag(flag, value, tmp_path):
    done = run_subprocess(["bench", flag, value, "--out", tmp_path], timeout=60)
    assert done.returncode == 2
    assert f"argument {flag}: " in done.stderr.strip().splitlines()[-1]


def test_the_command_line_has_no_hidden_option():
    """Every option of every command is in its --help: the benchmark's per-case worker is a
    module of its own (shapegrowth.commands.bench_case), not a hidden flag."""
    import argparse

    from shapegrowth.commands.cli import build_parser

    parser = build_parser()
    commands = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    for name, sub in commands.choices.items():
        hidden = [a.dest for a in sub._actions if a.help == argparse.SUPPRESS]
        assert not hidden, (name, hidden)


def test_a_bench_case_worker_with_a_bad_config_is_one_line(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "shapegrowth.commands.bench_case",
                           str(CONFIGS / "tiny" / "beam_wave.yaml"), "--out", str(tmp_path),
                           "--set", "mesh.size=-1"], capture_output=True, text=True,
                          timeout=120)
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == ["error: mesh.size: -1.0 must be > 0"]
    assert not (tmp_path / "case.json").exists()
