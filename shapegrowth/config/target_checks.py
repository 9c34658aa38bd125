"""The config's rules for the target and what is compared with it (objective.compare,
target.map / mesh / surface, target.transform): each problem is appended to ``errors`` as
one line naming the key; nothing is raised here (config/checks.py calls these)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import ExpressionError
from .expressions import COORDINATES
from .sections import FACE_ALIASES
from .selectors import Condition

if TYPE_CHECKING:
    from .reduction import Section
    from .root import Config
    from .sections import TargetConfig

# the surface files target.surface may name (read by shape/surface_formats.py)
SURFACE_FORMATS = (".stl", ".obj", ".ply", ".off", ".msh")
# the faces of a body that a section model does not keep (a box's X1-X3 section)
OFF_SECTION = {"box": ("x2_min", "x2_max")}


def check_compare(cfg: Config, section: Section, boundaries: tuple[str, ...],
                  errors: list[str]) -> None:
    """objective.compare: volume, boundary, or faces of this body; a face is compared with a
    target map's image of the same face or with a target surface; a section compares the
    faces it keeps (its edges stand for them); ``boundaries``: the body's names."""
    names = cfg.objective.compared
    kind = cfg.geometry.kind
    faces = cfg.objective.faces(kind)
    if faces is None:
        return
    allowed = (*FACE_ALIASES.get(kind, {}), *boundaries)
    body = "the file's body" if kind == "file" else f"a {kind}"
    wrong = [n for n in names if n not in allowed] if faces else []
    if not names or wrong or (len(names) > 1 and not set(names).isdisjoint({"volume",
                                                                             "boundary"})):
        errors.append(f"objective.compare: {list(names) if len(names) != 1 else names[0]} is "
                      f"not volume, boundary or faces of {body} (faces: {', '.join(allowed)})")
    elif len(set(faces)) < len(faces):
        errors.append(f"objective.compare: {list(names)} names a face twice; name each once")
    off = [n for n in faces if n in OFF_SECTION.get(kind, ())] if section.reduced else []
    if off:
        errors.append(f"objective.compare: '{off[0]}' is not on the section a 2D model of a "
                      f"{kind} keeps; compare a face in the plane, or use model.dim: 3")
    if cfg.target is not None and cfg.target.mesh is not None:
        errors.append("objective.compare: a face is compared with a target.map's image of it "
                      "or with a target.surface, not with a volume mesh; use compare: volume")


def check_target(cfg: Config, errors: list[str]) -> None:
    target = cfg.target
    assert target is not None  # the caller checks
    given = [key for key in ("map", "mesh", "surface") if getattr(target, key) is not None]
    if len(given) != 1:
        errors.append("target: give exactly one of 'map' (expressions), 'mesh' (a volume mesh "
                      "file) or 'surface' (a closed surface file)"
                      + (f", not {' and '.join(given)}" if given else ""))
    if target.map is not None and len(target.map) != cfg.growth_dim:
        errors.append(f"target.map: give {cfg.growth_dim} components"
                      + (" (the 3D body's map)" if cfg.section.reduced else ""))
    if target.mesh is not None and not Path(target.mesh).is_file():
        errors.append(f"target.mesh: file '{target.mesh}' not found")
    if target.surface is not None:
        if not Path(target.surface).is_file():
            errors.append(f"target.surface: file '{target.surface}' not found")
        elif Path(target.surface).suffix.lower() not in SURFACE_FORMATS:
            errors.append(f"target.surface: '{target.surface}' has an unknown format; give "
                          ".stl, .obj, .ply, .off or .msh")
        if cfg.dim != 3 and not cfg.section.reduced:
            errors.append("target.surface: a surface bounds a 3D solid; use model.dim: 3 (a 2D "
                          "model takes target.map or a 2D target.mesh)")
    if target.crop is not None:
        if target.surface is None:
            errors.append("target.crop: crops a target.surface; give one, or remove the key")
        else:
            try:
                Condition(target.crop, COORDINATES)
            except ExpressionError as exc:
                errors.append(f"target.crop: '{target.crop}': {exc}")
    if target.pieces != "largest" and target.surface is None:
        errors.append("target.pieces: chooses the pieces of a target.surface; give one, or "
                      "remove the key")
    _check_transform(target, errors)


def _check_transform(target: TargetConfig, errors: list[str]) -> None:
    t = target.transform
    if target.map is not None and not t.identity:
        errors.append("target.transform: places a mesh or surface file; write a map in place")
    scale = t.scale if isinstance(t.scale, tuple) else (t.scale,)
    if len(scale) not in (1, 3) or not all(s > 0 for s in scale):
        errors.append("target.transform.scale: give one positive number or three")
    for key in ("rotation", "translation"):
        if len(getattr(t, key)) != 3:
            errors.append(f"target.transform.{key}: give three numbers (X1, X2, X3)")
