"""Surface files as they come: each defect made on purpose, alone, is repaired (or kept, where
sampling needs no repair) and said in one line; a repaired file measures as its clean
original (rho_H and the exact Hausdorff distance, serially and on two ranks)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import CONFIGS
from mpi4py import MPI
from test_surface_distance import _cap
from test_surface_targets import icosphere, write_ply

from shapegrowth.config import ConfigError, load
from shapegrowth.shape.surface_files import filled_surface, loaded
from shapegrowth.shape.surface_formats import TriangleSurface, write_stl
from shapegrowth.shape.surface_repair import edge_counts, repaired


def _clean() -> tuple[np.ndarray, np.ndarray]:
    """An open spherical cap over the tiny beam's top face, in millimetres (4 096 triangles)."""
    points, triangles = _cap(1.0, np.array([0.5, 0.0, 0.06 - 1.0]), np.arcsin(0.3), n=16)
    return 1000 * points, triangles


def _broken(defect: str) -> tuple[np.ndarray, np.ndarray, str]:
    """The clean cap with one defect, and what the repair's line says of it."""
    p, t = _clean()
    rng = np.random.default_rng(1)
    if defect == "flat triangle":  # three points on a line, between existing vertices
        mid = p[t[0]].mean(axis=0)
        p = np.vstack([p, mid, mid + 1e-3 * (p[t[0, 1]] - mid), mid + 2e-3 * (p[t[0, 1]] - mid)])
        return p, np.vstack([t, [len(p) - 3, len(p) - 2, len(p) - 1]]), \
            "1 triangle without area dropped"
    if defect == "collapsed triangle":  # a triangle naming a vertex twice
        return p, np.vstack([t, [t[5, 0], t[5, 1], t[5, 0]]]), "1 triangle without area dropped"
    if defect == "triangle twice":  # the same triangle again, the other way round
        return p, np.vstack([t, t[7, ::-1]]), "1 triangle given twice dropped"
    if defect == "unreferenced vertex":
        return np.vstack([p, [[5e3, 5e3, 5e3]]]), t, "1 unreferenced vertex dropped"
    if defect == "turned triangles":  # a tenth of them inside out
        turn = rng.random(len(t)) < 0.1
        return p, np.where(turn[:, None], t[:, ::-1], t), \
            f"{int(turn.sum())} triangles turned to their neighbours' orientation"
    if defect == "stray piece":  # a small triangle far off
        p = np.vstack([p, [[3e3, 0, 0], [3e3 + 10, 0, 0], [3e3, 10, 0]]])
        return p, np.vstack([t, [len(p) - 3, len(p) - 2, len(p) - 1]]), \
            "1 smaller piece dropped"
    raise AssertionError(defect)


DEFECTS = ["flat triangle", "collapsed triangle", "triangle twice", "unreferenced vertex",
           "turned triangles", "stray piece"]


def _same_surface(a: TriangleSurface, b: TriangleSurface) -> bool:
    """The same points and the same triangles (as vertex sets, in any order)."""
    def rows(s):
        return sorted(map(tuple, np.sort(s.points[s.triangles], axis=1).reshape(-1, 9)))
    return np.array_equal(a.points, b.points) and rows(a) == rows(b)


@pytest.mark.parametrize("defect", DEFECTS)
def test_each_defect_alone_is_repaired_and_said(tmp_path, defect):
    """Written as a PLY (indexed vertices, so a vertex no triangle names survives the file):
    the repaired surface is the clean one, and its line says what was done."""
    p, t = _clean()
    write_ply(tmp_path / "clean.ply", TriangleSurface(p, t), binary=True)
    bp, bt, said = _broken(defect)
    write_ply(tmp_path / "broken.ply", TriangleSurface(bp, bt), binary=True)
    clean, nothing = loaded(tmp_path / "clean.ply")
    fixed, repair = loaded(tmp_path / "broken.ply")
    assert nothing.line() == "nothing to repair; kept: 64 edges on a rim"
    assert _same_surface(fixed, clean)
    assert repair.line().startswith("repaired: " + said), repair.line()
    assert "\n" not in repair.line()


def test_an_stl_repeats_its_vertices_and_all_pieces_stay_on_request(tmp_path):
    """An STL gives each triangle its own three vertices: merged, the cap is the PLY's; with
    target.pieces: all the stray piece stays, said as kept."""
    p, t = _broken("stray piece")[:2]
    write_stl(tmp_path / "cap.stl", p, t)
    surface, repair = loaded(tmp_path / "cap.stl", "all")
    assert len(surface.triangles) == len(t)
    assert repair.merged_vertices == 3 * len(t) - len(p)
    assert repair.line().endswith("kept: 2 pieces, 67 edges on a rim")


def test_an_edge_of_three_triangles_is_kept_on_an_open_surface(tmp_path):
    """A flap standing on an inner edge of the cap (the scan's non-manifold edge): sampled
    as it is, said as kept; a closed surface with one is refused, naming the reason."""
    p, t = _clean()
    counts_before = edge_counts(t)
    inner = t[len(t) // 2]
    p = np.vstack([p, p[inner[:2]].mean(axis=0) + [0.0, 0.0, 50.0]])
    write_stl(tmp_path / "flap.stl", p, np.vstack([t, [inner[0], inner[1], len(p) - 1]]))
    surface, repair = loaded(tmp_path / "flap.stl")
    assert repair.nonmanifold_edges == 1 and np.sum(counts_before > 2) == 0
    assert len(surface.triangles) == len(t) + 1
    assert "1 edge shared by more than two triangles" in repair.line()
    sphere = icosphere(1)
    a, b, _ = sphere.triangles[0]
    closed = TriangleSurface(np.vstack([sphere.points, [[0.0, 0.0, 3.0]]]),
                             np.vstack([sphere.triangles, [[a, b, len(sphere.points)]]]))
    write_stl(tmp_path / "closed_flap.stl", closed.points, closed.triangles)
    with pytest.raises(ConfigError) as err:
        filled_surface(tmp_path / "closed_flap.stl")
    assert "edges bound one triangle only" in err.value.problems[0] \
        or "is not a manifold" in err.value.problems[0]


def test_a_closed_surface_with_defects_fills_as_the_clean_one(tmp_path):
    """A sphere with triangles turned inside out, one given twice and one without area: the
    fill holds the clean sphere's volume to round-off."""
    sphere = icosphere(2)
    rng = np.random.default_rng(3)
    turn = rng.random(len(sphere.triangles)) < 0.3
    t = np.where(turn[:, None], sphere.triangles[:, ::-1], sphere.triangles)
    t = np.vstack([t, t[4], [t[9, 0], t[9, 0], t[9, 1]]])
    write_stl(tmp_path / "clean.stl", sphere.points, sphere.triangles)
    write_stl(tmp_path / "broken.stl", sphere.points, t)
    volume = [_volume(filled_surface(tmp_path / n)) for n in ("clean.stl", "broken.stl")]
    assert volume[1] == pytest.approx(volume[0], rel=1e-12)
    assert volume[0] == pytest.approx(sphere.volume(), rel=1e-6)  # the STL's float32


def _volume(filled) -> float:
    nodes, tets = filled
    jac = np.stack([nodes[tets[:, k + 1]] - nodes[tets[:, 0]] for k in range(3)], axis=2)
    return float(np.abs(np.linalg.det(jac)).sum()) / 6


def test_the_turning_is_consistent_on_many_pieces():
    """Forty small spheres and a cap, each with random triangles turned: after the repair
    (all pieces kept) every edge shared by two triangles is crossed once each way."""
    rng = np.random.default_rng(5)
    sphere = icosphere(1)
    points, triangles = [], []
    for k in range(40):
        triangles.append(sphere.triangles + sum(len(q) for q in points))
        points.append(sphere.points + [3.0 * k, 0.0, 0.0])
    p, t = _clean()
    triangles.append(t + sum(len(q) for q in points))
    points.append(p / 1000 + [0.0, 5.0, 0.0])
    t = np.vstack(triangles)
    turn = rng.random(len(t)) < 0.5
    surface, repair = repaired(np.vstack(points), np.where(turn[:, None], t[:, ::-1], t),
                               pieces="all")
    assert repair.pieces == 41 and repair.turned_triangles > 0
    s = surface.triangles
    directed = np.concatenate([s[:, [0, 1]], s[:, [1, 2]], s[:, [2, 0]]])
    assert len(np.unique(directed, axis=0)) == len(directed)


@pytest.mark.mpi
def test_a_repaired_file_measures_as_its_clean_original(shared_tmp):
    """The tiny beam's top face against the clean cap and against the cap with every defect
    at once (an STL: its vertices repeated too): rho_H, its gradient and the exact Hausdorff
    distance surface to surface equal to round-off, serially and on two ranks."""
    from shapegrowth.optim.objective import Objective
    from shapegrowth.physics.model import ForwardModel

    comm = MPI.COMM_WORLD
    if comm.rank == 0:
        p, t = _clean()
        write_stl(shared_tmp / "clean_mm.stl", p, t)
        rng = np.random.default_rng(2)
        turn = rng.random(len(t)) < 0.2
        bt = np.where(turn[:, None], t[:, ::-1], t)
        bt = np.vstack([bt, bt[11, ::-1], [t[3, 0], t[3, 1], t[3, 0]]])
        bp = np.vstack([p, [[3e3, 0, 0], [3e3 + 10, 0, 0], [3e3, 10, 0]]])
        write_stl(shared_tmp / "broken_mm.stl", bp,
                  np.vstack([bt, [len(bp) - 3, len(bp) - 2, len(bp) - 1]]))
    comm.barrier()
    measured = []
    for name in ("clean_mm.stl", "broken_mm.stl"):
        cfg = load(CONFIGS / "tiny" / "beam_wave.yaml", [
            "objective.compare=top", "target.map=null", f"target.surface={shared_tmp / name}",
            "target.transform.scale=0.001"])
        objective = Objective(cfg, ForwardModel.build(cfg).state)
        value, gradient = objective.evaluate(gradient=True)
        measured.append((value.rho_H, gradient.norm(), objective.surface_hausdorff()))
    assert measured[1] == pytest.approx(measured[0], rel=1e-12)
    assert measured[0][0] > 0 and measured[0][2] == pytest.approx(0.250031, rel=1e-4)


def test_pieces_without_a_surface_is_one_line():
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "beam_wave.yaml", ["target.pieces=all"])
    assert any(p.startswith("target.pieces: ") for p in err.value.problems)


def test_a_crop_keeps_the_triangles_whose_centre_it_holds_at(tmp_path):
    """target.crop in the file's own units: the cap's half x1 > 500 mm kept, said in the line;
    a crop that keeps nothing, and one that does not parse, are one line each."""
    p, t = _clean()
    write_stl(tmp_path / "cap.stl", p, t)
    inside = p[t].mean(axis=1)[:, 0] > 500
    surface, repair = loaded(tmp_path / "cap.stl", crop="x1 > 500")
    assert len(surface.triangles) == np.count_nonzero(inside)
    assert repair.line().startswith(
        f"repaired: {np.count_nonzero(~inside)} triangles outside target.crop dropped")
    with pytest.raises(ConfigError) as err:
        loaded(tmp_path / "cap.stl", crop="x3 > 1e6")
    assert err.value.problems[0].startswith("target.crop: 'x3 > 1e6' keeps no triangle")
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "beam_wave.yaml", [
            "objective.compare=top", "target.map=null",
            f"target.surface={tmp_path / 'cap.stl'}", "target.crop=x4 > 1"])
    assert any(p.startswith("target.crop: 'x4 > 1': ") for p in err.value.problems)


HEAD = Path("/usr/share/opencascade/data/stl/head.stl")  # Debian's occt-misc


@pytest.mark.skipif(not HEAD.is_file(), reason="no OpenCASCADE sample data (occt-misc)")
def test_the_example_scan_is_read_cropped_and_kept_with_its_defects():
    """configs/examples/plate_on_a_scan.yaml's target, a file no one here made (117 694
    triangles of an STL in millimetres, 64 edges of three or more triangles): of its top,
    x3 > 165 mm, the largest of 4 pieces is kept (74 % of the area), its duplicate vertices
    merged, its non-manifold edge and its rims kept, not refused; the config loads."""
    cfg = load(CONFIGS / "examples" / "plate_on_a_scan.yaml")
    assert cfg.target.surface == str(HEAD)
    surface, repair = loaded(HEAD, crop=cfg.target.crop, pieces=cfg.target.pieces)
    assert (repair.cropped_triangles, repair.merged_vertices) == (113693, 9558)
    assert (repair.pieces, repair.pieces_dropped, repair.nonmanifold_edges) == (1, 3, 1)
    assert repair.dropped_area == pytest.approx(0.263, abs=5e-4)
    assert len(surface.triangles) < 117694 - 113693
    centres = surface.points[surface.triangles].mean(axis=1)
    assert centres[:, 2].min() > 165.0  # the file's own units
