"""The rules of ``model: {dim: 2, reduction: shell}``: the config describes the 3D thin body
(its geometry, material, growth and target are the 3D body's, checked as a 3D config's),
and the shell stands for it; what the shell does not model yet is refused, each in one
line naming the key and the fix."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .root import Config

@dataclass(frozen=True)
class ShellKind:
    """How a thin body's shell stands for it: the growth's ``frame``, the ``axis`` of a
    curved wall (0: X1, 2: X3; None: the plane X3 = 0), the growth eigenvalues (0-based)
    along the shell's two tangents (along the axis, or X1, first) and across the wall, and
    the clamps at its ends: name -> (coordinate, the geometry key of its value, or None: 0)."""

    frame: str
    axis: int | None
    tangents: tuple[int, int]
    across: int
    ends: dict[str, tuple[int, str | None]]


SHELL_KINDS = {
    "box": ShellKind("cartesian", None, (0, 1), 2,
                     {"x1_min": (0, None), "x1_max": (0, "length")}),
    "tube": ShellKind("tube", 0, (0, 1), 2, {"x1_min": (0, None), "x1_max": (0, "length")}),
    "cylinder_shell": ShellKind("cylindrical", 2, (2, 1), 0,
                                {"bottom_rim": (2, None), "top_rim": (2, "height")}),
}
SHELL_BODIES = tuple(SHELL_KINDS)


def solid_config(cfg: Config) -> Config:
    """The 3D body a shell config stands for: its model keys those of a 3D model."""
    model = dataclasses.replace(cfg.model, dim=3, plane=None, reduction="plane_strain")
    return dataclasses.replace(cfg, model=model)


def check_shell(cfg: Config, errors: list[str],
                check_solid: Callable[[Config, list[str]], Config]) -> Config:
    """``cfg`` with a shell model, checked: as the 3D body it stands for (``check_solid``,
    the 3D config's rules) and by the shell's own; its model keys kept."""
    kind = cfg.geometry.kind
    if kind not in SHELL_KINDS:
        errors.append(f"model.reduction: shell models a thin box, tube or cylinder_shell, not "
                      f"a {kind}; use model.dim: 3 (or axisymmetric, the annulus's section)")
        return cfg
    if cfg.model.plane is not None:
        errors.append("model.plane: a shell's mid-surface is its body's own, it has no plane; "
                      "remove the key")
    if cfg.model.degree != 2:
        errors.append("model.degree: a shell's displacement is P2 (with the cubic bubble), its "
                      "director's angles P2; set 2 or remove the key")
    solid = check_solid(solid_config(cfg), errors)
    body = SHELL_KINDS[kind]
    frame = body.frame
    if solid.growth.frame != frame:
        errors.append(f"growth.frame: a {kind}'s shell grows along its {frame} frame (the "
                      f"shell's tangents, and across the wall); set growth.frame: {frame}")
    clamped = solid.boundary.clamped
    if not set(clamped) <= set(body.ends):
        errors.append(f"boundary.clamp: a shell is clamped at its ends ({', '.join(body.ends)}"
                      f"), not {', '.join(clamped)}; use model.dim: 3 for another support")
    if solid.boundary.fix:
        errors.append("boundary.fix: a shell is held by its clamp alone; remove the key or use "
                      "model.dim: 3")
    loads = solid.loads
    if any(loads.body_force or ()) or loads.traction or loads.pressure:
        errors.append("loads: a shell carries no loads (its growth alone); remove loads.* or "
                      "use model.dim: 3")
    if solid.target is None or solid.target.map is None:
        errors.append("target.map: a shell's target is a map of its body (the wall's cloud "
                      "carried by it); a target.surface or target.mesh needs model.dim: 3")
    eig = solid.growth.eigenvalues
    initial = eig.initial
    across = body.across
    if initial is not None and len(initial) == 3 and not (
            isinstance(initial[across], (int, float)) and initial[across] == 1):
        errors.append(f"growth.eigenvalues.initial: a shell keeps its wall's thickness "
                      f"(lambda_{across + 1} = 1, across it); give 1.0 there, or use "
                      "model.dim: 3")
    if eig.incompressible:
        errors.append("growth.eigenvalues.incompressible: not on a shell (its wall's "
                      "thickness is kept); remove the key")
    growth = solid.growth
    if growth.levels is not None:
        errors.append("growth.levels: a shell's design is continuous; remove the key or use "
                      "model.dim: 3")
    if growth.start != "given":
        errors.append(f"growth.start: a shell starts from growth.eigenvalues.initial, not "
                      f"'{growth.start}'; use start: given")
    if solid.optimizer.levels != (0,):
        errors.append("optimizer.levels: a shell runs on its own mesh (one level); remove the "
                      "key")
    if solid.optimizer.from_rest_every or solid.optimizer.stability.min_eigenvalue is not None:
        errors.append("optimizer.from_rest_every, optimizer.stability: not on a shell; remove "
                      "them")
    if solid.objective.complexity.kind != "none":
        errors.append("objective.complexity: not on a shell; set kind: none or use model.dim: 3")
    if solid.objective.compare != "volume" or solid.objective.placement != "pinned":
        errors.append("objective.compare, objective.placement: a shell compares its whole wall "
                      "where its clamp holds it (volume, pinned)")
    verify = solid.verify
    if verify.lift is not None or verify.every or verify.best != "self":
        errors.append("verify.lift, verify.every, verify.best: a shell is verified on its own "
                      "3D body at the end of the run; remove them")
    return dataclasses.replace(solid, model=cfg.model)
