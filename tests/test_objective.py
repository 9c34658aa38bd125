"""The objective on real bodies: summary fields, mesh-file targets, degenerate targets."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli
from mpi4py import MPI

from shapegrowth.config import load
from shapegrowth.config.maps import target_metric
from shapegrowth.optim.objective import Objective
from shapegrowth.physics.geometry import mesh_path
from shapegrowth.physics.model import ForwardModel
from shapegrowth.shape.targets import mapped_points

BEAM = CONFIGS / "tiny" / "beam_wave.yaml"
CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"


@pytest.mark.mpi
def test_solve_reports_the_shape_error(shared_tmp):
    assert run_cli("solve", BEAM, "--out", shared_tmp, "-q") == 0
    s = read_json(shared_tmp / "summary.json")
    # the extent of the target's sample points (quadrature points, inside the cells): 0.986
    # on tetrahedra, 0.958 on hexahedra (the end cells' Gauss points 0.021 in from each end)
    extent = 0.958 if s["config"]["mesh"]["cells"] == "hex" else 1.0
    assert s["target_size"] == pytest.approx(extent, rel=0.02)
    assert 0 < s["rho_H_initial"] == s["rho_H_final"]
    # the objective is the debiased divergence: rho_H less the mean of the self terms
    assert 0 < s["objective_final"] < s["rho_H_final"]
    # the bent beam's tip is far from the wave: the exact Hausdorff distance sees it
    assert 0.1 < s["hausdorff_final"] < 1.0
    assert s["time_split"]["hausdorff"] > 0


@pytest.mark.mpi
@pytest.mark.simplex  # target.mesh reads simplices (one line where it finds none)
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


@pytest.mark.mpi
def test_a_map_target_carries_its_own_volume(shared_tmp):
    """target.weights: volume weighs the map's cloud by |det grad Phi_d|.  The cube mapped by
    Phi_d = 1.2 (x1 + 0.1 x1^2, x2, x3) holds 1.2^3 of the reference volume, and the body
    grown by its metric (lambda_1 = 1.44 (1 + 0.2 x1)^2, lambda_2 = lambda_3 = 1.44, quadratic
    growth fields) takes exactly that cloud: the debiased divergence vanishes there while
    rho_H does not.  Against the push-forward weights the same body is not the target's
    measure (its density varies by +-10 %), and S stays positive."""
    sets = [f"mesh.cache_dir={shared_tmp}", "model.degree=2", "growth.degree=2",
            "target.map=[1.2*(x1 + 0.1*x1**2), 1.2*x2, 1.2*x3]",
            "growth.eigenvalues.initial=['1.44*(1 + 0.2*x1)**2', 1.44, 1.44]",
            "objective.hausdorff.alpha=20"]
    comm = MPI.COMM_WORLD
    values = {}
    for weights in ("volume", "pushforward"):
        cfg = load(CUBE, sets + [f"target.weights={weights}"])
        model = ForwardModel.build(cfg)
        assert model.state.solve().converged
        objective = Objective(cfg, model.state)
        total = comm.allreduce(float(objective.target.weights.sum()), MPI.SUM)
        values[weights] = (total, objective.evaluate(gradient=False)[0])
    assert values["volume"][0] == pytest.approx(1.2**3, rel=1e-9)
    assert values["pushforward"][0] == pytest.approx(1.0, rel=1e-12)
    volume, pushforward = values["volume"][1], values["pushforward"][1]
    assert volume.hausdorff < 1e-8 and volume.rho_H > 0.05
    assert abs(volume.shape) < 1e-8 * volume.rho_H
    assert pushforward.shape > 1e-5


def test_degenerate_target_of_scene_2(tmp_path):
    """(5.15) does not depend on X3: det grad Phi_d = 0. The push-forward weights, which
    the volume measure falls back to there, keep rho_H finite and its gradient exact."""
    ring = ["target.map=[length/(2*pi)*sin(2*pi*x1/length), x2, -length/(2*pi)*cos(2*pi*x1/length)]"]
    args = ["gradcheck", BEAM, "--out", tmp_path, "-q"] + [a for s in ring for a in ("--set", s)]
    assert run_cli(*args) == 0
    report = read_json(tmp_path / "gradcheck.json")
    assert np.isfinite(report["objective"]) and report["min_rate"] > 1.9


def test_missing_target_is_a_config_error(tmp_path, capsys):
    assert run_cli("gradcheck", CUBE, "--out", tmp_path) == 2
    assert "target: required" in capsys.readouterr().err


@pytest.mark.mpi
def test_a_face_is_compared_with_the_image_of_the_same_face():
    """objective.compare: top. The beam's top face at rest against the target map's image of
    it: lifted by 0.01, the exact Hausdorff distance is 0.01 and the target's area the face's;
    stretched twice along X1 (and lifted), the target's area is twice the face's (Nanson on
    the map)."""
    beam = CONFIGS / "tiny" / "beam_wave.yaml"  # 1 x 0.1 x 0.02
    for stretch in (1.0, 2.0):
        cfg = load(beam, ["objective.compare=top",
                          f"target.map=[{stretch}*x1, x2, x3 + 0.01]"])
        objective = Objective(cfg, ForwardModel.build(cfg).state)
        assert objective.face is not None and objective.face.area() == pytest.approx(0.1)
        area = MPI.COMM_WORLD.allreduce(float(objective.target.weights.sum()), MPI.SUM)
        assert area == pytest.approx(stretch * 0.1, rel=1e-9)
        if stretch == 1.0:
            assert objective.exact_hausdorff() == pytest.approx(0.01, rel=1e-9)


@pytest.mark.mpi
@pytest.mark.parametrize("config, onto_itself, lifted, unstructured", [
    (BEAM, ["1 - x1", "-x2", "x3"], ["x1", "x2", "x3 + 0.01"], True),
    # gmsh's triangles of the square turn onto themselves
    (CONFIGS / "tiny" / "square_disk.yaml", ["-x2", "x1"], ["x1", "x2 + 0.1"], False)])
def test_the_boundaries_distance_has_no_sampling(config, onto_itself, lifted, unstructured):
    """Objective.surface_hausdorff (verified.surface): a body compared as a volume, at rest,
    against a map that turns it onto itself (the beam half a turn about its vertical axis,
    the square a quarter turn) is the same set: its boundary lies on the map's image of its
    boundary to round-off, while its volume cloud's points, turned on the beam's unstructured
    tetrahedra, land between the cloud's points (the sampling that the boundaries' distance leaves
    out).  Moved rigidly by d, both measures read d exactly; the same on 2 ranks."""
    turned = load(config, ["target.map=[" + ", ".join(onto_itself) + "]"])
    objective = Objective(turned, ForwardModel.build(turned).state)
    size = objective.target_size
    assert objective.surface_hausdorff() == pytest.approx(0.0, abs=1e-12 * size)
    assert objective.surface_relative() == pytest.approx(0.0, abs=1e-12)
    if unstructured and turned.mesh.cells == "simplex":  # a grid turns onto its own points
        assert objective.exact_hausdorff() > 1e-3 * size
    moved = load(config, ["target.map=[" + ", ".join(lifted) + "]"])
    objective = Objective(moved, ForwardModel.build(moved).state)
    d = 0.01 if moved.model.dim == 3 else 0.1
    assert objective.surface_hausdorff() == pytest.approx(d, rel=1e-9)
    assert objective.exact_hausdorff() == pytest.approx(d, rel=1e-9)


@pytest.mark.simplex  # target.mesh reads simplices
def test_a_file_target_compared_as_a_volume_has_no_surface_number(shared_tmp):
    """A mesh-file target compared as a volume has no boundary image to measure against:
    surface_hausdorff says so (None), and verified.surface stays empty."""
    base = [f"mesh.cache_dir={shared_tmp}"]
    cfg = load(CUBE, base)
    ForwardModel.build(cfg)  # writes the mesh file
    msh = mesh_path(cfg)
    by_mesh = load(CUBE, base + [f"target.mesh={msh}"])
    objective = Objective(by_mesh, ForwardModel.build(by_mesh).state)
    assert objective.surface_hausdorff() is None and objective.surface_relative() is None


def target_points(config, X):
    """The config's target map at the points ``X`` (3 x n)."""
    return mapped_points(config, X.T)[0].T


def cylindrical_frames(theta):
    """Per point, the columns e_r, e_theta, E3 at the angles ``theta``."""
    return np.stack([np.stack([np.cos(theta), np.sin(theta), 0 * theta], axis=1),
                     np.stack([-np.sin(theta), np.cos(theta), 0 * theta], axis=1),
                     np.tile([0.0, 0.0, 1.0], (len(theta), 1))], axis=2)


PRINTED_FLARE = '["(x3 + 1)*cos(theta)", "(x3 + 1)*sin(theta)", "6 - (7 - 2*(x3 + 1))**2/8 - 23/8"]'


@pytest.mark.mpi
def test_scene_5s_clamped_rim_stays_a_wall_from_its_target():
    """Scene 5 as printed (SCENES.md): the target map sends the shell to the surface of
    revolution R = X3 + 1, which has no wall and starts at R = 1 on the clamped rim.  The
    shell's wall is R in [1 - t, 1]: its clamped rim's inner edge (1 - t, 0) stays where it
    is under any growth, and every target point is t from it at least (R and Z grow
    together from the target's rim (1, 0)), so no growth comes closer than t: t over the
    target size, 0.05 / 3.397 = 1.47 %, above the scenes' 1 %.  Measured: the corner does
    not move under a growth, the target's cloud keeps t from it, and against the same map
    at X3 = 0 all along (the wall-less cylinder R = 1), the body at rest is exactly t away
    surface to surface (the bound is the measure's own reading where it is attained)."""
    base = ["mesh.size=0.025", "mesh.layers=2", "target.weights=pushforward",
            f"target.map={PRINTED_FLARE}"]  # the shipped configs read the solid flare
    cfg = load(CONFIGS / "cylinder_flare_axi.yaml",
               [*base, "growth.eigenvalues.initial=[1.15, 1.1, 0.9]"])
    model = ForwardModel.build(cfg)
    assert model.state.solve().converged
    t = cfg.geometry.thickness
    corner = np.array([1.0 - t, 0.0])
    V = model.state.V
    n = V.dofmap.index_map.size_local
    nodes = V.tabulate_dof_coordinates()[:n, :2]
    at = np.flatnonzero(np.linalg.norm(nodes - corner, axis=1) < 1e-12)
    moved = model.state.u.x.array[:2 * n].reshape(n, 2)[at]
    assert MPI.COMM_WORLD.allreduce(len(at), MPI.SUM) >= 1  # a node sits on the corner
    assert np.all(np.abs(moved) < 1e-14)
    objective = Objective(cfg, model.state)
    assert objective.target_size == pytest.approx(3.4, rel=0.01)  # the flare's top diameter
    nearest = np.min(np.linalg.norm(objective.target.points[:, :2] - corner, axis=1),
                     initial=np.inf)
    assert MPI.COMM_WORLD.allreduce(nearest, MPI.MIN) >= t
    wall_less = load(CONFIGS / "cylinder_flare_axi.yaml",
                     [*base, "target.map=[cos(theta), sin(theta), x3]"])
    objective = Objective(wall_less, ForwardModel.build(wall_less).state)
    assert objective.surface_hausdorff() == pytest.approx(t, rel=1e-9)


@pytest.mark.mpi
def test_scene_5s_solid_flare_carries_the_wall_along_the_printed_flares_normal():
    """The shipped scene 5 reads the printed flare as the solid flare (configs/
    cylinder_flare.yaml): the outer face r = 1 on the printed surface, the wall carried
    inward along its normal undistorted.  In the cylindrical frame its metric C_d is then
    diagonal (the fixed frame can hold it) with C_rr = 1, the circumference stretched to
    rho / r; and the clamped rim's inner edge (1 - t, 0) lands t's chord of the flare's
    angle at the rim, atan(2/5) from the axis, from where it rests, and every target point
    is t sin atan(2/5) = 0.0186 from it at least: this reading's floor, 0.55 % of the size,
    below the printed reading's t (1.47 %)."""
    cfg = load(CONFIGS / "cylinder_flare.yaml")
    printed = load(CONFIGS / "cylinder_flare.yaml", [f"target.map={PRINTED_FLARE}"])
    t = cfg.geometry.thickness
    rng = np.random.default_rng(5)
    n = 200
    r = rng.uniform(1 - t, 1, n)
    theta = rng.uniform(0, 2 * np.pi, n)
    x3 = rng.uniform(0, 0.7, n)
    X = np.stack([r * np.cos(theta), r * np.sin(theta), x3])
    outer = X[:, :50] / r[:50]  # the same points on the outer face
    assert np.allclose(target_points(cfg, outer), target_points(printed, outer), atol=1e-13)
    C = target_metric(cfg, X)
    frame = cylindrical_frames(theta)
    Cf = np.einsum("nki,nkl,nlj->nij", frame, C, frame)
    assert np.abs(Cf - np.einsum("nii->ni", Cf)[:, :, None] * np.eye(3)).max() < 1e-7
    assert np.allclose(Cf[:, 0, 0], 1.0, atol=1e-7)
    rho = np.hypot(*target_points(cfg, X)[:2])
    assert np.allclose(Cf[:, 1, 1], (rho / r) ** 2, rtol=1e-7)
    corner = target_points(cfg, np.array([[1 - t], [0.0], [0.0]]))[:, 0]
    angle = np.arctan(2 / 5)
    assert np.linalg.norm(corner - [1 - t, 0, 0]) == pytest.approx(2 * t * np.sin(angle / 2))
    # the floor of this reading: the fixed corner's distance to the bottom edge's line
    floor = t * np.sin(angle)
    section = load(CONFIGS / "cylinder_flare_axi.yaml", ["mesh.size=0.025", "mesh.layers=2"])
    objective = Objective(section, ForwardModel.build(section).state)
    nearest = np.min(np.linalg.norm(objective.target.points[:, :2] - [1 - t, 0], axis=1),
                     initial=np.inf)
    assert MPI.COMM_WORLD.allreduce(nearest, MPI.MIN) >= floor * (1 - 1e-9)
    assert floor / objective.target_size == pytest.approx(0.0055, abs=5e-5)  # size ~3.39


PRINTED_CONE = '["x1", "x2", "0.625*(r - inner_radius) + x3"]'
SOLID_CONE = ('["(r - 0.625*x3/sqrt(1.390625))*cos(theta)", '
              '"(r - 0.625*x3/sqrt(1.390625))*sin(theta)", '
              '"0.625*(r - inner_radius) + x3/sqrt(1.390625)"]')


@pytest.mark.mpi
def test_scene_4s_solid_cone_carries_the_wall_along_the_printed_cones_normal():
    """Scene 4's printed cone (a shear of the flat disk, its fibres
    kept vertical, C_r3 = 5/8) read as the solid cone (docs/SCENES.md, 'Scene 4', configs/disk_cone.yaml): the mid-surface on the printed cone, the wall carried along its normal
    n = (-c e_r + E3) / s undistorted, c = 5/8, s = sqrt(1 + c^2).  In the cylindrical frame its metric is diagonal (the
    paper's fixed frame can hold it): C_rr = s^2, C_thth = ((r - c X3 / s) / r)^2,
    C_33 = 1, where the printed map's is not (C_r3 = c).  Its faces lie t/2 (s - 1) / s
    from the printed faces; the clamped rim's bottom corner (R1, -t/2) stays where it
    rests, c t / (2 s) outside the solid cone's leaning rim, and every target point is that
    far from it at least: this reading's floor, 0.22 % of the size."""
    cfg = load(CONFIGS / "disk_cone.yaml")  # the shipped reading
    assert cfg.target.map == load(CONFIGS / "disk_cone.yaml", [f"target.map={SOLID_CONE}"]
                                  ).target.map
    printed = load(CONFIGS / "disk_cone.yaml", [f"target.map={PRINTED_CONE}"])
    t, R1 = cfg.geometry.thickness, cfg.geometry.inner_radius
    c = 0.625
    s = np.sqrt(1 + c**2)
    rng = np.random.default_rng(4)
    n = 200
    r = rng.uniform(R1, 1.0, n)
    theta = rng.uniform(0, 2 * np.pi, n)
    x3 = rng.uniform(-t / 2, t / 2, n)
    X = np.stack([r * np.cos(theta), r * np.sin(theta), x3])
    mid = X.copy()
    mid[2] = 0.0
    assert np.allclose(target_points(cfg, mid), target_points(printed, mid), atol=1e-13)
    frame = cylindrical_frames(theta)

    def in_frame(config):
        return np.einsum("nki,nkl,nlj->nij", frame, target_metric(config, X), frame)

    Cf = in_frame(cfg)
    assert np.abs(Cf - np.einsum("nii->ni", Cf)[:, :, None] * np.eye(3)).max() < 1e-7
    assert np.allclose(Cf[:, 0, 0], s**2, rtol=1e-7)
    assert np.allclose(Cf[:, 1, 1], ((r - c * x3 / s) / r) ** 2, rtol=1e-7)
    assert np.allclose(Cf[:, 2, 2], 1.0, rtol=1e-7)
    assert np.allclose(in_frame(printed)[:, 0, 2], c, rtol=1e-7)  # the printed shear
    # the top face lies t/2 (s - 1) / s above the printed one (normal to both): the shear
    # leaves the printed wall t / s thick
    top = X.copy()
    top[2] = t / 2
    normal = np.stack([-c * np.cos(theta), -c * np.sin(theta), np.ones(n)]) / s
    gap = np.einsum("in,in->n", normal, target_points(cfg, top) - target_points(printed, top))
    assert np.allclose(gap, t / 2 * (s - 1) / s, rtol=1e-7)
    # the floor: the fixed bottom corner's distance to the solid cone's cloud (the section's)
    floor = c * t / (2 * s)
    section = load(CONFIGS / "disk_cone_axi.yaml", ["mesh.size=0.02", "mesh.layers=2",
                                                     f"target.map={SOLID_CONE}"])
    objective = Objective(section, ForwardModel.build(section).state)
    corner = np.array([R1, -t / 2])
    nearest = np.min(np.linalg.norm(objective.target.points[:, :2] - corner, axis=1),
                     initial=np.inf)
    assert MPI.COMM_WORLD.allreduce(nearest, MPI.MIN) >= floor * (1 - 1e-9)
    assert floor / objective.target_size == pytest.approx(0.00215, abs=5e-5)  # size ~1.97
