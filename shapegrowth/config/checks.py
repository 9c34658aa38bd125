"""Cross-field rules of the config, and the defaults that depend on other keys
(the dimension, the geometry kind).  Each problem is appended to ``errors`` as one
line naming the key; nothing is raised here."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path
from typing import TYPE_CHECKING

from .expressions import CONSTANTS, COORDINATES, FUNCTIONS, Expression, ExpressionError
from .material_checks import check_material
from .reduction import SECTIONED, SHELL, Section, section_of
from .sections import (
    BOUNDARIES,
    CAD_FORMATS,
    CURVED,
    GEOMETRY_PARAMS,
    LAYERED,
    MESH_FORMATS,
    PAPER_ANGLE_BOUNDS_2D,
    PAPER_ANGLE_BOUNDS_3D,
    GrowthConfig,
    ModelConfig,
)
from .selectors import msh_physical_names, parse_selector
from .shell_checks import check_shell
from .target_checks import OFF_SECTION, check_compare, check_target

if TYPE_CHECKING:
    from .root import Config


# bodies whose mesh can be graded towards their clamp (mesh.clamp_size)
GRADED = (("box", "x1_min"), ("tube", "x1_min"), ("annulus", "inner_rim"),
          ("cylinder_shell", "bottom_rim"))


def resolve_and_check(cfg: Config, errors: list[str]) -> Config:
    """Cross-field rules and dimension-dependent defaults."""
    if cfg.model.dim == 2 and cfg.model.reduction == SHELL:  # checked as its 3D body
        return check_shell(cfg, errors, resolve_and_check)
    geo, dim = cfg.geometry, cfg.model.dim
    kind = geo.kind
    for name in ("length", "width", "thickness", "radius", "inner_radius", "height", "side"):
        given = getattr(geo, name) is not None
        if name in GEOMETRY_PARAMS[kind] and not given:
            errors.append(f"geometry.{name}: required for kind '{kind}'")
        elif name not in GEOMETRY_PARAMS[kind] and given:
            takes = (f"it takes {', '.join(GEOMETRY_PARAMS[kind])}" if GEOMETRY_PARAMS[kind]
                     else "the file gives its shape; remove the key")
            errors.append(f"geometry.{name}: not used by kind '{kind}' ({takes})")
    if kind == "annulus" and geo.radius and geo.inner_radius and geo.inner_radius >= geo.radius:
        errors.append("geometry.inner_radius: must be smaller than geometry.radius")
    if kind in ("tube", "cylinder_shell") and geo.radius and geo.thickness \
            and geo.thickness >= geo.radius:
        errors.append("geometry.thickness: the wall must be thinner than geometry.radius")
    _check_file(cfg, errors)
    model = _check_model(cfg, errors)
    cfg = dataclasses.replace(cfg, model=model)
    section = section_of(dim, kind, model.reduction)

    names = boundary_names(cfg, errors)
    clamped = cfg.boundary.clamped
    bc = clamped[0] if len(clamped) == 1 else None  # the one clamp (grading, rigid)
    allowed = (*names, "rigid", "none")
    for name in clamped:
        if name not in allowed and not _read_later(cfg, name):
            errors.append(f"boundary.clamp: '{name}' is not a boundary of {_body(cfg)} "
                          f"(allowed: {', '.join(allowed)}; name more in "
                          "geometry.boundaries)")
    if not clamped:
        errors.append("boundary.clamp: an empty list; name a boundary, a list of them, or "
                      "rigid")
    elif len(clamped) > 1 and "rigid" in clamped:
        errors.append("boundary.clamp: rigid pins three vertices of a free body and stands "
                      "alone; give it without other boundaries")
    elif len(clamped) > 1 and "none" in clamped:
        errors.append("boundary.clamp: none stands alone; give it without other boundaries")
    elif clamped == ("none",) and not cfg.boundary.fix:
        errors.append("boundary.clamp: none leaves the body free; hold it with boundary.fix "
                      "(stopping every rigid motion), or use rigid")
    elif len(set(clamped)) < len(clamped):
        errors.append(f"boundary.clamp: {list(clamped)} names a boundary twice; name each "
                      "once")

    cad = kind == "file" and Path(geo.path or "").suffix.lower() in CAD_FORMATS
    if cfg.mesh.clamp_size is not None:
        if cad and clamped and not set(clamped) & {"rigid", "none"}:
            if cfg.mesh.clamp_size >= cfg.mesh.size:
                errors.append("mesh.clamp_size: must be smaller than mesh.size (or left out)")
        elif (kind, bc) not in GRADED:
            graded = ", ".join(f"{k} clamped at {c}" for k, c in GRADED)
            errors.append(f"mesh.clamp_size: grades the mesh towards a clamp: {graded}, or "
                          "a CAD part's clamped faces; remove the key")
        elif cfg.mesh.clamp_size >= cfg.mesh.size:
            errors.append("mesh.clamp_size: must be smaller than mesh.size (or left out)")

    for name in clamped:
        if section.reduced and name in OFF_SECTION.get(kind, ()):
            errors.append(f"boundary.clamp: '{name}' is not on the section a 2D model of a "
                          f"{kind} keeps; clamp a boundary in the plane, or use model.dim: 3")

    loads = cfg.loads
    n_load = 3 if section.reduced else dim  # a section's loads are the 3D body's
    body_force = loads.body_force if loads.body_force is not None else (0.0,) * n_load
    if len(body_force) != n_load:
        errors.append(f"loads.body_force: give {n_load} components")
    for key, named in (("loads.traction", loads.traction), ("loads.pressure", loads.pressure),
                       ("boundary.fix", cfg.boundary.fix)):
        for name in named:
            if name not in names and not _read_later(cfg, name):
                errors.append(f"{key}.{name}: not a boundary of {_body(cfg)} (allowed: "
                              f"{', '.join(names) or 'none yet'}; name more in "
                              "geometry.boundaries)")
    for name, vec in loads.traction.items():
        if vec is not None and len(vec) != n_load:
            errors.append(f"loads.traction.{name}: give {n_load} components")
    _check_fix_and_pressure(cfg, section, errors)
    if section.reduced:
        out = section.out_of_plane
        for key, vec in [("body_force", body_force), *(
                (f"traction.{n}", v) for n, v in loads.traction.items())]:
            if vec is not None and len(vec) == 3 and vec[out] != 0.0:
                errors.append(f"loads.{key}: a 2D model of a {kind} carries no load along "
                              f"X{out + 1} (out of its plane); set that component to 0")

    growth = _check_growth(cfg, errors)
    if section.reduced:
        _check_reduced(cfg, section, errors)
    elif cfg.verify.lift is not None:
        errors.append("verify.lift: lifts a 2D section model (model.dim: 2 of a box, annulus "
                      "or cylinder_shell) to 3D; remove the key")
    if cfg.verify.lift_refine is not None and cfg.verify.lift is None:
        errors.append("verify.lift_refine: refines the mesh of verify.lift, which is not set; "
                      "set verify.lift or remove the key")
    if cfg.verify.lift_degree is not None and cfg.verify.lift is None:
        errors.append("verify.lift_degree: the growth's degree on the body of verify.lift, "
                      "which is not set; set verify.lift or remove the key")
    if cfg.verify.best == "verified" and not (cfg.verify.enabled and cfg.verify.every):
        errors.append("verify.best: 'verified' chooses among verify.every's checks; set "
                      "verify.every (e.g. 20) with verify.enabled: true, or verify.best: self")
    _check_names(cfg, errors)
    _check_expressions(cfg, growth, errors)
    if cfg.target is not None:
        check_target(cfg, errors)
    check_compare(cfg, section, names, errors)
    if cfg.objective.placement == "fitted" and cfg.boundary.clamped != ("rigid",):
        errors.append("objective.placement: fitted moves a free body (boundary.clamp: rigid) "
                      "onto its best fit; a clamped body stands where its clamp holds it: "
                      "use placement: pinned or clamp: rigid")
    alphas = [a for a in cfg.objective.hausdorff.alphas if a is not None]  # None: reported
    if not cfg.objective.hausdorff.alphas or any(a <= 0 for a in alphas):
        errors.append("objective.hausdorff.alpha: give a positive number or a list of them, "
                      "e.g. [100, 300, 1000]")
    elif any(b < a for a, b in zip(alphas, alphas[1:])):
        errors.append("objective.hausdorff.alpha: a schedule must not decrease (it starts "
                      "smooth and ends sharp), e.g. [100, 300, 1000]")
    hausdorff = cfg.objective.hausdorff
    if hausdorff.taper > hausdorff.cutoff:
        errors.append(f"objective.hausdorff.taper: {hausdorff.taper} is wider than the cutoff "
                      f"{hausdorff.cutoff}; give at most the cutoff (default 2)")
    if hausdorff.precision == "float32" and (hausdorff.phi != "exp" or hausdorff.cutoff > 60):
        errors.append("objective.hausdorff.precision: float32 needs phi: exp and a cutoff of at "
                      "most 60 (its exponents stop at exp(-80)); use float64 here")
    _check_levels(cfg, errors)
    if cfg.solver.continuation.min_step > cfg.solver.continuation.initial_step:
        errors.append("solver.continuation.min_step: must not exceed initial_step")
    if cfg.solver.linear == "pmg" and model.degree != 2:
        errors.append(f"solver.linear: pmg coarsens P2 (Q2) displacements to P1 (Q1), and "
                      f"model.degree is {model.degree}; set model.degree: 2 or another solver")
    for key in cfg.solver.petsc_options:
        if not key.startswith(("state_", "adjoint_", "filter_")):
            errors.append(f"solver.petsc_options.{key}: keys start with state_, adjoint_ "
                          "or filter_")

    material = check_material(cfg, section, errors)
    return dataclasses.replace(cfg, growth=growth, model=model, material=material,
                               loads=dataclasses.replace(loads, body_force=tuple(body_force)))


# boundaries of a sectioned body that its section does not keep
# the section of each sectioned body, and its reductions
_SECTION_REDUCTIONS = {"box": ("plane_strain", "plane_stress"), "annulus": ("axisymmetric",),
                       "cylinder_shell": ("axisymmetric",)}


def _check_model(cfg: Config, errors: list[str]) -> ModelConfig:
    """model.dim, plane and reduction against the geometry; resolves the default plane."""
    m, kind = cfg.model, cfg.geometry.kind
    if m.dim == 3:
        if kind == "rectangle":
            errors.append("model.dim: 3 does not fit geometry.kind 'rectangle' (a 2D body); "
                          "use dim: 2, or the cube")
        if m.plane is not None or m.reduction != "plane_strain":
            errors.append("model.plane, model.reduction: a 3D model has none; remove them or "
                          "set model.dim: 2")
        return m
    if kind not in (*SECTIONED, "rectangle", "file"):
        errors.append(f"model.dim: 2 does not fit geometry.kind '{kind}' (2D: a rectangle, a "
                      f"file's plane part, or the section of a {', '.join(SECTIONED)})")
        return m
    plane = m.plane or ("x1x2" if kind in ("rectangle", "file") else "x1x3")
    if kind in ("rectangle", "file"):
        body = "a rectangle" if kind == "rectangle" else "a file's plane part"
        if plane != "x1x2":
            errors.append(f"model.plane: {body} lies in x1x2")
        if m.reduction == "axisymmetric":
            errors.append(f"model.reduction: {body} is a plane body (plane_strain or "
                          "plane_stress); axisymmetric models take an annulus or "
                          "cylinder_shell")
    else:
        if plane != "x1x3":
            errors.append(f"model.plane: the section of a {kind} is x1x3 (X1 = R and X3 = Z "
                          "when axisymmetric)")
        if m.reduction not in _SECTION_REDUCTIONS[kind]:
            errors.append(f"model.reduction: a {kind} reduces to "
                          f"{' or '.join(_SECTION_REDUCTIONS[kind])}")
    return dataclasses.replace(m, plane=plane)


def _check_reduced(cfg: Config, section: Section, errors: list[str]) -> None:
    """What a section model of a 3D body needs: a frame that keeps the third direction a
    principal direction of C_g, a target map, and a 3D config to lift to."""
    frame = cfg.growth.frame
    allowed = ("cylindrical",) if section.axisymmetric else ("cartesian", "cylindrical")
    if frame not in allowed:
        errors.append(f"growth.frame: the {cfg.model.reduction} model takes "
                      f"{' or '.join(allowed)} (the out-of-plane direction must stay an "
                      f"eigenvector of C_g), not {frame}")
    if cfg.growth.eigenvalues.incompressible:
        errors.append("growth.eigenvalues.incompressible: not available in a 2D section "
                      "model; use model.dim: 3")
    if cfg.target is not None and cfg.target.mesh is not None:
        errors.append("target.mesh: a 2D section model takes a target.map (the 3D body's); "
                      "use model.dim: 3 for a target mesh")
    if cfg.target is not None and cfg.target.surface is not None:
        errors.append("target.surface: a 2D section model takes a target.map (the 3D body's); "
                      "use model.dim: 3 for a surface target")
    lift = cfg.verify.lift
    if lift is not None and not Path(lift).is_file():
        errors.append(f"verify.lift: file '{lift}' not found (the 3D config to lift to)")


def _check_levels(cfg: Config, errors: list[str]) -> None:
    opt = cfg.optimizer
    levels = opt.levels
    if not levels or levels[0] < 0 or any(b <= a for a, b in zip(levels, levels[1:])) \
            or levels[-1] > 3:
        errors.append(f"optimizer.levels: refinements rising from 0 to at most 3, e.g. [0, 1], "
                      f"got {list(levels)}")
    if opt.level_iterations is not None:
        if len(opt.level_iterations) != len(levels):
            errors.append(f"optimizer.level_iterations: give {len(levels)} numbers, one per "
                          "level of optimizer.levels")
        elif any(n < 1 for n in opt.level_iterations):
            errors.append("optimizer.level_iterations: each level needs at least 1 iteration")
    far = cfg.solver.rtol_far
    if far is not None and far < cfg.solver.rtol:
        errors.append(f"solver.rtol_far: {far:g} is tighter than solver.rtol "
                      f"({cfg.solver.rtol:g}); give a looser tolerance, or null")
    if far is not None and opt.ftol_rel <= 0:
        errors.append("solver.rtol_far: scales with optimizer.ftol_rel, which is 0; "
                      "set optimizer.ftol_rel > 0 or solver.rtol_far: null")
    if 1 < len(levels) > opt.max_iterations:
        errors.append(f"optimizer.max_iterations: {opt.max_iterations} cannot be shared by "
                      f"{len(levels)} levels (one iteration each at least); raise it")


def _check_growth_levels(cfg: Config, initial: tuple, design: tuple[int, ...],
                         errors: list[str]) -> None:
    """growth.levels and growth.sharpness (physics/projection.py); ``design`` the designed
    eigenvalues (1-based)."""
    g = cfg.growth
    beta = g.sharpness
    if not beta or any(b <= 0 for b in beta) or any(b >= c for b, c in zip(beta, beta[1:])):
        errors.append(f"growth.sharpness: positive and increasing, got {list(beta)}")
    if g.levels is None:
        return
    levels: tuple = g.levels
    nested = bool(levels) and isinstance(levels[0], tuple)
    if nested and len(levels) != len(design):
        errors.append(f"growth.levels: one list per designed eigenvalue (growth.eigenvalues."
                      f"design: {list(design)}), or one list for all; got {len(levels)}")
        return
    sets = levels if nested else (levels,) * len(design)
    lo, hi = g.eigenvalues.bounds
    for i, levels in zip(design, sets):
        if len(levels) < 2 or any(a >= b for a, b in zip(levels, levels[1:])):
            errors.append(f"growth.levels: two values or more, increasing, got {list(levels)}")
            return
        if not (lo <= levels[0] and levels[-1] <= hi):
            errors.append(f"growth.levels: {list(levels)} leave the eigenvalues' bounds "
                          f"[{lo}, {hi}]")
        value = initial[i - 1] if i - 1 < len(initial) else None
        if isinstance(value, float) and not levels[0] <= value <= levels[-1]:
            errors.append(f"growth.eigenvalues.initial[{i - 1}]: {value} is outside "
                          f"growth.levels' range [{levels[0]}, {levels[-1]}], the design's "
                          "bounds; start inside it (between two levels the projection moves "
                          "it most)")
    if g.eigenvalues.incompressible:
        errors.append("growth.levels: the derived lambda_N of eigenvalues.incompressible takes "
                      "other values than the levels; design every eigenvalue instead")
    if cfg.verify.best == "verified":
        errors.append("growth.levels: the crisp design is what is verified; verify.best: "
                      "verified (a check along the path, at a sharpness) does not apply")


def _check_growth(cfg: Config, errors: list[str]) -> GrowthConfig:
    g, dim = cfg.growth, cfg.growth_dim
    eig = g.eigenvalues
    n_eig = dim - 1 if eig.incompressible else dim
    initial = eig.initial if eig.initial is not None else (1.0,) * n_eig
    if len(initial) != n_eig:
        extra = f" (incompressible: lambda_{dim} is derived)" if eig.incompressible else ""
        errors.append(f"growth.eigenvalues.initial: give {n_eig} values{extra}, got {len(initial)}")
    lo, hi = eig.bounds
    bounds_ok = 0 < lo < hi
    if not bounds_ok:
        errors.append(f"growth.eigenvalues.bounds: need 0 < lower < upper, got [{lo}, {hi}]")
    for i, value in enumerate(initial):
        if bounds_ok and isinstance(value, float) and not lo <= value <= hi:
            errors.append(f"growth.eigenvalues.initial[{i}]: {value} is outside the bounds "
                          f"[{lo}, {hi}]")
    design = eig.design if eig.design is not None else tuple(range(1, n_eig + 1))
    bad = [d for d in design if not 1 <= d <= n_eig]
    if bad or len(set(design)) != len(design):
        errors.append(f"growth.eigenvalues.design: a subset of 1..{n_eig} without repeats, "
                      f"got {list(design)}")

    _check_growth_levels(cfg, initial, tuple(design), errors)

    if g.frame == "tube" and dim == 2:
        errors.append("growth.frame: 'tube' is a 3D frame (2D allows cartesian, cylindrical, free)")
    n_ang = 3 if dim == 3 else 1
    ang = g.angles
    a_init = ang.initial if ang.initial is not None else (0.0,) * n_ang
    a_bounds = ang.bounds if ang.bounds is not None else (
        PAPER_ANGLE_BOUNDS_3D if dim == 3 else PAPER_ANGLE_BOUNDS_2D)
    if len(a_init) != n_ang:
        errors.append(f"growth.angles.initial: give {n_ang} angle(s) in {dim}D, got {len(a_init)}")
    if len(a_bounds) != n_ang:
        errors.append(f"growth.angles.bounds: give {n_ang} [lower, upper] pair(s) in {dim}D")
    for i, (a_lo, a_hi) in enumerate(a_bounds):
        if not a_lo < a_hi:
            errors.append(f"growth.angles.bounds[{i}]: lower must be below upper, "
                          f"got [{a_lo}, {a_hi}]")
        elif i < len(a_init) and isinstance(value := a_init[i], float) \
                and not a_lo <= value <= a_hi:
            errors.append(f"growth.angles.initial[{i}]: {value} is outside its bounds "
                          f"[{a_lo}, {a_hi}]")
    if g.start == "target":
        _check_target_start(cfg, errors)
    if (g.start in ("lifted", "run")) != (g.from_run is not None):
        errors.append("growth.from_run: give it with start: lifted or run (and only then), "
                      "e.g. from_run: results/beam_wave_2d")
    elif g.from_run is not None:
        missing = [f for f in ("summary.json", "growth.npz")
                   if not (Path(g.from_run) / f).is_file()]
        if missing:
            errors.append(f"growth.from_run: '{g.from_run}' holds no {' or '.join(missing)} "
                          "(the folder of a finished run)")
        if g.start == "lifted" and cfg.model.dim != 3:
            errors.append("growth.start: 'lifted' starts a 3D model (model.dim: 3) from a 2D "
                          "section run")
    if g.across_wall == "uniform" and (cfg.model.dim != 3 or cfg.geometry.kind not in LAYERED):
        errors.append(f"growth.across_wall: 'uniform' needs a thin-walled 3D body (model.dim: "
                      f"3, geometry.kind one of {', '.join(LAYERED)}); use 'free' here")
    if g.frame != "free" and ang.initial is not None and any(
            not (isinstance(a, float) and a == 0.0) for a in ang.initial):
        errors.append("growth.angles.initial: angles act only with frame: free")
    degree = g.degree if g.degree is not None else growth_degree(cfg)
    return dataclasses.replace(
        g, degree=degree,
        eigenvalues=dataclasses.replace(eig, initial=tuple(initial), design=tuple(design)),
        angles=dataclasses.replace(ang, initial=tuple(a_init), bounds=tuple(a_bounds)))


def growth_degree(cfg: Config) -> int:
    """The growth fields' default degree: 2 on curved hexahedra (the 27-node cells of a tube,
    an annulus or a cylinder shell in 3D), 1 elsewhere.  A bilinear field on a curved cell
    is bilinear in the cell's reference coordinates, so it misses the linear functions of X
    (and P1 on the affine tetrahedra holds them): the stretch that bends a tube as a whole
    varies linearly across its section, and the helix's exact growth on hexahedra at h 0.5
    lands 4.09 % from the helix with 1 (2.62 % at h 0.35), 0.04 % with 2."""
    curved = (cfg.mesh.cells == "hex" and cfg.model.dim == 3 and not cfg.section.reduced
              and cfg.geometry.kind in CURVED)
    return 2 if curved else 1


def _check_target_start(cfg: Config, errors: list[str]) -> None:
    g = cfg.growth
    if cfg.target is None or cfg.target.map is None:
        errors.append("growth.start: 'target' needs target.map (a target mesh has no map); "
                      "use start: given")
    if g.eigenvalues.incompressible:
        errors.append("growth.start: 'target' is not defined with eigenvalues.incompressible")
    dim = cfg.growth_dim
    n_eig = dim - 1 if g.eigenvalues.incompressible else dim
    defaults = {"eigenvalues": (1.0,) * n_eig, "angles": (0.0,) * (3 if dim == 3 else 1)}
    for key, default in defaults.items():
        # the resolved config holds the defaults: a config checked again stays valid
        if getattr(g, key).initial not in (None, default):
            errors.append(f"growth.{key}.initial: start: target sets the initial growth; "
                          "remove one of the two")


def _body(cfg: Config) -> str:
    return "the file's body" if cfg.geometry.kind == "file" else f"a {cfg.geometry.kind}"


def _check_file(cfg: Config, errors: list[str]) -> None:
    """geometry.path and geometry.scale: a file body's, and only its."""
    geo = cfg.geometry
    if geo.kind != "file":
        for key, unused in (("path", geo.path is not None), ("scale", geo.scale != 1.0)):
            if unused:
                errors.append(f"geometry.{key}: used by kind 'file' only; remove the key")
        return
    if geo.path is None:
        errors.append("geometry.path: required for kind 'file' (a STEP, IGES, BREP or .msh "
                      "file)")
        return
    path = Path(geo.path)
    if path.suffix.lower() not in (*CAD_FORMATS, *MESH_FORMATS):
        errors.append(f"geometry.path: '{geo.path}' has an unknown format; give a CAD part "
                      f"({', '.join(CAD_FORMATS)}), a gmsh mesh (.msh) or a dolfinx XDMF "
                      "mesh (.xdmf)")
    elif not path.is_file():
        errors.append(f"geometry.path: file '{geo.path}' not found")
    if cfg.mesh.cells == "hex" and path.suffix.lower() not in CAD_FORMATS:
        errors.append("mesh.cells: a mesh file is read with its own cells (a .msh of "
                      "hexahedra as such); remove the key")


def file_groups(cfg: Config) -> tuple[str, ...]:
    """The physical groups of a .msh body's boundary (its facets' dimension), by name; an
    XDMF body's names (tag_N) are checked once its file is read (physics/geometry.py)."""
    geo = cfg.geometry
    if geo.kind != "file" or geo.path is None or Path(geo.path).suffix.lower() != ".msh" \
            or not Path(geo.path).is_file():
        return ()
    try:
        named = msh_physical_names(Path(geo.path))
    except (OSError, ValueError):
        return ()  # physics/bodies.py reports an unreadable file, naming geometry.path
    return tuple(n for n, (dim, _) in named.items() if dim == cfg.model.dim - 1)


def _read_later(cfg: Config, name: str) -> bool:
    """An XDMF body's tag_N: its file says whether it is there, once read."""
    return (cfg.geometry.kind == "file" and Path(cfg.geometry.path or "").suffix.lower()
            == ".xdmf" and re.fullmatch(r"tag_\d+", name) is not None)


def boundary_names(cfg: Config, errors: list[str] | None = None) -> tuple[str, ...]:
    """Every boundary name the body has: its kind's, its file's physical groups and
    geometry.boundaries' (each selector checked into ``errors``)."""
    builtin = BOUNDARIES.get(cfg.geometry.kind, ())
    groups = file_groups(cfg)
    for name, text in cfg.geometry.boundaries.items():
        key = f"geometry.boundaries.{name}"
        if errors is None:
            continue
        if not name.isidentifier():
            errors.append(f"{key}: not usable as a name (letters, digits and _, e.g. base)")
        elif name in builtin or name in groups:
            errors.append(f"{key}: already a boundary of {_body(cfg)}; choose another name")
        try:
            selector = parse_selector(name, text, groups, cfg.expression_params)
        except ExpressionError as err:
            errors.append(f"{key}: {err}; give a condition such as 'x1 < 1e-6', a physical "
                          "group's name or 'face N'")
            continue
        if selector.kind == "faces" and (cfg.geometry.kind != "file" or Path(
                cfg.geometry.path or "").suffix.lower() not in CAD_FORMATS):
            errors.append(f"{key}: '{text}' names faces of a CAD part, and the body is not "
                          "one; give a condition on x1, x2, x3 or a physical group's name")
    return tuple(dict.fromkeys((*builtin, *groups, *cfg.geometry.boundaries)))


_COMPONENTS = ("x1", "x2", "x3")


def _check_fix_and_pressure(cfg: Config, section: Section, errors: list[str]) -> None:
    """boundary.fix's components (the mesh's own axes) and loads.pressure's models."""
    axes = [_COMPONENTS[a] for a in section.axes]
    for name, components in cfg.boundary.fix.items():
        wrong = [c for c in components if c not in axes]
        if not components or wrong or len(set(components)) < len(components):
            errors.append(f"boundary.fix.{name}: give the held components, each once, among "
                          f"{', '.join(axes)} (e.g. [{axes[0]}])")
        if name in cfg.boundary.clamped:
            errors.append(f"boundary.fix.{name}: the boundary is clamped already (every "
                          "component held); remove one of the two")
    if cfg.loads.pressure and section.reduced:
        errors.append(f"loads.pressure: not available in a 2D section model "
                      f"({cfg.model.reduction}); use model.dim: 3")
    for name in cfg.loads.pressure:
        if name in cfg.boundary.clamped:
            errors.append(f"loads.pressure.{name}: the boundary is clamped, and a pressure "
                          "there does no work; load a free boundary")


def _check_names(cfg: Config, errors: list[str]) -> None:
    reserved = set(COORDINATES) | set(CONSTANTS) | set(FUNCTIONS)
    for name in cfg.parameters:
        if name in reserved or not name.isidentifier():
            errors.append(f"parameters.{name}: not usable as a name (reserved or not an "
                          "identifier)")


def _check_expressions(cfg: Config, growth: GrowthConfig, errors: list[str]) -> None:
    names = [*COORDINATES, *cfg.expression_params]
    groups = [("growth.eigenvalues.initial", growth.eigenvalues.initial),
              ("growth.angles.initial", growth.angles.initial)]
    if cfg.target is not None and cfg.target.map is not None:
        groups.append(("target.map", cfg.target.map))
    for key, values in groups:
        for i, value in enumerate(values or ()):
            if isinstance(value, str):
                try:
                    Expression(value, names)
                except ExpressionError as err:
                    errors.append(f"{key}[{i}]: {err}")
