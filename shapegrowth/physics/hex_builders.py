"""The gmsh builders of ``mesh.cells: hex``: hexahedra in 3D, quadrilaterals in 2D, second
order (27 and 9 nodes: ``Mesh.SecondOrderIncomplete 0``), every one structured (transfinite,
recombined, swept), for every geometry kind and section.

Thin walls are what solid mechanics meshes with such elements: ``mesh.layers`` through the
thickness, about ``mesh.size`` in-plane, graded along the sweep from the clamp where
``mesh.clamp_size`` asks.  ``mesh.refine`` regenerates the mesh with every count doubled
(dolfinx refines only simplices): each interval of every count is halved, so every node of
the coarse mesh is a node of the fine one (nested), and a Lagrange field of the coarse mesh is
one of the fine mesh.  Counts that place the centre on a vertex (``clamp: rigid``) stay even.

* box: its X2-X3 section (``layers`` through X3, about width / h across X2) swept along X1
  from the clamp;
* tube, cylinder shell: the structured ring of ``builders.py`` (4 quarter rings,
  ``layers`` through the wall), swept along the axis from the clamp;
* annulus: its (R, Z) section (``layers`` through the thickness, graded along R from the
  inner rim) revolved about X3 in four quarter turns;
* rectangle (2D), cube: the structured square, the cube that square swept along X3;
* the 2D sections of ``model.reduction``: the line across the thickness swept along the
  long direction (as ``builders._section``), recombined into quadrilaterals.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from ..config import Config
from .builders import (
    count,
    dims,
    even_count,
    graded_layers,
    physical_groups,
    ring_quarter,
    structured_ring,
    swept_section,
)


def build_hex(cfg: Config, path: Path) -> None:
    """Build ``cfg``'s hexahedral (quadrilateral) mesh and write it to ``path`` (rank 0).

    gmsh places the mid-nodes of a second-order cell from the cell itself, while the next
    refinement's vertices inside a curved wall come from its transfinite map: the two do not
    coincide (by up to half the finer spacing across a thin tube's wall at h 1).  So each
    node is put where the linear mesh with every count doubled has its vertex: the cell's
    corners are vertices of both; an edge's mid-node is the finer vertex next to both ends of
    the edge, a face's centre the finer vertex next to two opposite edges' mid-nodes, the
    cell's centre the one next to two opposite faces' centres (gmsh's node order).  The nodes
    of refinement r are then the vertices of the linear mesh of counts 2^(r+1), and each
    refinement's nodes contain the last one's (nested)."""
    import gmsh

    split = 2 ** cfg.mesh.refine
    dim = cfg.model.dim
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        vertex_tags, vertices = _generate(gmsh, cfg, 2 * split, order=1)
        neighbours = _vertex_graph(gmsh, dim, vertex_tags)
        gmsh.clear()
        _generate(gmsh, cfg, split, order=2)
        placed = _place_nodes(gmsh, dim, vertices, neighbours)
        for tag, point in placed.items():
            gmsh.model.mesh.setNode(tag, list(point), [])
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


# gmsh's first-order cells' edges, and its second-order cells' node roles: each non-corner
# node of a 27-node hexahedron (9-node quadrilateral) by the two nodes it lies between
_LINEAR_EDGES = {
    3: [(0, 1), (1, 2), (2, 3), (3, 0), (4, 5), (5, 6), (6, 7), (7, 4), (0, 4), (1, 5),
        (2, 6), (3, 7)],
    2: [(0, 1), (1, 2), (2, 3), (3, 0)],
}
_BETWEEN = {
    3: [(8, 0, 1), (9, 0, 3), (10, 0, 4), (11, 1, 2), (12, 1, 5), (13, 2, 3), (14, 2, 6),
        (15, 3, 7), (16, 4, 5), (17, 4, 7), (18, 5, 6), (19, 6, 7),
        (20, 9, 11), (21, 8, 16), (22, 9, 17), (23, 11, 18), (24, 13, 19), (25, 16, 19),
        (26, 20, 25)],
    2: [(4, 0, 1), (5, 1, 2), (6, 2, 3), (7, 3, 0), (8, 4, 6)],
}


def _vertex_graph(gmsh, dim: int, tags: np.ndarray) -> list[set[int]]:
    """Each vertex's neighbours (indices into ``tags``) along the linear mesh's cell edges."""
    index = {int(t): i for i, t in enumerate(tags)}
    neighbours: list[set[int]] = [set() for _ in tags]
    for kind, _, nodes in zip(*gmsh.model.mesh.getElements(dim)):
        corners = gmsh.model.mesh.getElementProperties(kind)[3]
        cells = np.asarray(nodes).reshape(-1, corners)
        for a, b in _LINEAR_EDGES[dim]:
            for u, v in zip(cells[:, a], cells[:, b]):
                i, j = index[int(u)], index[int(v)]
                neighbours[i].add(j)
                neighbours[j].add(i)
    return neighbours


def _place_nodes(gmsh, dim: int, vertices: np.ndarray,
                 neighbours: list[set[int]]) -> dict[int, np.ndarray]:
    """Every node of the second-order mesh (tag -> position) at its finer linear vertex."""
    tags, coords, _ = gmsh.model.mesh.getNodes()
    coords = np.asarray(coords).reshape(-1, 3)
    scale = float(np.ptp(vertices, axis=0).max())
    distance, nearest = cKDTree(vertices).query(coords)
    at = {int(t): int(n) for t, n, d in zip(tags, nearest, distance) if d < 1e-9 * scale}
    for _, _, nodes in zip(*gmsh.model.mesh.getElements(dim)):
        cells = np.asarray(nodes).reshape(-1, 27 if dim == 3 else 9)
        for cell in cells:
            corners = [at.get(int(t)) for t in cell[:2 ** dim]]
            if any(c is None for c in corners):
                raise RuntimeError("hex mesh: a cell's corner is not a vertex of the finer mesh")
            found = {k: int(c) for k, c in enumerate(corners) if c is not None}
            for node, a, b in _BETWEEN[dim]:
                common = neighbours[found[a]] & neighbours[found[b]]
                if len(common) != 1:
                    raise RuntimeError("hex mesh: the finer mesh is not structured there")
                found[node] = common.pop()
                at[int(cell[node])] = found[node]
    return {tag: vertices[i] for tag, i in at.items()}


def _generate(gmsh, cfg: Config, split: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """The body's mesh with every count times ``split``, of ``order``: its node tags and
    coordinates (n, 3)."""
    gmsh.model.add(cfg.geometry.kind)
    h = cfg.mesh.size
    if cfg.section.reduced:
        _section(gmsh, cfg, h, split)
    else:
        builders = {"box": _box, "tube": _tube, "annulus": _annulus,
                    "cylinder_shell": _cylinder_shell, "rectangle": _rectangle, "cube": _cube}
        builders[cfg.geometry.kind](gmsh, cfg, h, split)
    physical_groups(gmsh, cfg)
    gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.ElementOrder", order)
    gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
    gmsh.model.mesh.generate(cfg.model.dim)
    tags, coords, _ = gmsh.model.mesh.getNodes()
    return np.asarray(tags), np.asarray(coords).reshape(-1, 3)


def _sweep(extent: float, h: float, cfg: Config, split: int) -> tuple[list[int], list[float]]:
    """gmsh's numElements and cumulative heights of a sweep over ``extent`` from the clamp:
    the simplex builders' layers (uniform, or graded from mesh.clamp_size), each interval
    split in ``split`` equal parts."""
    numbers, heights = graded_layers(extent, h, cfg)
    if not heights:
        return [numbers[0] * split], []
    ends, start = [], 0.0
    for end in heights:
        ends += [start + (end - start) * (k + 1) / split for k in range(split)]
        start = end
    ends[-1] = 1.0
    return [1] * len(ends), ends


def _box(gmsh, cfg: Config, h: float, split: int) -> None:
    g, geo = dims(cfg), gmsh.model.geo
    corners = [(-g.width / 2, -g.thickness / 2), (g.width / 2, -g.thickness / 2),
               (g.width / 2, g.thickness / 2), (-g.width / 2, g.thickness / 2)]
    points = [geo.addPoint(0.0, y, z) for y, z in corners]
    lines = [geo.addLine(points[k], points[(k + 1) % 4]) for k in range(4)]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    across, through = count(g.width, h) * split, cfg.mesh.layers * split
    for line, n in zip(lines, (across, through, across, through)):
        geo.mesh.setTransfiniteCurve(line, n + 1)
    geo.mesh.setTransfiniteSurface(surface)
    geo.mesh.setRecombine(2, surface)
    numbers, heights = _sweep(g.length, h, cfg, split)
    geo.extrude([(2, surface)], g.length, 0, 0, numElements=numbers, heights=heights,
                recombine=True)
    geo.synchronize()


def _walled(gmsh, cfg: Config, h: float, split: int, plane: str, axis_length: float) -> None:
    """The tube's or the shell's structured ring swept along its axis."""
    g, geo = dims(cfg), gmsh.model.geo
    surfaces = structured_ring(gmsh, g.radius - g.thickness, g.radius,
                               ring_quarter(cfg, h) * split, cfg.mesh.layers * split,
                               plane=plane)
    for s in surfaces:
        geo.mesh.setRecombine(2, s)
    numbers, heights = _sweep(axis_length, h, cfg, split)
    shift = (axis_length, 0, 0) if plane == "yz" else (0, 0, axis_length)
    geo.extrude([(2, s) for s in surfaces], *shift, numElements=numbers, heights=heights,
                recombine=True)
    geo.synchronize()


def _tube(gmsh, cfg: Config, h: float, split: int) -> None:
    _walled(gmsh, cfg, h, split, "yz", dims(cfg).length)


def _cylinder_shell(gmsh, cfg: Config, h: float, split: int) -> None:
    _walled(gmsh, cfg, h, split, "xy", dims(cfg).height)


def _annulus(gmsh, cfg: Config, h: float, split: int) -> None:
    g, geo = dims(cfg), gmsh.model.geo
    bottom = geo.addPoint(g.inner_radius, 0.0, -g.thickness / 2)
    top = geo.addPoint(g.inner_radius, 0.0, g.thickness / 2)
    rim = geo.addLine(bottom, top)
    geo.mesh.setTransfiniteCurve(rim, cfg.mesh.layers * split + 1)
    numbers, heights = _sweep(g.radius - g.inner_radius, h, cfg, split)
    swept = geo.extrude([(1, rim)], g.radius - g.inner_radius, 0, 0, numElements=numbers,
                        heights=heights, recombine=True)
    section = [(d, t) for d, t in swept if d == 2]
    quarter = ring_quarter(cfg, h) * split
    for _ in range(4):  # four quarter turns; the last closes onto the first section
        out = geo.revolve(section, 0, 0, 0, 0, 0, 1, math.pi / 2, numElements=[quarter],
                          recombine=True)
        section = [out[0]]
    geo.removeAllDuplicates()
    geo.synchronize()


def _square(gmsh, side: float, n: int, z: float = 0.0) -> int:
    geo = gmsh.model.geo
    corners = [(-side / 2, -side / 2), (side / 2, -side / 2), (side / 2, side / 2),
               (-side / 2, side / 2)]
    points = [geo.addPoint(x, y, z) for x, y in corners]
    lines = [geo.addLine(points[k], points[(k + 1) % 4]) for k in range(4)]
    surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
    for line in lines:
        geo.mesh.setTransfiniteCurve(line, n + 1)
    geo.mesh.setTransfiniteSurface(surface)
    geo.mesh.setRecombine(2, surface)
    return surface


def _rectangle(gmsh, cfg: Config, h: float, split: int) -> None:
    _square(gmsh, dims(cfg).side, even_count(dims(cfg).side, h) * split)
    gmsh.model.geo.synchronize()


def _cube(gmsh, cfg: Config, h: float, split: int) -> None:
    s = dims(cfg).side
    n = even_count(s, h) * split
    surface = _square(gmsh, s, n, z=-s / 2)
    gmsh.model.geo.extrude([(2, surface)], 0, 0, s, numElements=[n], recombine=True)
    gmsh.model.geo.synchronize()


def _section(gmsh, cfg: Config, h: float, split: int) -> None:
    """The 2D section of ``builders._section`` in quadrilaterals."""
    swept_section(gmsh, cfg, cfg.mesh.layers * split, lambda along: _sweep(along, h, cfg, split),
                  recombine=True)
