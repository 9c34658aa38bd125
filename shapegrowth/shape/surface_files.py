"""Triangulated surfaces from files (read by :mod:`.surface_formats`, repaired by
:mod:`.surface_repair`): filled into volumes or taken as surfaces.

A target given as a surface (``target.surface``) compared with the body's volume
(``objective.compare: volume``) is a solid: rho_H (2.9) compares the deformed body's volume
measure with the target's, so the closed surface is filled with tetrahedra by gmsh and
measured like a volume mesh.  An open surface is refused there: a surface cloud against a
volume cloud does not vanish when the shapes coincide, so the optimum would not be the
target.  Compared with a face of the body (``objective.compare: top``, ``boundary``, ...),
a surface, open or closed, is sampled with its area measure (:func:`surface_triangles`):
neither edges shared by more than two triangles nor triangles passing through each other
stop that, so both are taken as they are.

The filled polyhedron's volume, centroid and second moments are determined by the
surface alone (the divergence theorem), whatever tetrahedra gmsh chooses; the fill is
checked against that volume (a surface passing through itself fails that check).
"""

from __future__ import annotations

import functools
import logging
from pathlib import Path

import numpy as np
from mpi4py import MPI

from ..config import ConfigError
from ..config.expressions import COORDINATES, coordinate_env
from ..config.selectors import Condition
from .surface_formats import TriangleSurface, fail, read_triangles
from .surface_repair import Repair, edge_counts, repaired, turned_consistently

log = logging.getLogger(__name__)


@functools.lru_cache(maxsize=8)
def _repaired(path: str, mtime_ns: int, size: int, pieces: str,
              crop: str | None) -> tuple[TriangleSurface, Repair]:
    del mtime_ns, size  # the cache key: a changed file is read again
    points, triangles = read_triangles(Path(path))
    keep = None
    if crop is not None:
        centres = points[triangles].mean(axis=1)
        env = coordinate_env(centres.T)
        keep = np.broadcast_to(np.asarray(Condition(crop, COORDINATES)(env)) != 0,
                               (len(triangles),))
        if not keep.any():
            raise ConfigError([f"target.crop: '{crop}' keeps no triangle of '{path}' (its "
                               f"box: {np.round(points.min(axis=0), 6).tolist()} .. "
                               f"{np.round(points.max(axis=0), 6).tolist()})"])
    surface, repair = repaired(points, triangles, pieces=pieces, keep=keep)
    if MPI.COMM_WORLD.rank == 0:
        log.info("target.surface: '%s' %s", path, repair.line())
    return surface, repair


def loaded(path: Path, pieces: str = "largest",
           crop: str | None = None) -> tuple[TriangleSurface, Repair]:
    """A surface file read, cropped and repaired (:mod:`.surface_repair`), and what the
    repair did (said once per file in one line of the log); cached per file."""
    return _repaired(*_file_key(path), pieces, crop)


def _file_key(path: Path) -> tuple[str, int, int]:
    """A file's cache key: its resolved path, modification time and size."""
    if not path.is_file():
        raise fail(path, "not found")
    stat = path.stat()
    return str(path.resolve()), stat.st_mtime_ns, stat.st_size


def surface_triangles(path: Path, pieces: str = "largest",
                      crop: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The points and triangles of a surface, open or closed, repaired, to be sampled with
    its area measure (objective.compare: a face)."""
    surface = loaded(path, pieces, crop)[0]
    return surface.points, surface.triangles


def check_closed(surface: TriangleSurface, path: Path) -> None:
    """Every edge bounds exactly two triangles (a closed, manifold surface)."""
    counts = edge_counts(surface.triangles)
    open_edges, shared = int(np.sum(counts == 1)), int(np.sum(counts > 2))
    if open_edges:
        raise fail(path, f"is not closed: {open_edges} edges bound one triangle only; close "
                    "the surface (a solid's boundary), give a volume mesh as target.mesh, or "
                    "compare a face of the body with it (objective.compare: top, boundary, ...)")
    if shared:
        raise fail(path, f"is not a manifold: {shared} edges bound more than two triangles; "
                    "give one closed surface per solid")


def oriented(surface: TriangleSurface, path: Path) -> TriangleSurface:
    """The closed ``surface`` with its triangles turned consistently (neighbours cross
    their shared edge in opposite directions) and outward (positive enclosed volume):
    files often mix orientations, and the enclosed volume needs one."""
    t = turned_consistently(surface.triangles)[0]
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    if len(np.unique(directed, axis=0)) != len(directed):  # an edge crossed twice one way
        raise fail(path, "is not orientable (a Moebius-like surface bounds no solid)")
    p = surface.points[t]
    if np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() < 0:
        t = t[:, ::-1]
    return TriangleSurface(surface.points, np.ascontiguousarray(t))


@functools.lru_cache(maxsize=8)
def _filled(path: str, mtime_ns: int, size: int, pieces: str,
            crop: str | None) -> tuple[np.ndarray, np.ndarray]:
    surface = _repaired(path, mtime_ns, size, pieces, crop)[0]
    check_closed(surface, Path(path))
    return fill(oriented(surface, Path(path)), Path(path))


def filled_surface(path: Path, pieces: str = "largest",
                   crop: str | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, tetrahedra) of the solid a closed surface file bounds, repaired (cached per
    file)."""
    return _filled(*_file_key(path), pieces, crop)


def fill(surface: TriangleSurface, path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Tetrahedra filling the closed ``surface`` (gmsh's Delaunay, cell sizes from the
    surface's triangles), checked against the surface's own volume."""
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("target")
        tag = gmsh.model.addDiscreteEntity(2)
        gmsh.model.mesh.addNodes(2, tag, np.arange(1, len(surface.points) + 1),
                                 surface.points.ravel())
        gmsh.model.mesh.addElementsByType(tag, 2, [], (surface.triangles + 1).ravel())
        loop = gmsh.model.geo.addSurfaceLoop([tag])
        gmsh.model.geo.addVolume([loop])
        gmsh.model.geo.synchronize()
        try:
            gmsh.model.mesh.generate(3)
        except Exception as exc:  # self-intersecting or otherwise unfillable surfaces
            raise fail(path, f"could not be filled with tetrahedra by gmsh ({exc}); check that "
                        "it does not intersect itself") from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, node_tags = gmsh.model.mesh.getElementsByType(4)  # 4-node tetrahedra
    finally:
        gmsh.finalize()
    index = np.zeros(int(tags.max()) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    nodes = coords.astype("=f8").reshape(-1, 3)  # gmsh: a "<f8" dtype that MPI refuses
    tets = index[node_tags.astype(np.int64)].reshape(-1, 4)
    jac = np.stack([nodes[tets[:, k + 1]] - nodes[tets[:, 0]] for k in range(3)], axis=2)
    filled = float(np.abs(np.linalg.det(jac)).sum()) / 6 if len(tets) else 0.0
    enclosed = surface.volume()
    if not abs(filled - enclosed) <= 1e-8 * enclosed:
        raise fail(path, f"was filled with volume {filled:.6g} where the surface encloses "
                    f"{enclosed:.6g}; check that it does not intersect itself")
    return nodes, tets
