"""The config's sections of the body (geometry, mesh, model, material, boundary, loads,
growth, target; the objective, optimiser, solver, verification and outputs are
numerics.py's): typed, frozen dataclasses whose fields carry their help, default and range
(schema.py), and :class:`ConfigError`.  Reading and validating a config is loading.py's."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TypeVar

from ..errors import ConfigError
from .schema import option

GEOMETRY_PARAMS: dict[str, tuple[str, ...]] = {
    "box": ("length", "width", "thickness"),
    "tube": ("length", "radius", "thickness"),
    "annulus": ("radius", "inner_radius", "thickness"),
    "cylinder_shell": ("radius", "height", "thickness"),
    "rectangle": ("side",),
    "cube": ("side",),
    "file": (),  # geometry.path and geometry.scale
}
BOUNDARIES: dict[str, tuple[str, ...]] = {
    "box": ("x1_min", "x1_max", "x2_min", "x2_max", "x3_min", "x3_max"),
    "tube": ("x1_min", "x1_max", "inner", "outer"),
    "annulus": ("inner_rim", "outer_rim", "x3_min", "x3_max"),
    "cylinder_shell": ("bottom_rim", "top_rim", "inner", "outer"),
    "rectangle": ("x1_min", "x1_max", "x2_min", "x2_max"),
    "cube": ("x1_min", "x1_max", "x2_min", "x2_max", "x3_min", "x3_max"),
    "file": (),  # the file's physical groups and geometry.boundaries name them
}
# the bodies geometry.kind: file reads (physics/bodies.py): CAD meshed here, meshes read as
# they are
CAD_FORMATS = (".step", ".stp", ".iges", ".igs", ".brep")
MESH_FORMATS = (".msh", ".xdmf")
# objective.compare's face names beside the boundaries' own (docs/CONFIG.md)
FACE_ALIASES: dict[str, dict[str, str]] = {
    "box": {"top": "x3_max", "bottom": "x3_min"},
    "annulus": {"top": "x3_max", "bottom": "x3_min"},
    "rectangle": {"top": "x2_max", "bottom": "x2_min"},
    "cube": {"top": "x3_max", "bottom": "x3_min"},
}
PLANES = ("x1x2", "x1x3")
REDUCTIONS = ("plane_strain", "plane_stress", "axisymmetric", "shell")
LAYERED = ("box", "tube", "annulus", "cylinder_shell")  # bodies with a thin direction
CURVED = ("tube", "annulus", "cylinder_shell")  # bodies whose 3D hexahedra are curved cells
FRAMES = ("cartesian", "cylindrical", "tube", "free")
PAPER_ANGLE_BOUNDS_3D = ((0.0, 2 * math.pi), (0.0, math.pi), (0.0, 2 * math.pi))
PAPER_ANGLE_BOUNDS_2D = ((0.0, 2 * math.pi),)

Scalar = float | str  # a number or an expression
T = TypeVar("T")


def resolved(value: T | None) -> T:
    """A key whose default depends on others (``growth.eigenvalues.design``, ...): ``None``
    in the schema means "the default", which every :class:`Config` resolves when it is made
    (root.py), so a config's value is never ``None``."""
    if value is None:
        raise ConfigError(["config: a default was left unresolved (make configs with load, "
                           "from_dict or Config(...))"])
    return value


@dataclass(frozen=True)
class GeometryConfig:
    kind: str = option("shape of the reference body: a built-in one, or 'file' (geometry.path)",
                       choices=tuple(GEOMETRY_PARAMS))
    length: float | None = option("box, tube: extent along X1, from X1 = 0", None, gt=0)
    width: float | None = option("box: extent along X2, centred on X2 = 0", None, gt=0)
    thickness: float | None = option(
        "box: extent along X3 centred on X3 = 0; tube, annulus, cylinder_shell: wall", None, gt=0)
    radius: float | None = option("tube, annulus, cylinder_shell: outer radius", None, gt=0)
    inner_radius: float | None = option("annulus: inner radius", None, gt=0)
    height: float | None = option("cylinder_shell: extent along X3, from X3 = 0", None, gt=0)
    side: float | None = option("rectangle, cube: side length, centred at the origin", None, gt=0)
    path: str | None = option(
        "file: the body's file, a CAD part (STEP, IGES or BREP: meshed here with the `mesh` "
        "keys, second order), a gmsh mesh (.msh, read as it is: its cells, their order and "
        "its physical groups, which become boundary names) or a dolfinx XDMF mesh (.xdmf, "
        "each value N of its facet tags a boundary named tag_N)", None)
    scale: float = option("file: factor on the file's coordinates (0.001 for a part drawn in "
                          "millimetres and a body in metres)", 1.0, gt=0)
    boundaries: dict[str, str] = option(
        "named boundaries of any body, NAME: SELECTOR, for every key that takes a boundary "
        "name: a condition on the reference coordinates x1, x2, x3 (and r, theta, the "
        "geometry's numbers and `parameters`), true at a boundary facet's centre (e.g. "
        "'x1 < 1e-6', 'x3 > 0.99 and x1 > 5'), a physical group's name in a .msh, or 'face "
        "N' (a CAD part's face N, or several: 'face 3, 7'). A built-in body's boundaries keep "
        "their names", {})


@dataclass(frozen=True)
class MeshConfig:
    size: float = option("target element size (a .msh body keeps its own cells; give its "
                         "typical size)", gt=0)
    layers: int = option("elements through the wall or thickness (layered bodies)", 2, ge=1)
    clamp_size: float | None = option(
        "element size at the clamp (box or tube at x1_min, annulus at inner_rim, "
        "cylinder_shell at bottom_rim, a CAD part's clamped faces), growing to `size` away "
        "from it (resolves the sharp "
        "bend a clamped end needs); default: uniform `size`", None, gt=0)
    grading: float = option("growth of the element size per unit distance from the clamp "
                            "(with clamp_size)", 0.5, gt=0)
    refine: int = option("uniform refinements of the built mesh (each cell split in 4 in 2D, "
                         "8 in 3D; nested, so fields of the coarse mesh carry over exactly)",
                         0, ge=0, le=3)
    cells: str = option(
        "cell kind: 'simplex' (triangles in 2D, tetrahedra in 3D) or 'hex' (second-order "
        "quadrilaterals in 2D, hexahedra in 3D, 9 and 27 nodes; structured, `layers` through "
        "the thickness; `refine` regenerates the mesh with every count doubled, nested; a "
        "CAD part's: where gmsh can sweep it, a block; a mesh file keeps its own cells)",
        "simplex", choices=("simplex", "hex"))
    cache_dir: str = option("folder of the mesh cache", "meshes")


@dataclass(frozen=True)
class ModelConfig:
    dim: int = option("3, or 2: a plane body (rectangle), the section of a 3D body (box, "
                      "annulus, cylinder_shell) in `plane`, reduced by `reduction`, or a "
                      "thin body's shell (reduction: shell)", 3,
                      choices=(2, 3))
    plane: str | None = option(
        "dim 2: the coordinate plane the 2D mesh lies in: x1x2 (rectangle) or x1x3 (the "
        "section of a box, annulus or cylinder_shell; (R, Z) when axisymmetric); default: "
        "the geometry's", None, choices=PLANES)
    reduction: str = option(
        "dim 2: what the third direction does: plane_strain (no stretch), plane_stress (free "
        "stretch, no stress), axisymmetric (the hoop stretch (R + u_R)/R of a body of "
        "revolution about X3), or shell: a thin box's, tube's or cylinder shell's "
        "mid-surface as a growth shell, its growth lifted onto the 3D wall for the "
        "verification (docs/SHELLS.md)",
        "plane_strain", choices=REDUCTIONS)
    degree: int = option("polynomial degree of the displacement", 2, choices=(1, 2))
    quadrature_degree: int | None = option(
        "quadrature degree of the energy (default 2*degree; UFL's own estimate is far higher)",
        None, ge=1, le=12)


MATERIALS = ("mooney_rivlin", "neo_hookean", "yeoh", "gent", "ogden", "energy")
# each energy's constants: required, or with the default given here
MATERIAL_PARAMS: dict[str, dict[str, float | None]] = {
    "mooney_rivlin": {"mu1": 0.5, "mu2": 0.5, "lmbda": 3.0},
    "neo_hookean": {"mu": None, "kappa": None},
    "yeoh": {"c10": None, "c20": 0.0, "c30": 0.0, "kappa": None},
    "gent": {"mu": None, "Jm": None, "kappa": None},
    "ogden": {"kappa": None},
    "energy": {},
}
# the constants that are not single numbers: required by their kind, refused by the others
MATERIAL_EXTRAS: dict[str, tuple[str, ...]] = {"ogden": ("mu_p", "alpha_p"),
                                               "energy": ("energy",)}
OGDEN_TERMS = 3
VOLUMETRIC = ("quadratic", "log", "simo_taylor")


@dataclass(frozen=True)
class MaterialConfig:
    kind: str = option(
        "strain energy of the elastic part of F (physics/material.py): the paper's "
        "compressible Mooney-Rivlin (5.1), or on the isochoric invariants with a volumetric "
        "part U(J): neo_hookean (mu, kappa), yeoh (c10, c20, c30, kappa), gent (mu, Jm, kappa), "
        "ogden (mu_p, alpha_p, kappa) on the isochoric principal stretches; or energy: "
        "material.energy, a density of one's own", "mooney_rivlin", choices=MATERIALS)
    preset: str | None = option(
        "a lab material of docs/MATERIALS.md by name (e.g. treloar_ogden): its kind and "
        "constants (MPa), kappa for Poisson's ratio 0.49; a constant given beside it is taken "
        "instead of the preset's", None)
    mu1: float | None = option("Mooney-Rivlin mu1 (5.1) (default 0.5)", None, ge=0)
    mu2: float | None = option("Mooney-Rivlin mu2 (5.1) (default 0.5)", None, ge=0)
    lmbda: float | None = option("Mooney-Rivlin volumetric modulus lambda (5.1) (default 3)",
                                 None, ge=0)
    mu: float | None = option("shear modulus (neo_hookean, gent)", None, gt=0)
    c10: float | None = option("Yeoh's c10 (the shear modulus is 2 c10)", None, gt=0)
    c20: float | None = option("Yeoh's c20 (default 0)", None)
    c30: float | None = option("Yeoh's c30 (default 0)", None)
    Jm: float | None = option("Gent's limit of I1b - 3", None, gt=0)
    mu_p: tuple[float, ...] | None = option(
        "Ogden's mu_p, one to three terms: W = sum mu_p/alpha_p (sum_i lb_i^alpha_p - 3) over "
        "the isochoric stretches lb_i (the shear modulus is sum mu_p alpha_p / 2)", None)
    alpha_p: tuple[float, ...] | None = option("Ogden's alpha_p, one per mu_p, none zero", None)
    energy: str | None = option(
        "kind energy: W0 of the elastic part of F (its volumetric part included) over I1, I2, "
        "J and I1b = J^(-2/3) I1, I2b = J^(-4/3) I2, and the config's parameters, e.g. "
        "'c1*(I1b - 3) + k/2*(J - 1)**2'", None)
    kappa: float | None = option("bulk modulus of U(J) (neo_hookean, yeoh, gent, ogden)", None,
                                 gt=0)
    formulation: str | None = option(
        "displacement (the displacement alone) or mixed (displacement and pressure, "
        "Taylor-Hood: P2-P1 on simplices, Q2-Q1 on hexahedra; the volumetric part's kappa/2 "
        "(J - 1)^2 enforced through the pressure, so no locking as kappa/mu grows; "
        "docs/MATERIALS.md); default: mixed where incompressible (in plane stress the third "
        "stretch holds J = 1: displacement), else displacement", None,
        choices=("displacement", "mixed"))
    incompressible: bool = option(
        "J of the elastic part held at 1 by the pressure (the mixed formulation's limit; in "
        "plane stress by the third stretch, any kind; no kappa or lmbda)", False)
    volumetric: str | None = option(
        "U(J) of neo_hookean, yeoh, gent and ogden: 'quadratic' kappa/2 (J - 1)^2, 'log' kappa/2 "
        "(log J)^2 or 'simo_taylor' kappa/4 (J^2 - 1 - 2 log J) (default quadratic)", None,
        choices=VOLUMETRIC)


@dataclass(frozen=True)
class BoundaryConfig:
    clamp: str | tuple[str, ...] = option(
        "named boundary clamped in all directions, or a list of them (e.g. [x1_min, x1_max]: "
        "held at both ends), 'rigid' (remove rigid motions only), or 'none' (boundary.fix "
        "alone holds the body)")
    fix: dict[str, tuple[str, ...]] = option(
        "displacement components held at zero on a named boundary, beside the clamp, e.g. "
        "{x2_min: [x2]} (a roller or a symmetry plane, so that half a symmetric part is "
        "modelled)", {})

    @property
    def clamped(self) -> tuple[str, ...]:
        """The clamped boundaries' names (('rigid',) for rigid pins)."""
        return (self.clamp,) if isinstance(self.clamp, str) else tuple(self.clamp)


@dataclass(frozen=True)
class LoadsConfig:
    body_force: tuple[float, ...] | None = option("body force f per reference volume (2.7)", None)
    traction: dict[str, tuple[float, ...]] = option(
        "reference traction s0 (2.6) per named boundary, e.g. {x1_max: [0, 0, -1e-3]}", {})
    pressure: dict[str, float] = option(
        "follower pressure p per named boundary, on the deformed surface along minus its "
        "outward normal (p > 0 on a cavity's wall inflates it); the potential -p V of the "
        "volume the surface encloses, so the surface must be closed, or its rim clamped or on "
        "symmetry planes of boundary.fix (3D and plane bodies)", {})


@dataclass(frozen=True)
class EigenvaluesConfig:
    initial: tuple[Scalar, ...] | None = option(
        "initial lambda_i, each a number or an expression (default 1)", None)
    bounds: tuple[float, float] = option("lower and upper bound of every lambda_i", (0.01, 12.0))
    design: tuple[int, ...] | None = option(
        "which eigenvalues the optimiser may change (default all)", None)
    incompressible: bool = option("lambda_N = 1/(product of the others): give N-1 values", False)


@dataclass(frozen=True)
class AnglesConfig:
    initial: tuple[Scalar, ...] | None = option(
        "initial Rodrigues angles theta_i (frame: free), numbers or expressions (default 0)", None)
    bounds: tuple[tuple[float, float], ...] | None = option(
        "bounds per angle (default [0, 2pi], [0, pi], [0, 2pi]; 2D: [0, 2pi]); in 3D a third "
        "pair from -pi ([-pi, pi]) lets a frame turn both ways about one axis with its "
        "angles continuous (growth.start: target keeps the axes in one hemisphere then; "
        "docs/SCENES.md, scene 6)", None)


@dataclass(frozen=True)
class GrowthConfig:
    frame: str = option("eigenvector frame of C_g", "cartesian", choices=FRAMES)
    eigenvalues: EigenvaluesConfig = option("eigenvalue fields lambda_i", EigenvaluesConfig())
    angles: AnglesConfig = option("angle fields theta_i (frame: free)", AnglesConfig())
    filter_length: float = option("Helmholtz filter length l (5.7); 0: no filter", 0.0, ge=0)
    across_wall: str = option(
        "a thin wall's designed fields: 'free' (a value at every node) or 'uniform' (one value "
        "across the wall, each column of nodes through it at its mean, after the filter: the "
        "design stretches the mid-surface and bends the wall only through the fields it does "
        "not design, such as the target's metric with start: target; docs/SCENES.md, "
        "'Scene 4')", "free", choices=("free", "uniform"))
    degree: int | None = option(
        "polynomial degree of the growth fields (default: 2 on the curved hexahedra of a "
        "tube, annulus or cylinder shell in 3D, whose bilinear fields miss the linear "
        "functions of X that bend a wall: the helix's exact growth lands 4.1 % from it with 1, "
        "0.04 % with 2; 1 elsewhere)", None, choices=(1, 2))
    start: str = option(
        "initial growth: 'given' (eigenvalues.initial, angles.initial) or 'target': the target "
        "map's metric grad Phi_d^T grad Phi_d, projected on the frame (free: its eigenvalues "
        "and directions) and clipped to the bounds, 'lifted': the best growth of the 2D "
        "section run in `from_run`, extruded or revolved onto this 3D body, or 'run': the "
        "best growth of the run in `from_run` on the same mesh, field by field (a fixed "
        "frame's eigenvalues start a free frame at angle 0)", "given",
        choices=("given", "target", "lifted", "run"))
    from_run: str | None = option(
        "start: lifted or run: the folder of a finished run (its summary.json and "
        "growth.npz): of a 2D section model of this body (lifted), of this body on this "
        "mesh (run)", None)
    levels: tuple[float, ...] | tuple[tuple[float, ...], ...] | None = option(
        "the values every designed eigenvalue takes at the end of a run, increasing: one "
        "material per value, each of one growth (swelling) ratio (e.g. [1.0, 1.3]: two "
        "materials), or one such list per designed eigenvalue, in growth.eigenvalues.design's "
        "order (e.g. [[0.9, 1.2], [1.0, 1.1]]; a material is then one level of each). The "
        "filtered field is projected onto them by a smoothed Heaviside per "
        "interval whose sharpness grows over the stages of growth.sharpness; the run ends with "
        "the crisp design (each value sent to its nearest level), settled and verified from "
        "rest. The design's bounds become [first, last]; the filter length is the smallest "
        "feature", None)
    sharpness: tuple[float, ...] = option(
        "growth.levels: the projection's sharpness beta, one optimisation stage each, "
        "increasing (each stage gets its share of optimizer.max_iterations; an alpha schedule "
        "runs first, at the first sharpness)", (1.0, 2.0, 4.0, 8.0, 16.0, 32.0))

    grey_penalty: float = option(
        "growth.levels: weight w of the discreteness penalty w s D added to J (s the target's "
        "size), D the mean over the body and the designed eigenvalues of "
        "4 (p - a)(b - p) / (b - a)^2 (p a projected value, [a, b] its interval: 0 at the "
        "levels, 1 between): it keeps the optimiser from holding a design between two levels, "
        "on the projection's steep slope, that the crisp rounding then moves (measured on "
        "scene 1's section, two levels: verified 9.4 % with 0.01, 28 % without); 0: none",
        0.01, ge=0)

    def level_sets(self) -> tuple[tuple[float, ...], ...] | None:
        """growth.levels per designed eigenvalue (growth.eigenvalues.design's order): the one
        list for all repeated, or each eigenvalue's own; None without levels."""
        if self.levels is None:
            return None
        n = len(resolved(self.eigenvalues.design))
        levels: tuple = self.levels
        if levels and isinstance(levels[0], tuple):
            return tuple(tuple(float(g) for g in level) for level in levels)
        return (tuple(float(g) for g in levels),) * n


ALIGNMENTS = ("none", "principal_axes", "best_fit")


@dataclass(frozen=True)
class TransformConfig:
    """Where a target file lands: x -> R (s x) + t, then optionally a rigid alignment."""

    scale: float | tuple[float, ...] = option(
        "scale factor s of the file's coordinates (one number, or one per axis), e.g. 0.001 "
        "for a file in millimetres and a body in metres", 1.0)
    rotation: tuple[float, ...] = option(
        "rotation R in degrees about X1, then X2, then X3 (fixed axes), after the scaling",
        (0.0, 0.0, 0.0))
    translation: tuple[float, ...] = option("translation t, after the rotation",
                                            (0.0, 0.0, 0.0))
    align: str = option(
        "'principal_axes': then move the target rigidly so that its centroid and principal "
        "axes of inertia fall on the body's reference ones (needs three distinct principal "
        "moments in both); 'best_fit': from where scale, rotation and translation put it, the "
        "rigid motion that brings it closest to the body's compared part (iterated closest "
        "points: to the face's tangent planes where a face is compared, else to its points), "
        "for targets whose principal axes are not defined (a square, a disk, a cube) or not "
        "the body's", "none", choices=ALIGNMENTS)

    @property
    def identity(self) -> bool:
        return (self.scale in (1.0, (1.0, 1.0, 1.0)) and not any(self.rotation)
                and not any(self.translation) and self.align == "none")


@dataclass(frozen=True)
class TargetConfig:
    map: tuple[Scalar, ...] | None = option("target map Phi_d(X), one expression per component",
                                            None)
    mesh: str | None = option("target body as a mesh file (gmsh .msh)", None)
    surface: str | None = option(
        "target as a surface file (STL, OBJ, PLY, OFF or gmsh .msh triangles), repaired where "
        "that is safe (duplicate vertices merged; triangles without area, given twice or "
        "unreferenced dropped; turned consistently), the repair said in one line: compared "
        "with the body's volume it must be closed and is filled with tetrahedra by gmsh; "
        "compared with a face (objective.compare) it may be open, with non-manifold edges "
        "(3D models)", None)
    crop: str | None = option(
        "surface targets: keep only the triangles whose centre satisfies this condition over "
        "the file's own coordinates x1, x2, x3 (before target.transform; e.g. 'x3 > 140' for a "
        "scan's top), the rest dropped before the repair", None)
    pieces: str = option(
        "surface targets: of a file's disconnected pieces keep the 'largest' by area (a scan's "
        "stray fragments dropped, said in the repair's line) or 'all'", "largest",
        choices=("largest", "all"))
    transform: TransformConfig = option(
        "placement of a mesh or surface target's file (units, rotation, position)",
        TransformConfig())
    weights: str = option(
        "map targets: the measure of the target cloud: 'volume' w_q |det grad Phi_d| (the "
        "target's own volume; the push-forward where the map has no volume) or 'pushforward' "
        "w_q (the reference measure carried by the map)", "volume",
        choices=("volume", "pushforward"))
