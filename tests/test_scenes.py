"""Every paper scene config validates and runs two optimisation iterations on a coarse mesh."""

from __future__ import annotations

import math

import pytest
import yaml
from conftest import CONFIGS, read_json, run_cli

# the scenes' clouds are large enough for float32 pair sums (objective.hausdorff.precision:
# auto): their kernels compile first (the flare's run was charged 45 s on a fresh clone)
pytestmark = pytest.mark.usefixtures("compiled_kernels32")

SCENES = {  # coarse element size for CI
    "beam_wave": 0.1, "beam_ring": 0.1, "tube_helix": 2.0, "disk_cone": 0.25,
    "cylinder_flare": 0.25, "square_circle_fixed": 1.0, "square_circle_free": 1.0,
    "cube_cylinder_fixed": 2.0, "cube_cylinder_free": 2.0,
}


SLOW_SCENES = {"tube_helix", "disk_cone",  # 22 s and 17 s (their first state from rest)
               "cube_cylinder_fixed", "cube_cylinder_free"}  # 21-34 s each


@pytest.mark.parametrize("scene", [pytest.param(s, marks=[pytest.mark.slow] * (s in SLOW_SCENES))
                                   for s in SCENES])
def test_scene_config_runs(scene, tmp_path):
    config = CONFIGS / f"{scene}.yaml"
    assert run_cli("validate", config, "-q") == 0
    header = config.read_text().split("\nname:", 1)[0].lower()
    assert "reading" in header and "docs/scenes.md" in header  # the reading, and its page
    # one level of the config's coarse-to-fine ones: a smoke test (levels: tests/test_levels);
    # no verification (tests/test_verify.py): two iterations leave a growth far from the
    # target, which the disk and the tube took 3 minutes each to grow from rest on a refined
    # mesh
    code = run_cli("run", config, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=2",
                   "--set", f"mesh.size={SCENES[scene]}", "--set", "mesh.layers=1",
                   "--set", "optimizer.levels=[0]", "--set", "optimizer.level_iterations=null",
                   "--set", "verify.enabled=false")
    summary = read_json(tmp_path / "summary.json")
    assert code == 0, summary["status"]
    assert summary["iterations"] == 2 and summary["status"] == "max_iterations"
    assert math.isfinite(summary["rho_H_final"]) and summary["rho_H_final"] > 0
    assert summary["config"]["name"] == scene


REDUCED = {"beam_wave_2d": "beam_wave", "beam_ring_2d": "beam_ring",
           "disk_cone_axi": "disk_cone", "cylinder_flare_axi": "cylinder_flare"}


@pytest.mark.parametrize("reduced", list(REDUCED))
def test_reduced_scene_config_runs_and_lifts_to_its_3d_config(reduced, tmp_path):
    """Each reduced config says it is verified lifted onto its scene's 3D config, lifts to
    it, and runs (two iterations on a coarse section, the lift left to tests/test_reduced.py)."""
    config = CONFIGS / f"{reduced}.yaml"
    text = config.read_text()
    assert "lifted onto" in text.split("\nname:", 1)[0].lower()
    assert yaml.safe_load(text)["verify"]["lift"] == f"configs/{REDUCED[reduced]}.yaml"
    code = run_cli("run", config, "--out", tmp_path, "-q", "--set", "optimizer.max_iterations=2",
                   "--set", "mesh.size=0.05", "--set", "mesh.layers=2",
                   "--set", "optimizer.levels=[0]", "--set", "optimizer.level_iterations=null",
                   "--set", "verify.lift=null", "--set", "verify.lift_refine=null",
                   "--set", "verify.lift_degree=null")
    summary = read_json(tmp_path / "summary.json")
    assert code == 0, summary["status"]
    assert summary["iterations"] == 2 and summary["verified"]["status"] == "solved"
    assert summary["config"]["model"]["dim"] == 2
