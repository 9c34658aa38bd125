"""``shapegrowth study``: the grid, the reference judgement, the Pareto front, resuming."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from conftest import CONFIGS, run_cli

from shapegrowth.commands.study import Sweep, grid, pareto_front, reference_overrides
from shapegrowth.config import ConfigError

BEAM = CONFIGS / "tiny" / "beam_wave.yaml"


def test_sweeps_parse_into_a_product_grid():
    sweeps = [Sweep.parse("mesh.size=0.2, 0.1"),
              Sweep.parse("growth.eigenvalues.initial=[1,1,1],[1.1,1,1]")]
    assert sweeps[1].values == ("[1,1,1]", "[1.1,1,1]")
    points = grid(sweeps)
    assert len(points) == 4 and points[1] == {"mesh.size": "0.2",
                                              "growth.eigenvalues.initial": "[1.1,1,1]"}
    assert reference_overrides(sweeps + [Sweep.parse("model.degree=1,2")], ["mesh.layers=3"]) \
        == ["mesh.size=0.1", "model.degree=2", "mesh.layers=3"]
    # a nested reference judges each point on its own mesh: no finest mesh.size
    assert reference_overrides(sweeps + [Sweep.parse("model.degree=1,2")], ["mesh.refine=1"]) \
        == ["model.degree=2", "mesh.refine=1"]
    with pytest.raises(ConfigError):
        Sweep.parse("mesh.size")


def test_pareto_front_keeps_the_points_nothing_beats():
    cost = np.array([1.0, 2.0, 3.0, 4.0, 2.5])
    error = np.array([0.5, 0.6, 0.2, 0.1, 0.3])
    assert pareto_front(cost, error).tolist() == [0, 4, 2, 3]


@pytest.mark.slow  # 13 s serially and 12.5 s on 2 ranks: the fast tier's largest
@pytest.mark.mpi
def test_study_judges_each_optimum_on_the_reference_and_resumes(shared_tmp):
    args = ["study", BEAM, "--sweep", "mesh.size=0.2,0.1", "--sweep", "model.degree=1,2",
            "--set", "optimizer.max_iterations=3", "--out", shared_tmp, "-q"]
    assert run_cli(*args) == 0
    rows = list(csv.DictReader(open(shared_tmp / "study.csv")))
    assert len(rows) == 4 and (shared_tmp / "study.png").stat().st_size > 5000
    for row in rows:
        for key in ("dofs_state", "dofs_design", "iterations", "wall_time_s", "rho_H_final",
                    "hausdorff_final", "hausdorff_reference", "peak_memory_mb"):
            assert float(row[key]) >= 0, key
    finest = [r for r in rows if r["mesh.size"] == "0.1" and r["model.degree"] == "2"][0]
    # the reference is the finest point itself: its own optimum re-solved gives its numbers
    assert float(finest["hausdorff_reference"]) == pytest.approx(
        float(finest["hausdorff_final"]), rel=1e-6)
    coarse = [r for r in rows if r["mesh.size"] == "0.2" and r["model.degree"] == "1"][0]
    assert int(coarse["dofs_state"]) < int(finest["dofs_state"])
    before = (shared_tmp / "study.csv").read_text()
    assert run_cli(*args) == 0  # every point done: read back, nothing run again
    assert (shared_tmp / "study.csv").read_text() == before


def test_a_bad_sweep_value_is_one_clear_error(tmp_path, capsys):
    status = run_cli("study", BEAM, "--sweep", "mesh.size=0.1,-1,abc", "--out", tmp_path)
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 2
    assert all(line.startswith("error: --sweep mesh.size=") for line in err)
