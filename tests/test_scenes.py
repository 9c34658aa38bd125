"""Every paper scene config validates and runs two optimisation iterations on a coarse mesh."""

from __future__ import annotations

import math

import pytest
from conftest import CONFIGS, read_json, run_cli

SCENES = {  # coarse element size for CI
    "beam_wave": 0.1, "beam_ring": 0.1, "tube_helix": 2.0, "disk_cone": 0.25,
    "cylinder_flare": 0.25, "square_circle_fixed": 1.0, "square_circle_free": 1.0,
}


@pytest.mark.parametrize("scene", list(SCENES))
def test_scene_config_runs(scene, tmp_path):
    config = CONFIGS / f"{scene}.yaml"
    assert run_cli("validate", config, "-q") == 0
    assert "Reading" in config.read_text() or "Readings" in config.read_text()
    # one level of the config's coarse-to-fine ones: a smoke test (levels: tests/test_levels)
    code = run_cli("run", config, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=2",
                   "--set", f"mesh.size={SCENES[scene]}", "--set", "mesh.layers=1",
                   "--set", "optimizer.levels=[0]", "--set", "optimizer.level_iterations=null")
    summary = read_json(tmp_path / "summary.json")
    assert code == 0, summary["status"]
    assert summary["iterations"] == 2 and summary["status"] == "max_iterations"
    assert math.isfinite(summary["rho_H_final"]) and summary["rho_H_final"] > 0
    assert summary["config"]["name"] == scene
