"""A user's strain-energy density (``material.kind: energy``) checked before any mesh is made,
and the lab materials ``material.preset`` names.

``material.energy`` is W0 of the elastic part A = F G^-1 written over its invariants
``I1 = |A|^2``, ``I2 = |cof A|^2``, ``J = det A`` and the isochoric ``I1b = J^(-2/3) I1``,
``I2b = J^(-4/3) I2``, in the config's expression language (parsed, never executed).  Here it
is evaluated with numpy on two one-parameter deformations, a simple shear F = I + g e1 (x) e2
and a dilatation F = (1 + e) I: W0''(g) at 0 is the small-strain shear modulus mu, W0''(e) at 0
is 9 kappa, and W0'(e) at 0 is 3 times the pressure at rest (central differences, Richardson-
extrapolated), which must vanish (an energy not stress-free at F = I would move the body
without growth).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ExpressionError
from .expressions import Expression

INVARIANTS = ("I1", "I2", "J", "I1b", "I2b")

STEP = 1e-3  # the central differences' step (extrapolated: relative error ~1e-10)
REST_TOLERANCE = 1e-6  # the largest pressure at rest, relative to mu + kappa


def invariants(F: np.ndarray) -> dict[str, float]:
    """The names ``material.energy`` may use, of a 3x3 (elastic) deformation gradient."""
    C = F.T @ F
    i1 = float(np.trace(C))
    i2 = float((i1 ** 2 - np.trace(C @ C)) / 2)
    J = float(np.linalg.det(F))
    return {"I1": i1, "I2": i2, "J": J, "I1b": J ** (-2 / 3) * i1, "I2b": J ** (-4 / 3) * i2}


@dataclass(frozen=True)
class Moduli:
    """A strain-energy density's small-strain constants."""

    shear: float
    bulk: float
    rest_pressure: float  # dW0/dJ at F = I: zero for an energy stress-free at rest


def parse_energy(text: str, params: Mapping[str, float],
                 functions: Mapping[str, Callable[..., Any]] | None = None) -> Expression:
    """``material.energy`` parsed over the invariants and the config's named numbers (its
    calls numpy's, or ``functions``)."""
    return Expression(text, [*INVARIANTS, *params], functions)


def small_strain_moduli(text: str, params: Mapping[str, float]) -> Moduli:
    """mu, kappa and the pressure at rest of ``material.energy`` (raises ExpressionError)."""
    expr = parse_energy(text, params)

    def w(F: np.ndarray) -> float:
        value = float(np.asarray(expr({**params, **invariants(F)}), dtype=float))
        if not np.isfinite(value):
            raise ExpressionError(f"W0 is not finite near F = I ({value})")
        return value

    eye = np.eye(3)
    shear = np.zeros((3, 3))
    shear[0, 1] = 1.0
    w0 = w(eye)

    def second(direction: np.ndarray, scale: float) -> float:
        """W0'' at 0 along F = scale I + t direction."""
        return _richardson(lambda h: (w(scale * eye + h * direction) - 2 * w0
                                      + w(scale * eye - h * direction)) / h ** 2)

    mu = second(shear, 1.0)
    kappa = second(eye, 1.0) / 9
    rest = _richardson(lambda h: (w((1 + h) * eye) - w((1 - h) * eye)) / (2 * h)) / 3
    return Moduli(shear=mu, bulk=kappa, rest_pressure=rest)


def _richardson(difference: Callable[[float], float]) -> float:
    """A central difference of steps STEP and STEP/2 extrapolated: error O(STEP^4)."""
    return (4 * difference(STEP / 2) - difference(STEP)) / 3


@dataclass(frozen=True)
class Preset:
    """A lab material: an energy and its constants (MPa), fitted by ``source``."""

    kind: str
    constants: Mapping[str, float | tuple[float, ...]]
    source: str
    note: str = ""
    data: str = ""  # the tensile curve it was fitted to: data/lab_materials/<data>.csv


# the fits are of incompressible models; the bulk modulus kappa a preset adds is 49.67 mu
# (Poisson's ratio 0.49 at small strain), which material.kappa overrides
POISSON = 0.49
# the silicones: non-negative Yeoh constants fitted by config/lab_fits.py (1 < lambda <= 3) to
# the uniaxial curves of the Soft Robotics Materials Database (ASTM D412 die C, nominal stress)
MARECHAL = ("fitted to the uniaxial tensile curve (ASTM D412) of L. Marechal et al., Soft "
            "Robotics (2020), doi:10.1089/soro.2019.0115, from its Soft Robotics Materials "
            "Database (ODbL 1.0)")
# name, material, c10, c20, c30 (MPa)
_FITTED = (
    ("ecoflex_0010", "Smooth-On Ecoflex 00-10", 0.00367, 0.000126, 0.0),
    ("ecoflex_0030", "Smooth-On Ecoflex 00-30", 0.00786, 9.43e-05, 0.0),
    ("ecoflex_0050", "Smooth-On Ecoflex 00-50", 0.0107, 0.000231, 0.0),
    ("dragon_skin_10", "Smooth-On Dragon Skin 10 Medium", 0.025, 0.00181, 0.0),
    ("dragon_skin_20", "Smooth-On Dragon Skin 20", 0.0727, 0.0042, 0.0),
    ("dragon_skin_30", "Smooth-On Dragon Skin 30", 0.103, 0.00509, 0.0),
    ("rtv615", "Momentive RTV615 (a PDMS)", 0.163, 0.0139, 0.000939),
)
PRESETS: dict[str, Preset] = {
    "treloar_ogden": Preset(
        "ogden", {"mu_p": (0.63, 0.0012, -0.01), "alpha_p": (1.3, 5.0, -2.0)},
        "R. W. Ogden, Proc. R. Soc. Lond. A 326 (1972) 565-584, fitted to L. R. G. Treloar's "
        "vulcanised natural rubber (Trans. Faraday Soc. 40 (1944) 59); in MPa as G. A. "
        "Holzapfel, Nonlinear Solid Mechanics (Wiley, 2000), Sect. 6.5",
        "natural rubber, the classic three-term fit"),
    "elastosil_m4601": Preset(
        "yeoh", {"c10": 0.11, "c20": 0.02, "c30": 0.0},
        "P. Polygerinos et al., IEEE Trans. Robotics 31 (2015) 778-789 (Wacker Elastosil M4601 "
        "A/B)", "the fibre-reinforced bending actuators' silicone"),
    "pva_gel": Preset(
        "neo_hookean", {"mu": 0.00691},
        "D. C. Lin et al., Biomech. Model. Mechanobiol. 8 (2009) 345-358, "
        "doi:10.1007/s10237-008-0139-9, Table 3: a poly(vinyl alcohol) hydrogel in "
        "compression, the neo-Hookean fit's Young's modulus 20.74 kPa; mu = E/3",
        "a hydrogel (PVA)"),
    **{name: Preset("yeoh", {"c10": c10, "c20": c20, "c30": c30}, MARECHAL, material, name)
       for name, material, c10, c20, c30 in _FITTED},
}


def preset_shear(preset: Preset) -> float:
    """A preset's small-strain shear modulus (MPa)."""
    c = preset.constants
    if preset.kind == "ogden":
        mu_p, alpha_p = c["mu_p"], c["alpha_p"]
        assert isinstance(mu_p, tuple) and isinstance(alpha_p, tuple)
        return sum(m * a for m, a in zip(mu_p, alpha_p)) / 2
    if preset.kind == "yeoh":
        c10 = c["c10"]
        assert isinstance(c10, float)
        return 2 * c10
    mu = c["mu"]
    assert isinstance(mu, float)
    return mu


def preset_kappa(preset: Preset) -> float:
    """The bulk modulus a preset adds: Poisson's ratio ``POISSON`` at small strain."""
    return round(2 * preset_shear(preset) * (1 + POISSON) / (3 * (1 - 2 * POISSON)), 6)
