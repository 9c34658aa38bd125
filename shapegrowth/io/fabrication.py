"""``fabrication/``: the crisp design of a ``growth.levels`` run as a part can be made.

A material is one level per designed eigenvalue (one growth, or swelling, ratio each; with
one designed eigenvalue, one level).  Each cell of the reference body takes the material its
centre's filtered fields are sent to (the level nearest to each), as a density method
thresholds its filtered field, so that every material is a union of whole cells:

* ``material_K.stl``, one per material used: the surface of its region (the faces of its
  cells that no other cell of it shares, turned outwards; quadrilaterals split in two), in
  the config's units; a 2D model's region extruded (a plane section, through the box's
  width) or revolved (a body of revolution) into the 3D part it stands for
  (:class:`Sweep`).  Closed: every edge bounds an even number of its triangles (two, but
  where two pieces of the region touch along an edge).  Curved second-order cells are given
  by their corners.
* ``material.xdmf``: the material index K per cell on the reference mesh.
* ``fabrication.json``: :class:`Fabrication`.

The run's ``verified`` design is the nodal crisp one (each node sent to its nearest level,
interpolated between), which differs from the cell-wise one in the cells an interface
crosses; ``interface_fraction`` is their volume fraction.  The smallest feature of a region
is measured on its pieces (cells joined through shared faces): twice the largest distance of
a cell centre from the piece's surface, the smallest over the pieces of every material; the
filter length is what bounds it from below in the design (growth.filter_length).
"""

from __future__ import annotations

import dataclasses
import itertools
import logging
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import basix
import dolfinx
import numpy as np
import ufl

from .. import compat
from ..physics.projection import LevelProjection
from .files import write_json

log = logging.getLogger(__name__)

# a cell is grey where its last stage's projected value is farther than this share of the
# interval from the level it is sent to
GREY = 0.1
REVOLVE_SEGMENTS = 96  # a body of revolution's regions revolved in this many steps


@dataclass(frozen=True)
class Sweep:
    """How a 2D model's regions become the 3D parts its STL files give: ``extrude`` along
    the 3D axis ``across`` over [-extent / 2, extent / 2] (a plane section of a box, a plane
    body of some thickness), or ``revolve`` about the axis of a body of revolution (the
    section's second coordinate); ``axes`` the 3D axes of the mesh's two coordinates."""

    kind: str  # "extrude" or "revolve"
    axes: tuple[int, int]
    across: int
    extent: float = 0.0


@dataclass(frozen=True)
class Material:
    """One material of the crisp design."""

    index: int
    growth: tuple[float, ...]  # the level of each designed eigenvalue
    volume: float  # of its cells (a 2D model's: swept), in the config's units cubed
    volume_fraction: float
    pieces: int  # its region's connected pieces (cells joined through faces)
    smallest_feature: float  # of its thinnest piece (the module's text)
    stl: str | None  # its surface, in fabrication/ (3D bodies)


@dataclass(frozen=True)
class Fabrication:
    """fabrication/fabrication.json."""

    levels: tuple[tuple[float, ...], ...]  # of each designed eigenvalue
    designed: tuple[str, ...]  # the designed eigenvalues, in the order of Material.growth
    materials: tuple[Material, ...]
    smallest_feature: float  # over every material's pieces
    filter_length: float  # growth.filter_length: the design's smallest feature
    interface_fraction: float  # volume of the cells the nodal crisp design varies in
    grey_fraction: float | None  # the last stage's design away from the levels (GREY)
    sharpness: float | None  # the last stage's sharpness, which grey_fraction is taken at
    verified: float | None  # the crisp design's verified error (the run's headline)
    verified_status: str

    @property
    def volume_fractions(self) -> dict[str, float]:
        return {f"material_{m.index}": m.volume_fraction for m in self.materials}

    def to_json(self) -> dict[str, Any]:
        out = dataclasses.asdict(self)
        out["volume_fractions"] = self.volume_fractions
        if len(set(self.levels)) == 1:  # one list for all, as growth.levels gave it
            out["levels"] = list(self.levels[0])
        return out


def cell_values(field: dolfinx.fem.Function) -> np.ndarray:
    """``field`` at the centre of each of this rank's owned cells."""
    mesh = field.function_space.mesh
    centre = dolfinx.fem.Function(compat.scalar_space(mesh, 0, "DG"))
    centre.interpolate(field)
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    return centre.x.array[:owned].copy()


def cell_volumes(mesh, sweep: Sweep | None = None, quadrature_degree: int = 4) -> np.ndarray:
    """The volume of each of this rank's owned cells, curved ones included; a 2D model's
    cell, the volume it sweeps (area times the extent, or 2 pi R dA), else its area."""
    space = compat.scalar_space(mesh, 0, "DG")
    v = ufl.TestFunction(space)
    scale: Any = 1.0
    if sweep is not None:
        scale = 2 * math.pi * ufl.SpatialCoordinate(mesh)[0] if sweep.kind == "revolve" \
            else sweep.extent
    form = dolfinx.fem.form(scale * v * ufl.dx(domain=mesh, metadata={
        "quadrature_degree": quadrature_degree}))
    vector = dolfinx.fem.assemble_vector(form)
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    return np.asarray(vector.array[:owned]).copy()


def write_fabrication(out: Path, projections: list[LevelProjection],
                      crisp: list[dolfinx.fem.Function], filtered: list[dolfinx.fem.Function],
                      designed: list[str], filter_length: float, sharpness: float | None,
                      verified: float | None, verified_status: str,
                      sweep: Sweep | None = None) -> Fabrication:
    """fabrication/ in ``out`` (collective): ``projections`` onto each designed eigenvalue's
    levels, ``crisp`` the nodal crisp fields the run was verified with, ``filtered`` the same
    fields before the projection, ``designed`` their names; ``sharpness`` the last stage's
    (for the grey fraction); ``sweep`` a 2D model's way into 3D (None: a 2D model writes no
    STL)."""
    mesh = crisp[0].function_space.mesh
    comm = mesh.comm
    tdim = mesh.topology.dim
    folder = out / "fabrication"
    at_centre = [cell_values(f) for f in filtered]
    own = np.column_stack([p.index(x) for p, x in zip(projections, at_centre)])
    growth = np.column_stack([np.asarray(p.levels)[own[:, k]]  # (cells, fields)
                              for k, p in enumerate(projections)])
    # the nodal crisp design varies in a cell where its centre value is not a level
    crisp_centre = np.column_stack([cell_values(f) for f in crisp])
    spread = max(p.levels[-1] - p.levels[0] for p in projections)
    varies = np.any(np.abs(crisp_centre - growth) > 1e-9 * spread, axis=1)
    grey = np.zeros(len(own), dtype=bool)
    if sharpness is not None and math.isfinite(sharpness):
        for k, (p, x) in enumerate(zip(projections, at_centre)):
            levels = np.asarray(p.levels)  # the interval x lies in: its level and a neighbour
            low = np.clip(np.searchsorted(levels, x, side="right") - 1, 0, len(levels) - 2)
            moved = np.abs(p.value(x, sharpness) - growth[:, k])
            grey |= moved > GREY * (levels[low + 1] - levels[low])
    volumes = cell_volumes(mesh, sweep)
    nodes = compat.geometry_nodes(mesh)[:len(volumes)]
    n_corners = len(basix.topology(_cell_type(mesh))[0])
    corners = mesh.geometry.x[nodes[:, :n_corners]]  # (cells, corners, 3)
    gathered = comm.gather((growth, volumes, corners, varies, grey), root=0)
    result = None
    if comm.rank == 0:
        assert gathered is not None
        every, volumes, corners, varies, grey = (np.concatenate(parts) for parts in
                                                 zip(*gathered))
        result = _fabrication(folder, _cell_type(mesh), tdim,
                              tuple(p.levels for p in projections), designed, every,
                              volumes, corners, varies, grey, filter_length, sharpness,
                              verified, verified_status, sweep)
    result = comm.bcast(result, root=0)
    write_json(folder / "fabrication.json", result.to_json(), comm)
    _write_material_field(folder / "material.xdmf", mesh, result, growth)
    log.info("fabrication: %d material(s) (%s) in %s; smallest feature %.3g (filter length "
             "%.3g), interface cells %.1f %% of the volume", len(result.materials),
             ", ".join(f"{100 * m.volume_fraction:.1f} %" for m in result.materials), folder,
             result.smallest_feature, filter_length, 100 * result.interface_fraction)
    return result


def _cell_type(mesh) -> basix.CellType:
    name = mesh.topology.cell_type.name
    return getattr(basix.CellType, name)


def _material_ids(growth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The materials used (rows of levels, one per designed eigenvalue, sorted) and each
    cell's."""
    used, ids = np.unique(growth, axis=0, return_inverse=True)
    return used, ids.reshape(-1)


def _fabrication(folder: Path, cell: basix.CellType, tdim: int,
                 levels: tuple[tuple[float, ...], ...], designed: list[str],
                 growth: np.ndarray, volumes: np.ndarray,
                 corners: np.ndarray, varies: np.ndarray, grey: np.ndarray,
                 filter_length: float, sharpness: float | None, verified: float | None,
                 verified_status: str, sweep: Sweep | None) -> Fabrication:
    """The materials and their surfaces, on rank 0 from every rank's cells."""
    used, ids = _material_ids(growth)
    # the corners merged where their coordinates are equal (a node a rank shares is the
    # same number on each)
    points, vertex = np.unique(corners.reshape(-1, corners.shape[-1]), axis=0,
                               return_inverse=True)
    cells = vertex.reshape(len(corners), -1)
    facets = [list(f) for f in basix.topology(cell)[tdim - 1]]
    total = float(volumes.sum())
    materials = []
    for k in range(len(used)):
        mine = np.flatnonzero(ids == k)
        surface, owner, pairs = _surface(cells[mine], facets, cell)
        pieces, feature = _pieces(len(mine), pairs, points, cells[mine], surface, owner)
        stl = None
        if tdim == 3:
            stl = f"material_{k}.stl"
            _write_stl(folder / stl, points, _outward(
                points, surface, points[cells[mine][owner]].mean(axis=1)))
        elif sweep is not None:
            stl = f"material_{k}.stl"
            _write_stl(folder / stl, *_swept(sweep, points, cells[mine], surface, owner,
                                             cell))
        materials.append(Material(k, tuple(float(g) for g in used[k]),
                                  float(volumes[mine].sum()),
                                  float(volumes[mine].sum() / total), pieces, feature, stl))
    return Fabrication(
        levels, tuple(designed), tuple(materials),
        min(m.smallest_feature for m in materials), filter_length,
        float(volumes[varies].sum() / total),
        float(volumes[grey].sum() / total) if sharpness is not None else None,
        sharpness, verified, verified_status)


def _cyclic(facet: list[int], cell: basix.CellType) -> list[int]:
    """A facet's vertices in order round it (basix numbers a quadrilateral's as a tensor)."""
    if len(facet) == 4 and cell in (basix.CellType.hexahedron,):
        return [facet[0], facet[1], facet[3], facet[2]]
    return facet


def _surface(cells: np.ndarray, facets: list[list[int]], cell: basix.CellType
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The region's boundary as triangles (or segments in 2D) turned outwards, the cell
    each came from, and the pairs of cells that share a face."""
    local = [_cyclic(f, cell) for f in facets]
    faces = np.concatenate([cells[:, f] for f in local])  # (cells * facets, vertices)
    n = len(cells)
    owner = np.tile(np.arange(n), len(local))
    key = np.sort(faces, axis=1)
    _, first, inverse, count = np.unique(key, axis=0, return_index=True,
                                         return_inverse=True, return_counts=True)
    inverse = inverse.reshape(-1)
    once = count[inverse] == 1
    shared = np.flatnonzero(~once)
    order = shared[np.argsort(inverse[shared], kind="stable")]
    pairs = owner[order].reshape(-1, 2) if len(order) % 2 == 0 else np.zeros((0, 2), int)
    boundary, owners = faces[once], owner[once]
    if boundary.shape[1] == 4:  # quadrilaterals in two triangles
        boundary = np.concatenate([boundary[:, [0, 1, 2]], boundary[:, [0, 2, 3]]])
        owners = np.concatenate([owners, owners])
    return boundary, owners, pairs


def _outward(points: np.ndarray, triangles: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Each triangle turned so that its normal points away from its cell's centre."""
    p = points[triangles]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    inward = np.einsum("ij,ij->i", normal, p.mean(axis=1) - centres)
    return np.where((inward < 0)[:, None], triangles[:, ::-1], triangles)


def _pieces(n: int, pairs: np.ndarray, points: np.ndarray, cells: np.ndarray,
            surface: np.ndarray, owner: np.ndarray) -> tuple[int, float]:
    """The region's pieces and the smallest one's feature size (the module's text)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    count, piece = connected_components(graph, directed=False)
    centres = points[cells].mean(axis=1)
    samples, sample_piece = _samples(points, surface)
    sample_piece = piece[owner[sample_piece]]
    smallest = math.inf
    for k in range(count):
        tree = cKDTree(samples[sample_piece == k])
        depth = tree.query(centres[piece == k])[0].max()
        smallest = min(smallest, 2.0 * float(depth))
    return count, smallest


def _samples(points: np.ndarray, surface: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points spread over each boundary facet (its corners and a barycentric lattice of
    step 1/4), and the facet each lies on."""
    m = surface.shape[1]
    if m == 2:  # 2D: segments
        weights = np.linspace(0.0, 1.0, 9)[:, None] * np.array([1.0, -1.0]) + [0.0, 1.0]
    else:
        weights = np.array([(i / 4, j / 4, 1 - (i + j) / 4) for i, j in
                            itertools.product(range(5), range(5)) if i + j <= 4])
    p = points[surface]  # (facets, m, dim)
    samples = np.einsum("sk,fkd->fsd", weights, p)
    facet = np.repeat(np.arange(len(surface)), len(weights))
    return samples.reshape(-1, p.shape[-1]), facet


def _swept(sweep: Sweep, points: np.ndarray, cells: np.ndarray, segments: np.ndarray,
           owner: np.ndarray, cell: basix.CellType) -> tuple[np.ndarray, np.ndarray]:
    """A 2D region (its ``cells`` and boundary ``segments``) as the closed surface of the 3D
    part it stands for (:class:`Sweep`), turned outwards: its points and triangles."""
    plane = points[:, :2]
    if cell == basix.CellType.quadrilateral:  # tensor numbering: round the cell, in two
        caps = np.concatenate([cells[:, [0, 1, 3]], cells[:, [0, 3, 2]]])
        cap_owner = np.tile(np.arange(len(cells)), 2)
    else:
        caps, cap_owner = cells, np.arange(len(cells))
    n = len(plane)
    if sweep.kind == "extrude":
        layers = np.array([-0.5, 0.5]) * sweep.extent
        rings = [_embed(sweep, plane, y) for y in layers]
        out = np.concatenate(rings)
        walls = [np.column_stack([segments[:, 0], segments[:, 1], n + segments[:, 1]]),
                 np.column_stack([segments[:, 0], n + segments[:, 1], n + segments[:, 0]])]
        triangles = np.concatenate([caps, n + caps, *walls])
        owners = np.concatenate([cap_owner, cap_owner, owner, owner])
        centres = _embed(sweep, points[cells].mean(axis=1)[:, :2], 0.0)[owners]
    else:  # revolve in REVOLVE_SEGMENTS steps; a segment on the axis sweeps nothing
        steps = REVOLVE_SEGMENTS
        angle = 2 * np.pi * np.arange(steps) / steps
        out = np.concatenate([_embed(sweep, plane, 0.0, a) for a in angle])
        k = np.arange(steps)[:, None]
        a0, b0 = k * n + segments[:, 0], k * n + segments[:, 1]
        a1, b1 = (k + 1) % steps * n + segments[:, 0], (k + 1) % steps * n + segments[:, 1]
        triangles = np.concatenate([np.stack([a0, b0, b1], -1).reshape(-1, 3),
                                    np.stack([a0, b1, a1], -1).reshape(-1, 3)])
        owners = np.tile(np.tile(owner, steps), 2)
        middle = np.tile(np.repeat(angle + np.pi / steps, len(segments)), 2)
        plane_centres = points[cells].mean(axis=1)[:, :2][owners]
        centres = np.zeros((len(owners), 3))
        centres[:, sweep.axes[0]] = plane_centres[:, 0] * np.cos(middle)
        centres[:, sweep.across] = plane_centres[:, 0] * np.sin(middle)
        centres[:, sweep.axes[1]] = plane_centres[:, 1]
        p = out[triangles]
        area = np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)
        keep = area > 1e-14 * max(float(np.max(area, initial=0.0)), 1e-300)
        triangles, centres = triangles[keep], centres[keep]
    return out, _outward(out, triangles, centres)


def _embed(sweep: Sweep, plane: np.ndarray, across: float, angle: float = 0.0) -> np.ndarray:
    """3D points of the mesh's (n, 2) points, ``across`` off their plane (extrude) or turned
    by ``angle`` about the axis (revolve: the first coordinate the radius)."""
    out = np.zeros((len(plane), 3))
    if sweep.kind == "extrude":
        out[:, sweep.axes[0]], out[:, sweep.axes[1]] = plane[:, 0], plane[:, 1]
        out[:, sweep.across] = across
    else:
        out[:, sweep.axes[0]] = plane[:, 0] * np.cos(angle)
        out[:, sweep.across] = plane[:, 0] * np.sin(angle)
        out[:, sweep.axes[1]] = plane[:, 1]
    return out


def _write_stl(path: Path, points: np.ndarray, triangles: np.ndarray) -> None:
    from ..shape.surface_formats import write_stl

    p3 = np.zeros((len(points), 3))
    p3[:, :points.shape[1]] = points
    write_stl(path, p3, triangles)


def _write_material_field(path: Path, mesh, result: Fabrication, growth: np.ndarray) -> None:
    """material.xdmf: the material index per cell, ``growth`` (owned cells, fields) each
    cell's levels (collective)."""
    index = {m.growth: m.index for m in result.materials}
    field = dolfinx.fem.Function(compat.scalar_space(mesh, 0, "DG"), name="material")
    field.x.array[:len(growth)] = [index[tuple(float(g) for g in row)] for row in growth]
    field.x.scatter_forward()
    try:
        compat.write_xdmf(path, mesh, [field])
    except RuntimeError as err:  # dolfinx 0.5.2's pull-back on badly distorted curved cells
        log.warning("%s: not written (%s); the STL files and fabrication.json are", path, err)
