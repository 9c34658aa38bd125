"""``material``: a preset resolved into its kind and constants, each energy's constants given or
defaulted and the others absent, Ogden's terms and a user's energy checked."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, Any

from ..errors import ExpressionError
from .energies import (
    PRESETS,
    REST_TOLERANCE,
    preset_kappa,
    small_strain_moduli,
)
from .reduction import Section
from .sections import MATERIAL_EXTRAS, MATERIAL_PARAMS, OGDEN_TERMS, MaterialConfig

if TYPE_CHECKING:
    from .root import Config


def check_material(cfg: Config, section: Section, errors: list[str]) -> MaterialConfig:
    """The material with a preset's kind and constants filled in, each energy's constants
    given or defaulted, the volumetric part named only where the energy has one to choose."""
    m = _with_preset(cfg.material, errors)
    params = dict(MATERIAL_PARAMS[m.kind])
    if m.incompressible:  # the pressure holds J = 1: no bulk modulus
        params.pop("kappa", None)
        params.pop("lmbda", None)
    takes = ", ".join([*params, *MATERIAL_EXTRAS.get(m.kind, ())])
    values: dict[str, float | None] = {}
    for name in dict.fromkeys(n for kind in MATERIAL_PARAMS.values() for n in kind):
        given = getattr(m, name)
        if name in params:
            values[name] = given if given is not None else params[name]
            if values[name] is None:
                errors.append(f"material.{name}: required for kind '{m.kind}' (it takes "
                              f"{takes})")
        elif given is not None:
            errors.append(f"material.{name}: not used by kind '{m.kind}' (it takes {takes})")
    for kind, names in MATERIAL_EXTRAS.items():
        for name in names:
            given = getattr(m, name)
            if kind == m.kind and given is None:
                errors.append(f"material.{name}: required for kind '{m.kind}' (it takes "
                              f"{takes})")
            elif kind != m.kind and given is not None:
                errors.append(f"material.{name}: not used by kind '{m.kind}' (it takes "
                              f"{takes})")
    volumetric = m.volumetric
    if m.kind in ("mooney_rivlin", "energy"):
        if volumetric is not None:
            own = "(lmbda)" if m.kind == "mooney_rivlin" else "(written in material.energy)"
            errors.append(f"material.volumetric: kind '{m.kind}' has its own volumetric part "
                          f"{own}; remove the key or choose another kind")
    else:
        volumetric = volumetric or "quadratic"
    if m.kind != "mooney_rivlin" and section.stress_free and not m.incompressible:
        errors.append(f"material.kind: plane stress holds the third stretch in closed form "
                      f"for a compressible mooney_rivlin or any incompressible body, not a "
                      f"compressible {m.kind}; set material.incompressible: true, or use "
                      "model.reduction: plane_strain or model.dim: 3")
    formulation = _check_formulation(cfg, m, volumetric, errors)
    if m.kind == "ogden" and m.mu_p is not None and m.alpha_p is not None:
        _check_ogden(m.mu_p, m.alpha_p, errors)
    if m.kind == "energy" and m.energy is not None:
        _check_energy(m.energy, cfg.expression_params, errors)
    v = values.get
    return dataclasses.replace(m, formulation=formulation, volumetric=volumetric,
                               mu1=v("mu1"), mu2=v("mu2"), lmbda=v("lmbda"), mu=v("mu"),
                               c10=v("c10"), c20=v("c20"), c30=v("c30"), Jm=v("Jm"),
                               kappa=v("kappa"))


def _with_preset(m: MaterialConfig, errors: list[str]) -> MaterialConfig:
    """``material.preset``'s kind and constants, a constant given beside it kept."""
    if m.preset is None:
        return m
    preset = PRESETS.get(m.preset)
    if preset is None:
        errors.append(f"material.preset: unknown '{m.preset}' (known: {', '.join(PRESETS)}; "
                      "docs/MATERIALS.md)")
        return m
    if m.kind not in ("mooney_rivlin", preset.kind):  # mooney_rivlin: the default, unset
        errors.append(f"material.kind: preset '{m.preset}' is a {preset.kind} energy, not "
                      f"{m.kind}; remove material.kind")
        return m
    changes: dict[str, Any] = {"kind": preset.kind}
    for name, value in preset.constants.items():
        if getattr(m, name) is None:
            changes[name] = value
    if m.kappa is None and not m.incompressible:
        changes["kappa"] = preset_kappa(preset)
    return dataclasses.replace(m, **changes)


def _check_formulation(cfg: Config, m: MaterialConfig, volumetric: str | None,
                       errors: list[str]) -> str:
    """The formulation: mixed where asked or incompressible; what the mixed one needs."""
    membrane = cfg.section.stress_free  # incompressible: J = 1 through the third stretch
    formulation = m.formulation or ("mixed" if m.incompressible and not membrane
                                    else "displacement")
    if m.incompressible and formulation != "mixed" and not membrane:
        errors.append("material.formulation: an incompressible body needs the mixed "
                      "formulation (in 3D, plane strain and axial symmetry; plane stress "
                      "holds J = 1 through the third stretch); remove the key or set it to "
                      "mixed")
    if formulation != "mixed":
        return formulation
    if m.kind == "energy":
        errors.append("material.formulation: mixed splits off the volumetric part kappa/2 "
                      "(J - 1)^2, which a user's energy does not name; use kind neo_hookean, "
                      "yeoh, gent, ogden or mooney_rivlin")
    elif volumetric not in (None, "quadratic"):
        errors.append(f"material.volumetric: the mixed formulation enforces the quadratic "
                      f"kappa/2 (J - 1)^2, not {volumetric}; remove the key")
    if membrane:
        errors.append("material.formulation: plane stress holds the third stretch in closed "
                      "form (J = 1 through it where incompressible); a mixed body runs in 3D, "
                      "plane strain or axial symmetry: remove the key")
    if cfg.model.degree != 2:
        errors.append("model.degree: the mixed formulation is Taylor-Hood, P2 displacements "
                      "with a P1 pressure; set model.degree: 2")
    if cfg.solver.linear in ("mumps_blr", "gamg", "hypre", "pmg"):
        errors.append(f"solver.linear: {cfg.solver.linear} is for a positive definite "
                      "tangent; a mixed body's is a saddle point: use mumps, mumps_ldlt, "
                      "mumps_ooc or auto")
    return formulation


def _check_ogden(mu_p: tuple[float, ...], alpha_p: tuple[float, ...],
                 errors: list[str]) -> None:
    if not 1 <= len(mu_p) <= OGDEN_TERMS or len(alpha_p) != len(mu_p):
        errors.append(f"material.alpha_p: one alpha_p per mu_p, 1 to {OGDEN_TERMS} terms (got "
                      f"{len(mu_p)} mu_p, {len(alpha_p)} alpha_p)")
        return
    if any(a == 0 for a in alpha_p):
        errors.append("material.alpha_p: no alpha_p may be zero (mu_p/alpha_p divides by it)")
        return
    shear = sum(m * a for m, a in zip(mu_p, alpha_p)) / 2
    if shear <= 0:
        errors.append(f"material.mu_p: the shear modulus sum mu_p alpha_p / 2 must be positive "
                      f"(it is {shear:g})")


def _check_energy(text: str, params: dict[str, float], errors: list[str]) -> None:
    try:
        moduli = small_strain_moduli(text, params)
    except ExpressionError as err:
        errors.append(f"material.energy: {err}")
        return
    floor = REST_TOLERANCE * (abs(moduli.shear) + abs(moduli.bulk))  # the differences' error
    if not moduli.shear > floor or not moduli.bulk > floor:
        errors.append(f"material.energy: its small-strain shear and bulk moduli must be "
                      f"positive (they are {moduli.shear:.4g} and {moduli.bulk:.2g}); add a "
                      "volumetric part such as k/2*(J - 1)**2")
    elif abs(moduli.rest_pressure) > REST_TOLERANCE * (moduli.shear + moduli.bulk):
        errors.append(f"material.energy: not stress-free at F = I (pressure "
                      f"{moduli.rest_pressure:.4g}); its derivative in J must vanish at rest, "
                      "e.g. write (J - 1)**2 or J**2 - 1 - 2*log(J), not J")
