"""The lab presets and how they were fitted: the incompressible Yeoh solid's uniaxial nominal
stress against the derivative of its energy, the non-negative fit recovering known constants,
each silicone preset equal to the fit of its tensile curve in data/lab_materials/ (the Soft
Robotics Materials Database's), and every preset loaded as its kind with its bulk modulus."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CONFIGS, ROOT

from shapegrowth.config import load
from shapegrowth.config.energies import POISSON, PRESETS, preset_shear
from shapegrowth.config.lab_fits import fit_yeoh, read_tensile_curve, yeoh_nominal_stress
from shapegrowth.errors import InputError

DATA = ROOT / "data" / "lab_materials"
FITTED = [name for name, preset in PRESETS.items() if preset.data]


def test_the_yeoh_uniaxial_stress_is_the_derivative_of_its_energy():
    """P(lambda) = dW/dlambda for W = W0(I1(lambda)), I1 = lambda^2 + 2/lambda (the
    incompressible uniaxial stretch): central differences, 1e-8 relative."""
    c = (0.1, -0.01, 0.002)  # any sign: the formula, not the fit

    def energy(lam: np.ndarray) -> np.ndarray:
        x = lam ** 2 + 2 / lam - 3
        return c[0] * x + c[1] * x ** 2 + c[2] * x ** 3

    lam = np.linspace(0.6, 3.0, 25)
    h = 1e-5
    numeric = (energy(lam + h) - energy(lam - h)) / (2 * h)
    assert np.allclose(yeoh_nominal_stress(c, lam), numeric, rtol=1e-8, atol=1e-9)


def test_the_fit_recovers_the_constants_of_a_yeoh_curve():
    """A curve made by known non-negative constants (one of them zero) is fitted back to
    round-off, the residual zero."""
    c = (0.0786, 0.0, 0.0012)
    strain = np.linspace(0.02, 2.0, 60)
    fit = fit_yeoh(strain, yeoh_nominal_stress(c, 1 + strain))
    assert np.allclose((fit.c10, fit.c20, fit.c30), c, rtol=1e-9, atol=1e-13)
    assert fit.rms < 1e-12 and fit.points == 60 and fit.shear_modulus == pytest.approx(0.1572)


def test_the_fit_keeps_the_constants_non_negative():
    """A softening curve (c20 < 0 would fit it best) gets c20 = 0: the fitted solid stays
    stable past its data."""
    strain = np.linspace(0.05, 2.0, 40)
    fit = fit_yeoh(strain, yeoh_nominal_stress((0.05, -0.002, 0.0), 1 + strain))
    assert min(fit.c10, fit.c20, fit.c30) >= 0.0 and fit.c20 == 0.0 and fit.rms > 1e-3


@pytest.mark.parametrize("name", FITTED)
def test_each_silicone_preset_is_the_fit_of_its_tensile_curve(name):
    """The preset's constants (three significant figures) are the fit of its curve on
    1 < lambda <= 3: the two nominal stresses within 0.5 % of the largest, the shear modulus
    to 3 figures; the fit's residual at most 1.5 % of the largest stress (root mean square;
    measured 0.19-1.49 %) and 7.5 % at worst (Ecoflex 00-10's slack first points: 7.2 %)."""
    preset = PRESETS[name]
    strain, stress = read_tensile_curve(DATA / f"{preset.data}.csv")
    fit = fit_yeoh(strain, stress)
    lam = np.linspace(1.0, 3.0, 81)
    shipped = tuple(float(preset.constants[k]) for k in ("c10", "c20", "c30"))
    fitted = yeoh_nominal_stress((fit.c10, fit.c20, fit.c30), lam)
    top = np.abs(stress[strain <= 2.0]).max()
    assert np.abs(yeoh_nominal_stress(shipped, lam) - fitted).max() < 5e-3 * top
    assert preset_shear(preset) == pytest.approx(fit.shear_modulus, rel=5e-3)
    assert fit.rms < 0.015 and fit.worst < 0.075, fit
    assert fit.points > 80


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_preset_loads_as_its_kind_with_its_bulk_modulus(name):
    """``material.preset`` gives the preset's kind and constants, and kappa for Poisson's
    ratio 0.49 at its small-strain shear modulus; the hydrogel's is E/3 of its published
    neo-Hookean fit (20.74 kPa)."""
    preset = PRESETS[name]
    m = load(CONFIGS / "tiny" / "beam_wave.yaml", [f"material.preset={name}"]).material
    assert m.kind == preset.kind
    for key, value in preset.constants.items():
        assert getattr(m, key) == value
    mu = preset_shear(preset)
    assert m.kappa == pytest.approx(2 * mu * (1 + POISSON) / (3 * (1 - 2 * POISSON)), rel=1e-5)
    if name == "pva_gel":
        assert mu == pytest.approx(20.74e-3 / 3, rel=1e-3)


def test_a_file_without_the_engineering_columns_is_refused_in_one_line(tmp_path):
    path = tmp_path / "curve.csv"
    path.write_text("Time (s);True Strain;True Stress (MPa)\n0.1;0.01;0.02\n")
    with pytest.raises(InputError, match="no header row naming 'Engineering Strain'"):
        read_tensile_curve(path)


def test_a_row_without_numbers_is_refused_naming_its_line(tmp_path):
    path = tmp_path / "curve.csv"
    path.write_text("Material;mine\nEngineering Strain;Engineering Stress (MPa)\n0.1;0.02\n"
                    "0.2;n/a\n")
    with pytest.raises(InputError, match=r"curve.csv, line 4: no numbers"):
        read_tensile_curve(path)
