"""The objective on real bodies: summary fields, mesh-file targets, degenerate targets."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from conftest import CONFIGS, read_json, run_cli
from shapegrowth.config import load
from shapegrowth.forward import ForwardModel
from shapegrowth.geometry import mesh_path
from shapegrowth.objective import Objective

BEAM = CONFIGS / "tiny" / "beam_wave.yaml"
CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"


@pytest.mark.mpi
def test_solve_reports_the_shape_error(shared_tmp):
    assert run_cli("solve", BEAM, "--out", shared_tmp, "-q") == 0
    s = read_json(shared_tmp / "summary.json")
    # the extent of the target's sample points (quadrature points, inside the cells): 0.986
    assert s["target_size"] == pytest.approx(1.0, rel=0.02)
    assert 0 < s["rho_H_initial"] == s["rho_H_final"] == s["objective_final"]
    # the bent beam's tip is far from the wave: the exact Hausdorff distance sees it
    assert 0.1 < s["hausdorff_final"] < 1.0
    assert s["time_split"]["hausdorff"] > 0


@pytest.mark.mpi
def test_mesh_file_target_equals_the_same_shape_given_as_a_map(shared_tmp):
    """The cube's own mesh file as target is the identity map: the same quadrature
    points with the same weights, so rho_H agrees to round-off."""
    base = ["growth.eigenvalues.initial=[1.21, 1.0, 0.81]", f"mesh.cache_dir={shared_tmp}"]
    by_map = load(CUBE, base + ["target.map=[x1, x2, x3]"])
    model = ForwardModel.build(by_map)
    model.state.solve()
    value_map, _ = Objective(by_map, model.state).evaluate(gradient=False)
    msh = mesh_path(by_map)
    by_mesh = load(CUBE, base + [f"target.mesh={msh}"])
    value_mesh, _ = Objective(by_mesh, model.state).evaluate(gradient=False)
    assert value_mesh.rho_H == pytest.approx(value_map.rho_H, rel=1e-12)


def test_degenerate_target_of_scene_2(tmp_path):
    """(5.15) does not depend on X3: det grad Phi_d = 0. The push-forward weights keep
    rho_H finite and its gradient exact."""
    ring = ["target.map=[length/(2*pi)*sin(2*pi*x1/length), x2, -length/(2*pi)*cos(2*pi*x1/length)]"]
    args = ["gradcheck", BEAM, "--out", tmp_path, "-q"] + [a for s in ring for a in ("--set", s)]
    assert run_cli(*args) == 0
    report = read_json(tmp_path / "gradcheck.json")
    assert np.isfinite(report["objective"]) and report["min_rate"] > 1.9


def test_missing_target_is_a_config_error(tmp_path, capsys):
    assert run_cli("gradcheck", CUBE, "--out", tmp_path) == 2
    assert "target: required" in capsys.readouterr().err
