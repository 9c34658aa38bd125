"""fabrication/ of a 2D model (io/fabrication.py): a plane section's regions extruded through
the box's width, a body of revolution's revolved about its axis, each STL closed and
enclosing its material's swept volume (serially and on two ranks)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import CONFIGS, read_json, stl_closed_volume

from shapegrowth.config import load
from shapegrowth.io.fabrication import write_fabrication
from shapegrowth.physics.model import ForwardModel
from shapegrowth.physics.projection import LevelProjection

pytestmark = pytest.mark.simplex  # the swept cells are the tiny configs' triangles

LEVELS = (0.9, 1.2)


def filtered_and_crisp(model, split: float) -> tuple[list, list]:
    """A filtered lambda_1 rising through the levels' middle at x = ``split`` (x the mesh's
    first coordinate), and its crisp design: the cells whose centre lies below ``split``
    take the first level."""
    lam = model.growth.eigenvalues[0]
    x = lam.function_space.tabulate_dof_coordinates()[:, 0]
    filtered = lam.copy()
    filtered.x.array[:] = np.mean(LEVELS) + (x - split)
    lam.x.array[:] = LevelProjection(LEVELS).value(filtered.x.array, math.inf)
    return [filtered], [lam]


@pytest.mark.mpi
@pytest.mark.parametrize("config, sets, split, swept", [
    ("beam_arc.yaml", ["model.dim=2", "model.reduction=plane_stress", "mesh.size=0.05"], 0.35,
     lambda x0, x1, x3: (x1 - x0) * 0.1 * 0.02),  # the box's width 0.1 times the area
    ("disk_axi.yaml", [], 0.6,  # r from 0.2 to 1, thickness 0.05: pi (r1^2 - r0^2) t
     lambda r0, r1, t: math.pi * (r1 ** 2 - r0 ** 2) * 0.05),
])
def test_a_section_s_materials_are_swept_into_closed_parts(config, sets, split, swept,
                                                           shared_tmp):
    """Two regions of the section (split at X1 or R = ``split``, along the cells' edges):
    each material's STL is
    closed and encloses its region's swept volume (extruded exactly; revolved in 96 steps,
    the inscribed polygon's 0.07 % less), and the fractions are of the swept volumes."""
    from shapegrowth.commands.run import sweep_of

    cfg = load(CONFIGS / "tiny" / config, [*sets, f"mesh.cache_dir={shared_tmp}"])
    model = ForwardModel.build(cfg)
    filtered, crisp = filtered_and_crisp(model, split)
    out = shared_tmp / "made"
    made = write_fabrication(out, [LevelProjection(LEVELS)], crisp, filtered, ["lambda_1"], 0.0,
                             None, None, "not verified", sweep_of(cfg))
    start, end = (0.0, 1.0) if config == "beam_arc.yaml" else (0.2, 1.0)
    expected = [swept(start, split, 0), swept(split, end, 0)]
    assert [m.growth for m in made.materials] == [(LEVELS[0],), (LEVELS[1],)]
    for material, volume in zip(made.materials, expected):
        assert material.volume == pytest.approx(volume, rel=1e-9)
        enclosed = stl_closed_volume(out / "fabrication" / material.stl)
        assert enclosed == pytest.approx(volume, rel=1e-3 if "disk" in config else 1e-6)
    assert made.volume_fractions["material_0"] == pytest.approx(
        expected[0] / sum(expected), rel=1e-9)
    # the nodal crisp design steps in the cells beside the split (its nodes there are at the
    # second level)
    assert 0.0 < made.interface_fraction < 0.5
    assert read_json(out / "fabrication" / "fabrication.json")["levels"] == list(LEVELS)
