"""The 2D models of 3D bodies: X1-X3 sections in plane strain and plane stress, (R, Z)
sections of bodies of revolution, and the lift of their growth onto the 3D body.

Closed forms: the plane-stress stretch is stress-free; a compatible bend gives the arc in
both plane models; uniform growth of an annulus and a cylinder shell scales radii and volume
exactly; the growth of a cone (metric of its normal offsets) gives the cone.  The lift
carries a growth linear in the section's coordinates onto the 3D nodes exactly, and where the
growth is compatible the 3D body does not leave the section at all.
"""

from __future__ import annotations

import dolfinx.fem
import numpy as np
import pytest
import ufl
from conftest import CONFIGS, read_json, run_cli
from mpi4py import MPI

import shapegrowth as sg
from shapegrowth import compat
from shapegrowth.config.reduction import Section
from shapegrowth.optim.lift import lift_growth, lifted_model, verification_model
from shapegrowth.optim.objective import VERIFY_CLOUD_DEGREE
from shapegrowth.physics.kinematics import Kinematics
from shapegrowth.physics.material import MooneyRivlin

BEND = CONFIGS / "beam_bend.yaml"
WAVE = CONFIGS / "tiny" / "beam_wave.yaml"
DISK = CONFIGS / "tiny" / "disk_axi.yaml"


def _section(path, *sets):
    return sg.load_config(path, ["model.dim=2", *sets])


def _annulus(extra: dict | None = None, thickness: float = 0.05, size: float = 0.05):
    raw = {"name": "t", "geometry": {"kind": "annulus", "radius": 1.0, "inner_radius": 0.2,
                                     "thickness": thickness},
           "mesh": {"size": size, "layers": 2},
           "model": {"dim": 2, "reduction": "axisymmetric"}, "boundary": {"clamp": "rigid"},
           "growth": {"frame": "cylindrical"}}
    raw.update(extra or {})
    return sg.config_from_dict(raw)


def test_the_section_models_are_chosen_by_the_model_keys():
    box = _section(BEND, "model.reduction=plane_stress")
    assert box.section == Section("plane_stress", (0, 2), stress_free=True)
    assert box.growth_dim == 3 and box.model.plane == "x1x3"
    square = sg.load_config(CONFIGS / "square_circle_free.yaml")
    assert not square.section.reduced and square.growth_dim == 2
    assert _annulus().section.axisymmetric
    assert sg.load_config(BEND).section.kind == "solid"
    pts = np.array([[0.6, 0.8, 0.1]])
    assert np.allclose(_annulus().section.coordinates_of(pts), [[1.0, 0.1]])
    assert np.allclose(box.section.coordinates_of(pts), [[0.6, 0.1]])


@pytest.mark.parametrize("sets, message", [
    (["model.reduction=axisymmetric"], "model.reduction: a box reduces to plane_strain or "
                                       "plane_stress"),
    (["model.plane=x1x2"], "model.plane: the section of a box is x1x3"),
    (["growth.frame=free"], "growth.frame: the plane_strain model takes cartesian or "
                            "cylindrical"),
    (["boundary.clamp=x2_min"], "boundary.clamp: 'x2_min' is not on the section"),
    (["loads.body_force=[0, 1.0e-3, 0]"], "loads.body_force: a 2D model of a box carries no "
                                          "load along X2"),
    (["verify.lift=nowhere.yaml"], "verify.lift: file 'nowhere.yaml' not found"),
    (["verify.lift_refine=0"], "verify.lift_refine: refines the mesh of verify.lift, which is "
                               "not set"),
    (["verify.lift_refine=4"], "verify.lift_refine"),
    (["verify.lift_degree=2"], "verify.lift_degree: the growth's degree on the body of "
                               "verify.lift, which is not set"),
    (["verify.lift_degree=3"], "verify.lift_degree"),
])
def test_a_section_config_that_cannot_work_is_refused_naming_the_key(sets, message):
    with pytest.raises(sg.ConfigError) as err:
        _section(BEND, *sets)
    assert any(p.startswith(message) for p in err.value.problems), err.value.problems


def test_lift_and_reductions_are_refused_where_they_mean_nothing():
    with pytest.raises(sg.ConfigError, match="verify.lift: lifts a 2D section model"):
        sg.load_config(BEND, [f"verify.lift={BEND}"])
    with pytest.raises(sg.ConfigError, match="model.plane, model.reduction: a 3D model"):
        sg.load_config(BEND, ["model.reduction=plane_stress"])
    with pytest.raises(sg.ConfigError, match="model.dim: 2 does not fit geometry.kind 'tube'"):
        sg.load_config(CONFIGS / "tube_helix.yaml", ["model.dim=2"])


def test_the_plane_stress_stretch_leaves_the_third_direction_free_of_stress():
    """s* of kinematics.py: dpsi/ds = 0 there (S33 = 0) and psi is at a minimum in s; at
    F = G (the grown shape) it is sqrt(lambda_3)."""
    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    one = dolfinx.fem.Constant(mesh, 1.0)  # gives the expressions their mesh
    mat = MooneyRivlin(0.5, 0.5, 3.0)
    kin = Kinematics(Section("plane_stress", (0, 2), stress_free=True), mesh, mat)
    F = one * ufl.as_matrix([[1.3, 0.2], [-0.1, 0.8]])
    Cg = one * ufl.as_matrix([[1.5, 0.1, 0.0], [0.1, 0.7, 0.0], [0.0, 0.0, 1.8]])
    u = ufl.as_vector([0.0, 0.0])

    def at(expr):
        return float(compat.evaluate_expression(expr, np.array([[0.3, 0.3]]), mesh, [0])[0, 0])

    s = ufl.variable(one * at(kin.third_stretch(F, u, Cg)))
    F3 = ufl.as_matrix([[F[0, 0], F[0, 1], 0], [F[1, 0], F[1, 1], 0], [0, 0, s]])
    dpsi = ufl.diff(mat.psi(F3, Cg), s)
    assert abs(at(dpsi)) < 1e-12 and at(ufl.diff(dpsi, s)) > 0
    G = one * ufl.as_matrix([[1.5 ** 0.5, 0.0], [0.0, 0.7 ** 0.5]])
    Cd = one * ufl.as_matrix([[1.5, 0.0, 0.0], [0.0, 0.7, 0.0], [0.0, 0.0, 1.8]])
    assert at(kin.third_stretch(G, u, Cd)) == pytest.approx(1.8 ** 0.5, rel=1e-12)


@pytest.mark.mpi
@pytest.mark.parametrize("reduction, sets", [
    ("plane_strain", []), ("plane_stress", []),
    ("plane_stress", ["material.preset=elastosil_m4601", "material.incompressible=true"])],
    ids=["plane_strain", "plane_stress", "plane_stress-incompressible-yeoh"])
def test_a_compatible_bend_gives_the_arc_in_the_x1x3_section(reduction, sets):
    """lambda_1 = (1 + kappa x3)^2 bends the beam stress-free into the arc of curvature
    kappa = pi (a half circle): tip at (sin(kappa L)/kappa, -(1 - cos kappa L)/kappa); so
    does an incompressible Yeoh section (J = 1 through its third stretch)."""
    cfg = _section(BEND, f"model.reduction={reduction}", "mesh.size=0.02", *sets)
    model = sg.build_model(cfg)
    assert model.state.solve().converged
    tip = sg.evaluate_at(model.state.u, np.array([[1.0, 0.0, 0.0]]))[0]
    kappa = np.pi
    assert tip[0] == pytest.approx(np.sin(kappa) / kappa - 1.0, abs=2e-3)
    assert tip[1] == pytest.approx(-(1 - np.cos(kappa)) / kappa, abs=2e-3)
    assert model.residual_strain_norm() < 2e-3


@pytest.mark.mpi
@pytest.mark.parametrize("geometry", [
    {"kind": "annulus", "radius": 1.0, "inner_radius": 0.2, "thickness": 0.05},
    {"kind": "cylinder_shell", "radius": 1.0, "height": 1.0, "thickness": 0.05}])
def test_uniform_growth_of_a_body_of_revolution_scales_radii_and_volume(geometry):
    """C_g = lambda I: every radius times sqrt(lambda), the volume 2 pi int R dR dZ times
    lambda^(3/2), the reference volume that of the 3D body (pi (R2^2 - R1^2) t)."""
    lam = 1.44
    cfg = _annulus({"geometry": geometry, "growth": {
        "frame": "cylindrical", "eigenvalues": {"initial": [lam, lam, lam]}}})
    model = sg.build_model(cfg)
    assert model.state.solve().converged
    V = model.state.V
    n = V.dofmap.index_map.size_local
    R = V.tabulate_dof_coordinates()[:n, 0]
    u = model.state.u.x.array.reshape(-1, 2)[:n]
    assert np.abs((R + u[:, 0]) / R - np.sqrt(lam)).max(initial=0.0) < 1e-10
    reference, deformed = model.volumes()
    if geometry["kind"] == "annulus":
        exact = np.pi * (1.0 - 0.2 ** 2) * 0.05
    else:
        exact = np.pi * (1.0 - 0.95 ** 2) * 1.0
    assert reference == pytest.approx(exact, rel=1e-12)
    assert deformed == pytest.approx(lam ** 1.5 * exact, rel=1e-10)


@pytest.mark.mpi
def test_the_growth_of_a_cone_grows_the_cone():
    """The cone map p(R, Z) = (R, a R) + Z n (n its unit normal) has the metric
    diag(1 + a^2, (1 - Z a / (R sqrt(1 + a^2)))^2, 1) in the cylindrical frame: that growth
    is compatible, and the annulus grown so from rest is the cone of slope a."""
    a = 0.3
    # t = 0.05: a disk of t = 0.02 (h 0.02-0.04, 2-4 layers) grown from rest ends on the
    # inverted cone instead (slope -0.29, residual strain 0.014), a second equilibrium that
    # only the small through-thickness part of the growth tells apart
    cfg = _annulus({"parameters": {"a": a}, "mesh": {"size": 0.05, "layers": 4},
                    "growth": {"frame": "cylindrical", "degree": 2, "eigenvalues": {
                        "initial": ["1 + a**2", "(1 - x3*a/(r*sqrt(1 + a**2)))**2", 1.0]}}},
                   thickness=0.05)
    model = sg.build_model(cfg)
    assert model.state.solve().converged
    u = sg.evaluate_at(model.state.u, np.array([[0.2, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    assert np.abs(u[:, 0]).max() < 1e-5  # the mid-surface keeps its radii
    assert (u[1, 1] - u[0, 1]) / 0.8 == pytest.approx(a, abs=1e-5)
    assert model.residual_strain_norm() < 1e-4


@pytest.mark.mpi
@pytest.mark.parametrize("cells", ["simplex", "hex"])
@pytest.mark.parametrize("path, sets, expression", [
    (WAVE, ["model.reduction=plane_stress"], lambda x: 1 + 0.5 * x[2] + 0.2 * x[0]),
    (DISK, [], lambda x: 1 + 0.1 * np.hypot(x[0], x[1]) - 0.5 * x[2])])
def test_the_lift_carries_a_linear_growth_onto_the_3d_nodes_exactly(path, sets, expression,
                                                                     cells):
    """A growth linear in the section's coordinates, (X1, X3) or (R, Z), is a P1 (Q1) field
    of the section; lifted (extruded or revolved, triangles onto tetrahedra or
    quadrilaterals onto hexahedra), each 3D node holds the expression at its own point."""
    text = ("1 + 0.5*x3 + 0.2*x1" if path == WAVE else "1 + 0.1*r - 0.5*x3")
    reduced = sg.load_config(path, ["model.dim=2", *sets, f"mesh.cells={cells}",
                                    f"growth.eigenvalues.initial=['{text}', 1.1, 0.9]"])
    solid_sets = ["mesh.size=0.2", "mesh.layers=1"] if path == DISK else []
    solid = sg.load_config(path, ["model.dim=3", "model.plane=null", f"mesh.cells={cells}",
                                  "model.reduction=plane_strain", *solid_sets])
    model2, model3 = sg.build_model(reduced), sg.build_model(solid)
    lift_growth(reduced, model2.growth, model3)
    x = model3.growth.space.tabulate_dof_coordinates().T
    assert np.abs(model3.growth.eigenvalues[0].x.array - expression(x)).max() < 1e-12
    assert np.allclose(model3.growth.eigenvalues[1].x.array, 1.1, rtol=0, atol=1e-14)


@pytest.mark.mpi
def test_a_lift_of_degree_two_carries_a_quadratic_growth_exactly():
    """verify.lift_degree: a growth quadratic in the section's (X1, X3), held exactly by the
    section's degree-2 growth, lifted onto the 3D body's degree-1 growth is only
    interpolated (between its nodes it misses by the curvature times h^2 / 8); on the
    verification model of degree 2 every 3D node holds the expression, and so does every
    point between them."""
    def expression(x):
        return 1 + 0.2 * x[0] ** 2 + 500 * x[2] ** 2
    text = "1 + 0.2*x1**2 + 500*x3**2"
    reduced = sg.load_config(WAVE, ["model.dim=2", "model.reduction=plane_stress",
                                    "growth.degree=2",
                                    f"growth.eigenvalues.initial=['{text}', 1.1, 0.9]"])
    section = sg.build_model(reduced)
    solid = sg.load_config(WAVE)
    probes = np.array([[0.51, 0.013, 0.003], [0.27, -0.031, -0.0071]])
    missed = []
    for degree in (None, 2):
        model3 = sg.build_model(verification_model(solid, 0, degree))
        assert model3.cfg.growth.degree == (degree or 1)
        lift_growth(reduced, section.growth, model3)
        value = sg.evaluate_at(model3.growth.eigenvalues[0], probes)[:, 0]
        missed.append(np.abs(value - expression(probes.T)).max())
        if degree == 2:
            x = model3.growth.space.tabulate_dof_coordinates().T
            assert np.abs(model3.growth.eigenvalues[0].x.array - expression(x)).max() < 1e-12
    assert missed[1] < 1e-12 < 1e-4 < missed[0]


def _shell(dim: int) -> sg.Config:
    raw = {"name": "shell", "geometry": {"kind": "cylinder_shell", "radius": 1.0, "height": 0.4,
                                         "thickness": 0.1},
           "mesh": {"size": 0.1 if dim == 2 else 0.2, "layers": 1},
           "model": {"dim": dim, **({"reduction": "axisymmetric"} if dim == 2 else {})},
           "boundary": {"clamp": "bottom_rim"},
           "growth": {"frame": "cylindrical", "eigenvalues": {"initial": [1.0, 1.0, 1.21]}},
           "target": {"map": ["x1", "x2", "x3"]}}
    return sg.config_from_dict(raw)


@pytest.mark.mpi
@pytest.mark.parametrize("body", ["beam", "shell"])
def test_the_3d_body_does_not_leave_the_section_where_the_growth_is_compatible(body):
    """Growth along the axis away from the clamp (X1 of the beam, Z of the shell) leaves the
    clamped face unstretched: both bodies stretch homogeneously, u = 0.1 X1 (or 0.1 Z), a
    field P2 holds exactly, so every 3D node sits where the section puts it."""
    if body == "beam":
        grow = "growth.eigenvalues.initial=[1.21, 1.0, 1.0]"
        reduced = sg.load_config(WAVE, ["model.dim=2", "model.reduction=plane_stress", grow])
        solid = sg.load_config(WAVE, [grow])
    else:
        reduced, solid = _shell(2), _shell(3)
    section = sg.build_model(reduced)
    assert section.state.solve().converged
    lifted, model3 = lifted_model(section, solid)
    assert lifted.status == "solved" and lifted.departure is not None
    assert lifted.departure < 1e-8
    tip = np.array([[1.0, 0.0, 0.0]]) if body == "beam" else np.array([[1.0, 0.0, 0.4]])
    along = 0 if body == "beam" else 2
    assert sg.evaluate_at(model3.state.u, tip)[0, along] == pytest.approx(0.1 * tip[0, along],
                                                                         rel=1e-8)


@pytest.mark.mpi
def test_a_section_of_a_body_of_revolution_reads_its_error_as_its_3d_body_does():
    """Two surfaces of revolution about one axis are as far apart (Hausdorff) as their
    sections, so the (R, Z) section's relative error is taken over the revolved body's size,
    its diameter, as the 3D body's is, not over the section's own extent (here its height
    0.4: five times larger). The shell stretched along its axis (above) misses
    its rest shape by about its top rim's rise, 0.04, in both models, on simplices and on
    hexahedra; the two read alike to their sample points' spacing."""
    measured = []
    for cfg in (_shell(2), _shell(3)):
        model = sg.build_model(cfg)
        assert model.state.solve().converged
        objective = sg.Objective(cfg, model.state)
        measured.append((objective.target_size, objective.exact_hausdorff(),
                         objective.relative_error()))
    (size2, d2, e2), (size3, d3, e3) = measured
    assert 1.9 < size2 < 2.0 and size2 == pytest.approx(size3, rel=0.01)  # 2 R, not 0.4
    # measured 0.0383 and 0.0372 on simplices, 0.0379 and 0.0358 on hexahedra: the facets'
    # sample points sit inside the rim
    assert d2 == pytest.approx(0.04, rel=0.15) and d3 == pytest.approx(0.04, rel=0.15)
    assert e2 == pytest.approx(e3, rel=0.1)


@pytest.mark.slow
@pytest.mark.mpi
def test_a_section_run_writes_its_growth_and_the_lifted_number_a_3d_run_starts_from(
        shared_tmp):
    """verify.lift: summary.json's verified.lifted (3D DOFs, from rest); ``shapegrowth
    lift`` of the run folder gives the same number from the run's growth.npz, which holds
    the last level's growth (on the mesh refined once) and reads back onto that mesh only."""
    solid = shared_tmp / "solid.yaml"
    import yaml

    raw = yaml.safe_load(WAVE.read_text())
    raw["mesh"] = {"size": 0.1, "layers": 1, "cache_dir": str(shared_tmp)}
    solid.write_text(yaml.safe_dump(raw))
    out = shared_tmp / "run"
    status = run_cli("run", str(WAVE), "--out", str(out), "-q",
                     "--set", "model.dim=2", "--set", "model.reduction=plane_stress",
                     "--set", f"mesh.cache_dir={shared_tmp}",
                     "--set", "optimizer.max_iterations=4", "--set", "optimizer.levels=[0,1]",
                     "--set", f"verify.lift={solid}")
    assert status == 0
    verified = read_json(out / "summary.json")["verified"]
    lifted = verified["lifted"]
    assert lifted["status"] == "solved" and lifted["config"] == "tiny_beam_wave"
    assert 0 < lifted["relative"] < 1 and lifted["dofs"] > 3 * read_json(
        out / "summary.json")["dofs"]["state"]
    # the command, onto the 3D config's verification model as the run's lift
    assert run_cli("lift", str(out), "--config", str(solid), "-q") == 0
    again = read_json(out / "lift" / "lift.json")
    assert again["lifted"]["relative"] == pytest.approx(lifted["relative"], rel=1e-8)
    # the boundaries' distance, surface to surface: the 3D body's and the section's edges'
    assert 0 < lifted["surface"] < 1 and 0 < verified["surface"] < 1
    assert again["lifted"]["surface"] == pytest.approx(lifted["surface"], rel=1e-8)
    assert again["reduced_verified"] == pytest.approx(verified["relative"], rel=1e-12)
    # the bent 3D beam leaves the section (anticlastic, and the clamp holds the width); the
    # command measures it from the section solved from rest, the run from its own path's
    # equilibrium: one equilibrium here, so the same number
    assert 1e-7 < lifted["departure"] < 1  # the compatible growth: < 1e-8 (above)
    assert again["lifted"]["departure"] == pytest.approx(lifted["departure"], rel=1e-5)
    # `verify --refine 1`: the run's verification again, the section and its lift (onto the
    # run's verify.lift at the refinement the run's lift used)
    assert run_cli("verify", str(out), "--refine", "1", "-q") == 0
    check = read_json(out / "verify-r1" / "verify.json")
    assert check["verified"]["relative"] == pytest.approx(verified["relative"], rel=1e-9)
    assert check["verified"]["lifted"]["dofs"] == lifted["dofs"]
    assert check["check"]["second"] == pytest.approx(lifted["relative"], rel=1e-8)
    assert check["check"]["first"] == lifted["relative"] and check["check"]["settled"]
    # --continued: the 3D body grown from rest one refinement coarser (its mesh without the
    # run's lift_refine), continued onto the run's lift: the lift's equilibrium from rest
    assert run_cli("verify", str(out), "--refine", "1", "--continued", "--out",
                   str(out / "continued"), "-q") == 0
    on = read_json(out / "continued" / "verify.json")["verified"]
    assert on["lifted"]["continued_from"] == 0 and on["continued_from"] is None
    assert on["lifted"]["dofs"] == lifted["dofs"]
    assert on["lifted"]["relative"] == pytest.approx(lifted["relative"], rel=1e-7)
    assert on["lifted"]["departure"] == pytest.approx(lifted["departure"], rel=1e-5)
    # --lift none: the section against the section's own verified number
    assert run_cli("verify", str(out), "--refine", "1", "--lift", "none", "--out",
                   str(out / "section"), "-q") == 0
    section = read_json(out / "section" / "verify.json")
    assert "lifted" not in section["verified"]
    assert section["check"]["first"] == verified["relative"]
    assert section["check"]["second"] == pytest.approx(verified["relative"], rel=1e-9)
    # growth.start: lifted: a 3D run starts from it, on the body the run lifted onto, its
    # clouds the verification's (VERIFY_CLOUD_DEGREE) so that its first number is the lift's
    start = shared_tmp / "start"
    assert run_cli("run", str(solid), "--out", str(start), "-q", "--set", "mesh.refine=1",
                   "--set", f"objective.hausdorff.quadrature_degree={VERIFY_CLOUD_DEGREE}",
                   "--set", "growth.start=lifted", "--set", f"growth.from_run={out}",
                   "--set", "optimizer.max_iterations=1", "--set", "verify.enabled=false") == 0
    first = read_json(start / "summary.json")["hausdorff_initial"]
    assert first == pytest.approx(lifted["hausdorff"], rel=1e-6)
    from shapegrowth.io.files import growth_refinements, read_growth

    assert growth_refinements(out / "growth.npz") == 1
    coarse = sg.build_model(sg.load_config(WAVE, ["model.dim=2", f"mesh.cache_dir={shared_tmp}"]))
    with pytest.raises(ValueError, match="does not hold this model's growth"):
        read_growth(out / "growth.npz", coarse.growth)


def test_lift_refuses_a_run_folder_without_a_run_and_another_body(shared_tmp, capsys):
    assert run_cli("lift", str(shared_tmp / "none"), "--config", str(BEND)) == 2
    assert "error: lift: " in capsys.readouterr().err
    reduced = _section(WAVE)
    other = sg.load_config(WAVE, ["geometry.length=2.0", "boundary.clamp=x1_max"])
    from shapegrowth.optim.lift import check_liftable

    check_liftable(reduced, sg.load_config(WAVE))  # the body it stands for
    with pytest.raises(sg.ConfigError) as err:
        check_liftable(reduced, other)
    assert [p.split(" ")[0] + " " + p.split("has ")[-1][:16] for p in err.value.problems] == [
        "verify.lift: another geometry", "verify.lift: another clamp th"]
    with pytest.raises(sg.ConfigError) as err:  # the lift measures what the run compared
        check_liftable(_section(WAVE, "objective.compare=top"), sg.load_config(WAVE))
    assert err.value.problems == [
        "verify.lift: 'tiny_beam_wave' compares ['volume'] (pinned), the run ['top'] (pinned); "
        "the lift must measure what the run compared"]
    check_liftable(_section(WAVE, "objective.compare=top"),
                   sg.load_config(WAVE, ["objective.compare=top"]))


def test_a_run_lifts_onto_its_own_material_and_a_mismatch_stops_it_before_it_starts(
        shared_tmp, capsys):
    """A run's --set material.* applies to the config it lifts onto (the same body in the
    same material); the formulation may differ (an incompressible section in plane stress
    holds J = 1 through its third stretch, its 3D body through a pressure); a lift config of
    another material is refused before the run optimises anything."""
    import yaml

    from shapegrowth.commands.run import lift_config
    from shapegrowth.optim.lift import check_liftable

    sets = ["model.dim=2", "model.reduction=plane_stress", "material.preset=elastosil_m4601",
            "material.incompressible=true", f"verify.lift={WAVE}", "mesh.size=0.2"]
    section = sg.load_config(WAVE, sets)
    solid = lift_config(section, sets)
    assert solid is not None and solid.model.dim == 3 and solid.mesh.size == 0.1
    assert (section.material.formulation, solid.material.formulation) == ("displacement",
                                                                          "mixed")
    assert solid.material.kind == "yeoh" and solid.material.c10 == section.material.c10
    with pytest.raises(sg.ConfigError, match="verify.lift: 'tiny_beam_wave' has another "
                                             "material than the run"):
        check_liftable(section, sg.load_config(WAVE))
    other = shared_tmp / "other.yaml"
    raw = yaml.safe_load(WAVE.read_text())
    raw["material"] = {"mu1": 0.7}
    other.write_text(yaml.safe_dump(raw))
    out = shared_tmp / "run"
    assert run_cli("run", str(WAVE), "--out", str(out), "--set", "model.dim=2",
                   "--set", "model.reduction=plane_stress", "--set", f"verify.lift={other}") == 2
    assert "error: verify.lift: 'tiny_beam_wave' has another material" in capsys.readouterr().err
    assert not (out / "summary.json").exists() and not (out / "history.csv").exists()


@pytest.mark.mpi
def test_a_section_probe_is_a_3d_point_and_moves_as_the_3d_body(shared_tmp):
    """``solve --probe`` of an axisymmetric model takes a 3D point at any angle and reports
    its 3D deformed position: uniform growth lambda about the pinned section centre
    (R, Z) = (0.6, 0) sends (0, 0.6, 0.01) to sqrt(lambda) times itself."""
    import yaml

    lam = 1.44
    cfg = _annulus({"growth": {"frame": "cylindrical", "eigenvalues": {"initial": [lam] * 3}},
                    "mesh": {"size": 0.05, "layers": 2, "cache_dir": str(shared_tmp)}})
    path = shared_tmp / "annulus.yaml"
    path.write_text(yaml.safe_dump({k: v for k, v in cfg.to_dict().items()
                                    if k in ("name", "geometry", "mesh", "model", "boundary",
                                             "growth")}))
    out = shared_tmp / "solve"
    assert run_cli("solve", str(path), "--out", str(out), "--probe", "0,0.6,0.01", "-q") == 0
    (probe,) = read_json(out / "summary.json")["probes"]
    assert probe["reference"] == [0.0, 0.6, 0.01]
    assert np.allclose(probe["deformed"], [0.0, 0.6 * lam ** 0.5, 0.01 * lam ** 0.5], atol=1e-10)


def test_a_lifted_start_needs_a_finished_section_run(shared_tmp):
    with pytest.raises(sg.ConfigError, match="growth.from_run: give it with start: lifted or run"):
        sg.load_config(WAVE, ["growth.start=lifted"])
    with pytest.raises(sg.ConfigError, match="holds no summary.json or growth.npz"):
        sg.load_config(WAVE, ["growth.start=lifted", f"growth.from_run={shared_tmp}"])


def test_a_lift_is_measured_where_the_3d_config_verifies_unless_the_run_says_otherwise():
    """verify.lift_refine: the lift config's finest level refined that many times instead
    of its own verify.refine (disk_cone_axi: its finest level, where its solve from rest
    finishes)."""
    from shapegrowth.optim.lift import verification_model

    solid = sg.load_config(CONFIGS / "disk_cone.yaml")
    finest = solid.mesh.refine + solid.optimizer.levels[-1]
    assert verification_model(solid).mesh.refine == finest + solid.verify.refine
    assert verification_model(solid, 0).mesh.refine == finest
    assert sg.load_config(CONFIGS / "disk_cone_axi.yaml").verify.lift_refine == 0
