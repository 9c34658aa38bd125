"""The gmsh builders of the reference bodies (rank 0 only; geometry.py caches and reads
their meshes).

Placement (every config and target map relies on it):

* ``box``: X1 in [0, L], X2 in [-w/2, w/2], X3 in [-t/2, t/2]; unstructured
  triangles of size h in the X1-X2 plane, extruded through the thickness in
  ``layers`` elements.
* ``tube``: hollow circular cylinder about the X1 axis, X1 in [0, L], outer
  radius R, wall t; a structured ring (``layers`` through the wall, size h
  around) swept along X1 in steps of h.
* ``annulus``: R1 <= r <= R2 in the X1-X2 plane, X3 in [-t/2, t/2].
* ``cylinder_shell``: axis X3, outer radius R, wall t, X3 in [0, height];
  structured ring swept along X3.
* ``rectangle`` (2D) and ``cube``: side s, centred at the origin; structured
  (criss-cross triangles, hexahedra split in six tetrahedra) with an even number
  of divisions about s/h, so the centre and the axes through it carry vertices
  (``clamp: rigid`` pins them; see boundary.py).

* a 2D section model of a box, annulus or cylinder shell (``model.reduction``): its X1-X3
  or (R, Z) section, a line across the thickness swept along the long direction.

Every boundary listed in :data:`shapegrowth.config.BOUNDARIES` is a physical
group; its tag is its position in that list plus one.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import BOUNDARIES, GEOMETRY_PARAMS, Config, resolved

BUILDER_VERSION = 4  # bump when a builder changes, so cached meshes are rebuilt


@dataclass(frozen=True)
class _Dimensions:
    """The geometry's numbers for its kind, as floats (a config holds every number its kind
    takes, GEOMETRY_PARAMS; the others are never read)."""

    length: float = math.nan
    width: float = math.nan
    thickness: float = math.nan
    radius: float = math.nan
    inner_radius: float = math.nan
    height: float = math.nan
    side: float = math.nan


def dims(cfg: Config) -> _Dimensions:
    geo = cfg.geometry
    return _Dimensions(**{k: float(resolved(getattr(geo, k))) for k in GEOMETRY_PARAMS[geo.kind]})



def build(cfg: Config, path: Path) -> None:
    """Build ``cfg``'s mesh with gmsh and write it to ``path`` (rank 0 only)."""
    import gmsh

    geo, h = cfg.geometry, cfg.mesh.size
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add(geo.kind)
        builders = {"box": _box, "tube": _tube, "annulus": _annulus,
                    "cylinder_shell": _cylinder_shell, "rectangle": _rectangle, "cube": _cube}
        if cfg.section.reduced:
            _section(gmsh, cfg, h)
        else:
            builders[geo.kind](gmsh, cfg, h)
        physical_groups(gmsh, cfg)
        gmsh.model.mesh.generate(cfg.model.dim)
        for _ in range(cfg.mesh.refine):
            gmsh.model.mesh.refine()
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def count(extent: float, h: float, minimum: int = 1) -> int:
    return max(minimum, int(round(extent / h)))


def _box(gmsh, cfg: Config, h: float) -> None:
    g = dims(cfg)
    occ = gmsh.model.occ
    rect = occ.addRectangle(0.0, -g.width / 2, -g.thickness / 2, g.length, g.width)
    occ.extrude([(2, rect)], 0, 0, g.thickness, numElements=[cfg.mesh.layers])
    occ.synchronize()
    gmsh.model.mesh.setSize(gmsh.model.getEntities(0), h)
    if cfg.mesh.clamp_size is not None:
        edges = [tag for dim, tag in gmsh.model.getBoundary([(2, rect)], oriented=False)
                 if abs(gmsh.model.occ.getCenterOfMass(dim, tag)[0]) < 1e-12]
        _graded_towards(gmsh, edges, cfg.mesh.clamp_size, h, cfg.mesh.grading)


# Grading towards the clamp (``mesh.clamp_size``, ``mesh.grading``): the element size is
# clamp_size at the clamped edge and grows by ``grading`` per unit distance up to mesh.size.
# An unstructured section (box, annulus) is graded by a size field and extruded through the
# thickness; a structured wall (tube, cylinder shell) by the heights of its extruded layers.

def _graded_towards(gmsh, curves: list[int], h_min: float, h: float, rate: float) -> None:
    """Size h_min on ``curves`` of the section, growing by ``rate`` per unit distance up to
    h (the extrusion carries the graded triangles through the thickness)."""
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "CurvesList", curves)
    field.setNumber(distance, "NumPointsPerCurve", 100)
    ramp = field.add("MathEval")
    field.setString(ramp, "F", f"min({h}, {h_min} + {rate} * F{distance})")
    field.setAsBackgroundMesh(ramp)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def _annulus(gmsh, cfg: Config, h: float) -> None:
    g = dims(cfg)
    occ = gmsh.model.occ
    outer = occ.addDisk(0, 0, -g.thickness / 2, g.radius, g.radius)
    inner = occ.addDisk(0, 0, -g.thickness / 2, g.inner_radius, g.inner_radius)
    ring, _ = occ.cut([(2, outer)], [(2, inner)])
    occ.extrude(ring, 0, 0, g.thickness, numElements=[cfg.mesh.layers])
    occ.synchronize()
    gmsh.model.mesh.setSize(gmsh.model.getEntities(0), h)
    if cfg.mesh.clamp_size is not None:  # towards the inner rim, the clamp
        rim = [tag for dim, tag in gmsh.model.getBoundary(ring, oriented=False)
               if _extent(gmsh, dim, tag) < 2.5 * g.inner_radius]
        _graded_towards(gmsh, rim, cfg.mesh.clamp_size, h, cfg.mesh.grading)


def _extent(gmsh, dim: int, tag: int) -> float:
    box = gmsh.model.getBoundingBox(dim, tag)
    return max(box[3] - box[0], box[4] - box[1], box[5] - box[2])


def graded_layers(extent: float, h: float, cfg: Config) -> tuple[list[int], list[float]]:
    """Layers of an extrusion over ``extent`` from the clamped end: uniform of about h, or,
    with mesh.clamp_size, clamp_size at the start growing by mesh.grading per unit length
    up to h (gmsh's numElements and cumulative heights)."""
    if cfg.mesh.clamp_size is None:
        return [count(extent, h)], []
    ends, x = [], 0.0
    while x < extent * (1 - 1e-9):
        x += min(h, cfg.mesh.clamp_size + cfg.mesh.grading * x)
        ends.append(x)
    if len(ends) > 1 and extent - ends[-2] < 0.5 * (ends[-1] - ends[-2]):
        ends.pop(-2)  # no sliver at the far end
    return [1] * len(ends), [min(e / extent, 1.0) for e in ends[:-1]] + [1.0]


def ring_quarter(cfg: Config, h: float) -> int:
    """Segments of each quarter of a wall's ring: about 2 pi R / (4 h), at least 2 (8 round)."""
    return max(2, int(math.ceil(count(2 * math.pi * dims(cfg).radius, h, minimum=8) / 4)))


def structured_ring(gmsh, r_in: float, r_out: float, quarter: int, n_wall: int,
                    plane: str) -> list[int]:
    """Four transfinite quarter-ring surfaces (geo kernel) in the plane 'yz' or 'xy',
    ``quarter`` segments each, ``n_wall`` through the wall."""
    geo = gmsh.model.geo

    def point(r: float, angle: float) -> int:
        a, b = r * math.cos(angle), r * math.sin(angle)
        return geo.addPoint(0.0, a, b) if plane == "yz" else geo.addPoint(a, b, 0.0)

    centre = geo.addPoint(0.0, 0.0, 0.0)
    angles = [k * math.pi / 2 for k in range(4)]
    p_in = [point(r_in, a) for a in angles]
    p_out = [point(r_out, a) for a in angles]
    radial = [geo.addLine(p_in[k], p_out[k]) for k in range(4)]
    arc_in = [geo.addCircleArc(p_in[k], centre, p_in[(k + 1) % 4]) for k in range(4)]
    arc_out = [geo.addCircleArc(p_out[k], centre, p_out[(k + 1) % 4]) for k in range(4)]
    surfaces = []
    for k in range(4):
        loop = geo.addCurveLoop([radial[k], arc_out[k], -radial[(k + 1) % 4], -arc_in[k]])
        surfaces.append(geo.addPlaneSurface([loop]))
    # The geo kernel's own settings: model-level ones (gmsh.model.mesh.setTransfinite*) are
    # reset by the synchronize after the extrusion, which left every tube and shell with
    # gmsh's default ring (8 segments round, 1 layer) whatever mesh.size and mesh.layers said.
    for c in radial:
        geo.mesh.setTransfiniteCurve(c, n_wall + 1)
    for c in arc_in + arc_out:
        geo.mesh.setTransfiniteCurve(c, quarter + 1)
    for s in surfaces:
        geo.mesh.setTransfiniteSurface(s, arrangement="Alternate")
    geo.synchronize()
    return surfaces


def _tube(gmsh, cfg: Config, h: float) -> None:
    g = dims(cfg)
    surfaces = structured_ring(gmsh, g.radius - g.thickness, g.radius, ring_quarter(cfg, h),
                               cfg.mesh.layers, plane="yz")
    numbers, heights = graded_layers(g.length, h, cfg)  # from X1 = 0, the clamp
    gmsh.model.geo.extrude([(2, s) for s in surfaces], g.length, 0, 0,
                           numElements=numbers, heights=heights)
    gmsh.model.geo.synchronize()


def _cylinder_shell(gmsh, cfg: Config, h: float) -> None:
    g = dims(cfg)
    surfaces = structured_ring(gmsh, g.radius - g.thickness, g.radius, ring_quarter(cfg, h),
                               cfg.mesh.layers, plane="xy")
    numbers, heights = graded_layers(g.height, h, cfg)  # from X3 = 0, the bottom rim
    gmsh.model.geo.extrude([(2, s) for s in surfaces], 0, 0, g.height,
                           numElements=numbers, heights=heights)
    gmsh.model.geo.synchronize()


def _section(gmsh, cfg: Config, h: float) -> None:
    """The section a 2D model of a box, annulus or cylinder shell keeps, in mesh coordinates
    (X1, X3) or (R, Z): a line across the thin direction (``layers`` elements) swept along the
    long one in steps of about h, graded from the clamped end as the 3D bodies are.

    * box: X1 in [0, L], X3 in [-t/2, t/2], swept along X1 from the clamp at X1 = 0;
    * annulus: R in [R1, R2], Z in [-t/2, t/2], swept along R from the inner rim;
    * cylinder_shell: R in [R - t, R], Z in [0, height], swept along Z from the bottom rim.
    """
    swept_section(gmsh, cfg, cfg.mesh.layers, lambda along: graded_layers(along, h, cfg))


def swept_section(gmsh, cfg: Config, layers: int,
                  sweep: Callable[[float], tuple[list[int], list[float]]],
                  recombine: bool = False) -> None:
    """A section (``_section``): ``layers`` elements across, ``sweep(length)`` gives gmsh's
    numElements and heights along; ``recombine``: quadrilaterals."""
    g, geo = dims(cfg), gmsh.model.geo
    if cfg.geometry.kind == "cylinder_shell":
        start, across, along = (g.radius - g.thickness, 0.0), (g.thickness, 0.0), g.height
        direction = (0.0, 1.0)
    else:
        r0 = 0.0 if cfg.geometry.kind == "box" else g.inner_radius
        length = g.length if cfg.geometry.kind == "box" else g.radius - g.inner_radius
        start, across, along = (r0, -g.thickness / 2), (0.0, g.thickness), length
        direction = (1.0, 0.0)
    a = geo.addPoint(start[0], start[1], 0.0)
    b = geo.addPoint(start[0] + across[0], start[1] + across[1], 0.0)
    line = geo.addLine(a, b)
    # the geo kernel's own setting: a model-level one is reset by the next synchronize
    geo.mesh.setTransfiniteCurve(line, layers + 1)
    numbers, heights = sweep(along)
    geo.extrude([(1, line)], direction[0] * along, direction[1] * along, 0.0,
                numElements=numbers, heights=heights, recombine=recombine)
    geo.synchronize()


def even_count(extent: float, h: float) -> int:
    """Divisions of a side: about extent/h, even so that the centre is a vertex."""
    return 2 * max(1, int(round(extent / h / 2)))


def _structured(gmsh, n: int) -> None:
    """Transfinite mesh of every entity, n divisions per edge.

    A square gets criss-cross triangles; a cube's faces get the diagonals of
    gmsh's split of each hexahedron into six tetrahedra ("Left"), the only
    arrangement whose face triangles are faces of the tetrahedra.
    """
    mesh = gmsh.model.mesh
    solid = bool(gmsh.model.getEntities(3))
    for _, tag in gmsh.model.getEntities(1):
        mesh.setTransfiniteCurve(tag, n + 1)
    for _, tag in gmsh.model.getEntities(2):
        mesh.setTransfiniteSurface(tag, arrangement="Left" if solid else "Alternate")
    for _, tag in gmsh.model.getEntities(3):
        mesh.setTransfiniteVolume(tag)


def _rectangle(gmsh, cfg: Config, h: float) -> None:
    s = dims(cfg).side
    gmsh.model.occ.addRectangle(-s / 2, -s / 2, 0.0, s, s)
    gmsh.model.occ.synchronize()
    _structured(gmsh, even_count(s, h))


def _cube(gmsh, cfg: Config, h: float) -> None:
    s = dims(cfg).side
    gmsh.model.occ.addBox(-s / 2, -s / 2, -s / 2, s, s, s)
    gmsh.model.occ.synchronize()
    _structured(gmsh, even_count(s, h))


def _boundary_name(kind: str, cfg: Config, lo: np.ndarray, hi: np.ndarray,
                   tol: float) -> str | None:
    """Name of the boundary entity with bounding box [lo, hi], from its position."""
    g = dims(cfg)
    flat = [i for i in range(3) if hi[i] - lo[i] < tol]
    if kind in ("box", "cube", "rectangle"):
        if kind == "box":
            body_lo = (0.0, -g.width / 2, -g.thickness / 2)
            body_hi = (g.length, g.width / 2, g.thickness / 2)
        else:
            body_lo, body_hi = (-g.side / 2,) * 3, (g.side / 2,) * 3
        for i in flat:
            if abs(lo[i] - body_lo[i]) < tol:
                return f"x{i + 1}_min"
            if abs(lo[i] - body_hi[i]) < tol:
                return f"x{i + 1}_max"
        return None
    axis = 0 if kind == "tube" else 2
    far = max(abs(lo[i]) for i in range(3) if i != axis)
    far = max(far, max(abs(hi[i]) for i in range(3) if i != axis))
    if kind == "tube":
        if axis in flat:
            return "x1_min" if abs(lo[0]) < tol else "x1_max"
        return "outer" if abs(far - g.radius) < tol else "inner"
    if kind == "cylinder_shell":
        if axis in flat:
            return "bottom_rim" if abs(lo[2]) < tol else "top_rim"
        return "outer" if abs(far - g.radius) < tol else "inner"
    if kind == "annulus":
        if axis in flat:
            return "x3_min" if lo[2] < 0 else "x3_max"
        return "outer_rim" if abs(far - g.radius) < tol else "inner_rim"
    return None


def physical_groups(gmsh, cfg: Config) -> None:
    kind, dim = cfg.geometry.kind, cfg.model.dim
    names = BOUNDARIES[kind]
    tol = 1e-6 * max(v for v in cfg.expression_params.values())
    groups: dict[str, list[int]] = {name: [] for name in names}
    for _, tag in gmsh.model.getEntities(dim - 1):
        upward, _ = gmsh.model.getAdjacencies(dim - 1, tag)
        if len(upward) != 1:
            continue  # an interface between two volumes of the same body
        box = np.array(gmsh.model.getBoundingBox(dim - 1, tag))
        lo, hi = box[:3], box[3:]
        if cfg.section.reduced:  # mesh coordinates (X1, X3) or (R, Z): the 3D box it spans
            lo, hi = _section_box(cfg, lo, hi)
        name = _boundary_name(kind, cfg, lo, hi, tol)
        if name is None:
            raise RuntimeError(f"cannot classify boundary entity {tag} of a {kind}")
        groups[name].append(tag)
    for i, name in enumerate(names):
        if not groups[name]:
            continue  # off the section (a box's x2_min, x2_max): checks.py keeps it unused
        gmsh.model.addPhysicalGroup(dim - 1, groups[name], i + 1)
        gmsh.model.setPhysicalName(dim - 1, i + 1, name)
    volumes = [tag for _, tag in gmsh.model.getEntities(dim)]
    gmsh.model.addPhysicalGroup(dim, volumes, 1)
    gmsh.model.setPhysicalName(dim, 1, "body")


def _section_box(cfg: Config, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 3D bounding box of a section's edge with bounding box [lo, hi] in mesh coordinates:
    X2 spans the box's width (it is not one of the edge's flat directions); a body of
    revolution's edge stands at theta = 0."""
    span = dims(cfg).width / 2 if cfg.geometry.kind == "box" else 0.0
    return (np.array([lo[0], -span, lo[1]]), np.array([hi[0], span, hi[1]]))
