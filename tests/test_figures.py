"""3D figures (shape3d.png): a section swept back into its 3D body closes into the solid it
stands for (closed forms of the extruded and revolved volumes), and `shapegrowth figure`
draws a finished run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import CONFIGS, run_cli
from mpi4py import MPI

from shapegrowth.io.figures3d import _extruded, _revolved, boundary_edges
from shapegrowth.io.plotting import Surface
from shapegrowth.shape.surface_files import check_closed, oriented
from shapegrowth.shape.surface_formats import TriangleSurface


def section(lo=(1.0, 0.0), hi=(2.0, 1.0), n=3) -> Surface:
    """The rectangle [lo, hi] as an n x n grid of triangles, displacement zero."""
    s, t = np.meshgrid(np.linspace(lo[0], hi[0], n + 1), np.linspace(lo[1], hi[1], n + 1))
    points = np.column_stack([s.ravel(), t.ravel(), 0 * s.ravel()])
    k = np.arange((n + 1) * (n + 1)).reshape(n + 1, n + 1)[:-1, :-1].ravel()
    triangles = np.vstack([np.column_stack([k, k + 1, k + n + 2]),
                           np.column_stack([k, k + n + 2, k + n + 1])])
    return Surface(points, points.copy(), triangles, np.ones(len(points)))


def solid(surface: Surface) -> float:
    closed = TriangleSurface(surface.deformed, surface.triangles)
    check_closed(closed, Path("swept"))
    return oriented(closed, Path("swept")).volume()


def test_the_boundary_of_a_grid_is_its_rim():
    assert len(boundary_edges(section(n=3).triangles)) == 12


def test_an_extruded_section_is_the_prism():
    """The X1-X3 section [1, 2] x [0, 1] extruded across X2 over [-0.3, 0.3]: volume 0.6."""
    swept = _extruded(section(), (0, 2), 1, (-0.3, 0.3))
    assert solid(swept) == pytest.approx(0.6, rel=1e-12)
    assert swept.deformed[:, 1].min() == -0.3 and swept.deformed[:, 1].max() == 0.3


def test_a_revolved_section_is_the_polygonal_ring():
    """(R, Z) in [1, 2] x [0, 1] revolved on N = 64 segments: the ring with N-gon sections,
    volume (N/2) sin(2 pi/N) (R2^2 - R1^2) h, within 0.2 % of Pappus' 3 pi."""
    swept = _revolved(section(), 64)
    exact = 32 * np.sin(2 * np.pi / 64) * 3.0
    assert solid(swept) == pytest.approx(exact, rel=1e-12)
    assert solid(swept) == pytest.approx(3 * np.pi, rel=2e-3)


@pytest.mark.mpi
# slow (9.6 s compiled, 22-25 s on fresh clones; 11.4 s on two ranks): a 2D run draws itself
# serially and on two ranks in test_optimize
@pytest.mark.slow
def test_a_run_draws_itself_in_3d_and_figure_draws_it_again(shared_tmp):
    out = shared_tmp / "run"
    assert run_cli("run", CONFIGS / "tiny" / "beam_wave.yaml", "--out", out, "-q",
                   "--set", "optimizer.max_iterations=2", "--set", "verify.enabled=false") == 0
    assert (out / "shape3d.png").is_file()
    assert run_cli("figure", out, "--out", shared_tmp / "again", "--view", "10,-90",
                   "-q") == 0
    if MPI.COMM_WORLD.rank == 0:
        import matplotlib.image

        image = matplotlib.image.imread(shared_tmp / "again" / "shape3d.png")
        assert image.shape[:2] == (672, 840)  # 7 x 5.6 inches at 120 dpi
        assert len(np.unique(image.reshape(-1, image.shape[2]), axis=0)) > 100  # not blank


def test_figure_of_a_missing_run_is_one_line(tmp_path, capsys):
    assert run_cli("figure", tmp_path / "nothing") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"error: figure: {tmp_path / 'nothing' / 'summary.json'} not found (RUN_DIR "
                   "is the folder of a finished `shapegrowth run`)"]


def test_a_bad_view_is_refused(tmp_path, capsys):
    with pytest.raises(SystemExit):
        run_cli("figure", tmp_path, "--view", "10")
    assert "two angles in degrees (elevation, azimuth), got '10'" in capsys.readouterr().err
