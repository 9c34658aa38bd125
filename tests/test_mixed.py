"""The mixed displacement-pressure formulation (``material.formulation: mixed``, Taylor-Hood)
and its incompressible limit (``material.incompressible``): the same energy's homogeneous
closed forms, J of the elastic part held at 1, the reduced gradient's Taylor rate, no
locking where the displacement element locks, and its config; an incompressible sheet in
plane stress (J = 1 through the third stretch: any energy, the displacement alone); serial
and 2 ranks (the exact resume of a mixed run: tests/test_optimize.py)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS, read_json, run_cli
from scipy.optimize import brentq, fsolve
from test_energies import closed_stress

from shapegrowth.config import ConfigError, load
from shapegrowth.physics.material import Isochoric, MooneyRivlin, Ogden

CUBE = CONFIGS / "tiny" / "cube_uniform.yaml"
BEAM = CONFIGS / "tiny" / "beam_bend.yaml"
NH = ["material.kind=neo_hookean", "material.mu=0.8"]


def _sets(*sets: str) -> list[str]:
    return [x for s in sets for x in ("--set", s)]


def _uniaxial(out, s: float, sets: list[str]) -> tuple[float, float]:
    """The stretch along X1 and the volume ratio of the free cube (P2) under traction s."""
    assert run_cli("solve", CUBE, "--out", out, "-q", "--probe", "0.5,0,0", "--probe",
                   "-0.5,0,0", *_sets("model.degree=2",
                                      f"loads.traction={{x1_max: [{s}, 0, 0], "
                                      f"x1_min: [{-s}, 0, 0]}}", *sets)) == 0
    summary = read_json(out / "summary.json")
    assert summary["status"] == "converged"
    probes = np.array([p["deformed"] for p in summary["probes"]])
    return probes[0, 0] - probes[1, 0], summary["volume_deformed"]


@pytest.mark.mpi
def test_a_mixed_cube_under_traction_takes_the_energy_s_homogeneous_stretch(shared_tmp):
    """The mixed formulation solves the same energy: the neo-Hookean cube's stretches from
    its closed form (P11 = s, P22 = 0), as the displacement formulation's (test_energies)."""
    s, m = 0.24, Isochoric("neo_hookean", kappa=4.0, mu=0.8)
    a, volume = _uniaxial(shared_tmp, s, [*NH, "material.kappa=4",
                                          "material.formulation=mixed"])

    def residual(ab):
        P = closed_stress(m, np.diag([ab[0], ab[1], ab[1]]), np.eye(3))
        return [P[0, 0] - s, P[2, 2]]

    a0, b0 = fsolve(residual, [1.1, 0.95], xtol=1e-12)
    assert a == pytest.approx(a0, rel=1e-9)
    assert volume == pytest.approx(a0 * b0 * b0, rel=1e-9)


@pytest.mark.mpi
@pytest.mark.parametrize("kind", ["neo_hookean", "mooney_rivlin"])
def test_an_incompressible_cube_keeps_its_volume_and_the_closed_form(kind, shared_tmp):
    """Incompressible uniaxial tension: volume 1 to the solver's tolerance and the
    textbook nominal stress s = (a - a^-2) (mu1 + mu2 / a) (the paper's energy at J = 1 is
    Mooney-Rivlin with C10 = mu1/2, C01 = mu2/2; neo-Hookean: mu2 = 0, mu1 = mu)."""
    s = 0.3
    sets = [*NH] if kind == "neo_hookean" else []
    mu1, mu2 = (0.8, 0.0) if kind == "neo_hookean" else (0.5, 0.5)
    a, volume = _uniaxial(shared_tmp, s, [*sets, "material.incompressible=true"])
    a0 = brentq(lambda x: (x - x ** -2) * (mu1 + mu2 / x) - s, 1.0, 3.0, xtol=1e-15)
    assert a == pytest.approx(a0, rel=1e-9)
    assert volume == pytest.approx(1.0, abs=1e-9)


@pytest.mark.mpi
def test_an_incompressible_body_grows_stress_free_by_a_uniform_growth(shared_tmp):
    """C_g = 1.3^2 I: det F = det G, so J of the elastic part is 1 and the body grows
    stress-free with volume ratio 1.3^3 (the pressure zero)."""
    assert run_cli("solve", CUBE, "--out", shared_tmp, "-q", *_sets(
        "model.degree=2", "material.incompressible=true",
        "growth.eigenvalues.initial=[1.69, 1.69, 1.69]")) == 0
    summary = read_json(shared_tmp / "summary.json")
    ratio = summary["volume_deformed"] / summary["volume_reference"]
    assert ratio == pytest.approx(1.3 ** 3, rel=1e-10)
    assert summary["stress_l2"] < 1e-9


@pytest.mark.mpi
@pytest.mark.parametrize("sets", [
    ["material.formulation=mixed"],
    ["material.incompressible=true"],
    pytest.param(["material.preset=treloar_ogden", "material.incompressible=true"],
                 marks=pytest.mark.slow),
    pytest.param(["material.incompressible=true", "mesh.cells=hex"], marks=pytest.mark.slow),
], ids=["mixed", "incompressible", "ogden", "hex"])
def test_a_mixed_body_has_its_gradient(sets, shared_tmp):
    """The reduced gradient through the mixed state and its adjoint (the pressure's rows
    zero in dJ/dw): Taylor rate > 1.9 (measured 1.9997-1.9999, serial and 2 ranks, whose
    objectives agree to 2e-16)."""
    assert run_cli("gradcheck", CONFIGS / "tiny" / "beam_wave.yaml", "--out", shared_tmp,
                   "-q", *_sets(*sets)) == 0
    check = read_json(shared_tmp / "gradcheck.json")
    assert min(check["rates"]) > 1.9, check


@pytest.mark.mpi
@pytest.mark.parametrize("sets", [["material.formulation=mixed"],
                                  ["material.incompressible=true"]],
                         ids=["mixed", "incompressible"])
def test_a_mixed_body_s_stability_penalty_has_its_gradient(sets, shared_tmp):
    """The stability penalty (optimizer.stability) of a mixed body dominating J, the beam held
    at both ends: its eigenvalues' sensitivity is the whole eigenvector's (u, p) quadratic
    form of the tangent's derivative, and their u- and p-derivatives join dJ/dw before the
    adjoint solve.  Taylor rate > 1.9 (measured 1.998-2.000 mixed, J 82.7 of which rho_H
    ~1e-2); with the pressure's part of dP/dw dropped the rate falls to 0.99."""
    assert run_cli("gradcheck", CONFIGS / "tiny" / "beam_wave.yaml", "--out", shared_tmp,
                   "-q", *_sets(*sets, "boundary.clamp=[x1_min, x1_max]",
                                "optimizer.stability.min_eigenvalue=0.5",
                                "optimizer.stability.modes=3",
                                "optimizer.stability.weight=100")) == 0
    check = read_json(shared_tmp / "gradcheck.json")
    assert check["objective"] > 10.0, check  # the penalty, not rho_H, is J
    assert min(check["rates"]) > 1.9, check


def test_an_incompressible_section_in_plane_stress_holds_j_at_one():
    """The third stretch of an incompressible plane-stress section makes J of the elastic
    part 1 at any F and C_g, and at F = G (the grown shape) it is sqrt(lambda_3)."""
    import dolfinx.fem
    import ufl
    from mpi4py import MPI

    from shapegrowth import compat
    from shapegrowth.config.reduction import Section
    from shapegrowth.physics.kinematics import Kinematics, block

    mesh = dolfinx.mesh.create_unit_square(MPI.COMM_SELF, 1, 1)
    one = dolfinx.fem.Constant(mesh, 1.0)
    kin = Kinematics(Section("plane_stress", (0, 2), stress_free=True), mesh,
                     Isochoric("neo_hookean", kappa=0.0, mu=1.0), incompressible=True)
    F = one * ufl.as_matrix([[1.3, 0.2], [-0.1, 0.8]])
    Cg = one * ufl.as_matrix([[1.5, 0.1, 0.0], [0.1, 0.7, 0.0], [0.0, 0.0, 1.8]])
    u = ufl.as_vector([0.0, 0.0])

    def at(expr):
        return float(compat.evaluate_expression(expr, np.array([[0.3, 0.3]]), mesh, [0])[0, 0])

    F3 = block(F, kin.third_stretch(F, u, Cg))
    assert at(ufl.det(F3) / ufl.sqrt(ufl.det(Cg))) == pytest.approx(1.0, abs=1e-14)
    G = one * ufl.as_matrix([[1.5 ** 0.5, 0.0], [0.0, 0.7 ** 0.5]])
    Cd = one * ufl.as_matrix([[1.5, 0.0, 0.0], [0.0, 0.7, 0.0], [0.0, 0.0, 1.8]])
    assert at(kin.third_stretch(G, u, Cd)) == pytest.approx(1.8 ** 0.5, rel=1e-13)


# incompressible energies in plane stress (kappa 0: the constraint takes the volumetric part)
SHEETS = {
    "mooney_rivlin": ([], None),
    "neo_hookean": (NH, Isochoric("neo_hookean", kappa=0.0, mu=0.8)),
    "yeoh": (["material.preset=elastosil_m4601"],
             Isochoric("yeoh", kappa=0.0, c=(0.11, 0.02, 0.0))),
    "ogden": (["material.preset=treloar_ogden"],
              Ogden((0.63, 0.0012, -0.01), (1.3, 5.0, -2.0), kappa=0.0)),
}


@pytest.mark.mpi
@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n == "ogden"
                                  else n for n in SHEETS])
def test_an_incompressible_sheet_in_plane_stress_takes_the_uniaxial_closed_form(name,
                                                                               shared_tmp):
    """A free square section of a box in plane stress, incompressible, under traction s on
    its X1 faces: the homogeneous stretch a with s = dW/da along F = diag(a, a^-1/2, a^-1/2)
    (closed_stress's P, the constraint's pressure eliminated: P11 - a^(-3/2) (P22 + P33) / 2),
    and its area a^(1/2)."""
    sets, m = SHEETS[name]
    m = m if m is not None else MooneyRivlin(0.5, 0.5, 0.0)
    s = 0.1 if name == "yeoh" else 0.3
    assert run_cli("solve", CUBE, "--out", shared_tmp, "-q", "--probe", "1,0,0", "--probe",
                   "0,0,0", *_sets("geometry={kind: box, length: 1, width: 1, thickness: 1}",
                                   "mesh.layers=2", "model.dim=2",
                                   "model.reduction=plane_stress", "model.degree=2",
                                   "material.incompressible=true", *sets,
                                   f"loads.traction={{x1_max: [{s}, 0, 0], "
                                   f"x1_min: [{-s}, 0, 0]}}")) == 0
    summary = read_json(shared_tmp / "summary.json")
    probes = np.array([p["deformed"] for p in summary["probes"]])

    def nominal(a: float) -> float:
        P = closed_stress(m, np.diag([a, a ** -0.5, a ** -0.5]), np.eye(3))
        return P[0, 0] - a ** -1.5 * (P[1, 1] + P[2, 2]) / 2 - s

    a0 = brentq(nominal, 1.0, 3.0, xtol=1e-15)
    assert probes[0, 0] - probes[1, 0] == pytest.approx(a0, rel=1e-9)
    assert summary["volume_deformed"] == pytest.approx(a0 ** 0.5, rel=1e-9)


@pytest.mark.mpi
def test_an_incompressible_sheet_has_its_gradient(shared_tmp):
    """The plane-stress section of an incompressible Yeoh beam (Elastosil): Taylor rate > 1.9
    (measured 2.001-2.011)."""
    assert run_cli("gradcheck", CONFIGS / "tiny" / "beam_wave.yaml", "--out", shared_tmp,
                   "-q", *_sets("model.dim=2", "model.reduction=plane_stress",
                                "material.preset=elastosil_m4601",
                                "material.incompressible=true")) == 0
    check = read_json(shared_tmp / "gradcheck.json")
    assert min(check["rates"]) > 1.9, check


def _tip(out, sets: list[str]) -> float:
    """The thin cantilever's tip deflection under scripts/locking.py's load at nu = 0.4999
    (E = 2.9998: the Euler-Bernoulli deflection 1e-3)."""
    load = 1e-3 * 2.9998 * 0.02 ** 2 / 4
    assert run_cli("solve", BEAM, "--out", out, "-q", "--probe", "1,0,0", *_sets(
        "material.kind=neo_hookean", "material.mu=1", "growth.eigenvalues.initial=[1, 1, 1]",
        "parameters={kappa: 0}", f"loads.traction={{x1_max: [0, 0, {-load}]}}", *sets)) == 0
    probe = read_json(out / "summary.json")["probes"][0]
    return probe["reference"][2] - probe["deformed"][2]


@pytest.mark.mpi
@pytest.mark.simplex  # its fractions are P2 tetrahedra's (Q2 hexahedra lock less: 0.957)
def test_the_mixed_element_does_not_lock_where_the_displacement_element_does(shared_tmp):
    """The thin cantilever of scripts/locking.py at nu = 0.4999 (kappa = 5000 mu), on its
    coarse mesh: the P2 displacement element's tip deflection is 0.936 of the reference, the
    mixed element's 0.987, as at nu = 0.3 (0.996), and the incompressible limit's the same
    to 1e-3.  The reference: the mixed element on the mesh refined twice, 9.76399e-4
    (results/locking/table.md, docs/MATERIALS.md)."""
    kappa = f"material.kappa={2 * 1.4999 / (3 * (1 - 2 * 0.4999))!r}"
    reference = 9.76399e-4
    displacement = _tip(shared_tmp / "displacement", [kappa]) / reference
    mixed = _tip(shared_tmp / "mixed", [kappa, "material.formulation=mixed"]) / reference
    limit = _tip(shared_tmp / "limit", ["material.incompressible=true"]) / reference
    assert displacement < 0.95, displacement  # locked: measured 0.9363
    assert mixed == pytest.approx(0.9865, abs=2e-3)
    assert limit == pytest.approx(mixed, rel=1e-3)


@pytest.mark.parametrize("sets, words", [
    (["material.incompressible=true", "material.formulation=displacement"],
     "material.formulation: an incompressible body needs the mixed formulation"),
    (["material.formulation=mixed", "material.kind=energy",
      "material.energy=I1b - 3 + (J - 1)**2"], "material.formulation: mixed splits off"),
    (["material.formulation=mixed", *NH, "material.kappa=5", "material.volumetric=log"],
     "material.volumetric: the mixed formulation enforces the quadratic"),
    (["material.formulation=mixed", "model.degree=1"],
     "model.degree: the mixed formulation is Taylor-Hood"),
    (["material.formulation=mixed", "solver.linear=gamg"],
     "solver.linear: gamg is for a positive definite tangent"),
    (["material.incompressible=true", *NH, "material.kappa=5"],
     "material.kappa: not used by kind 'neo_hookean'"),
    (["material.incompressible=true", "material.formulation=mixed", "model.dim=2",
      "model.reduction=plane_stress"],
     "material.formulation: plane stress holds the third stretch in closed form"),
])
def test_the_mixed_formulation_s_config_says_what_it_needs(sets, words):
    with pytest.raises(ConfigError) as err:
        load(CONFIGS / "tiny" / "beam_wave.yaml", sets)
    assert any(line.startswith(words) for line in err.value.problems), err.value.problems


def test_an_incompressible_body_is_mixed_and_a_preset_adds_no_kappa():
    m = load(CONFIGS / "tiny" / "beam_wave.yaml",
             ["material.preset=treloar_ogden", "material.incompressible=true"]).material
    assert (m.formulation, m.kappa, m.kind) == ("mixed", None, "ogden")
    m = load(CONFIGS / "tiny" / "beam_wave.yaml").material
    assert (m.formulation, m.incompressible) == ("displacement", False)
    m = load(CONFIGS / "tiny" / "beam_wave.yaml",  # a sheet: J = 1 by its third stretch
             ["model.dim=2", "model.reduction=plane_stress", "material.preset=treloar_ogden",
              "material.incompressible=true"]).material
    assert (m.formulation, m.kappa, m.kind) == ("displacement", None, "ogden")
