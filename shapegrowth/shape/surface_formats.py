"""Triangulated surface files: STL (binary or ASCII), OBJ, PLY (binary or ASCII) and OFF
read by trimesh, gmsh .msh by gmsh, into one :class:`TriangleSurface`; binary STL written.

trimesh was measured against meshio and a reader of the project's own on a CAD export of
117 694 triangles (OCCT's head.stl): 0.04 s as given (0.22 s with trimesh's own merging),
meshio 0.35 s, the own reader 0.33 s.  Reading only: the repair is
:mod:`.surface_repair`'s, and whether a surface is closed or bounds a solid is decided by
:mod:`.surface_files`, which fills or samples it.  A file that cannot be read is a
:class:`ConfigError` naming ``target.surface``.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import ConfigError
from ..config.target_checks import SURFACE_FORMATS

KEY = "target.surface"


@dataclass(frozen=True)
class TriangleSurface:
    """Vertices (n, 3) and triangles (m, 3) of a surface."""

    points: np.ndarray
    triangles: np.ndarray

    def volume(self) -> float:
        """The enclosed volume (divergence theorem; the triangles consistently oriented,
        either way)."""
        p = self.points[self.triangles]
        return abs(float(np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum())) / 6


def fail(path: Path, what: str) -> ConfigError:
    """The one-line error for the surface file ``path``: ``what`` is wrong with it."""
    return ConfigError([f"{KEY}: '{path}' {what}"])


def read_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The points (n, 3) and triangles (m, 3) of a surface file as it gives them: STL, OBJ,
    PLY and OFF read by trimesh (polygons split into triangles), gmsh .msh by gmsh."""
    if not path.is_file():
        raise fail(path, "not found")
    suffix = path.suffix.lower()
    if suffix not in SURFACE_FORMATS:
        raise fail(path, f"has an unknown format; give one of {', '.join(SURFACE_FORMATS)}")
    if not path.read_bytes().strip():
        raise fail(path, "is empty")
    try:
        if suffix == ".msh":
            points, triangles = _read_msh_triangles(path)
        else:
            points, triangles = _read_mesh_library(path, suffix[1:])
    except Exception as exc:  # the readers raise what their formats' parsers raise
        what = " ".join(str(exc).split()) or type(exc).__name__
        raise fail(path, f"is not a valid {suffix[1:].upper()} file ({what})") from None
    if len(triangles) == 0:
        raise fail(path, f"is not a valid {suffix[1:].upper()} file (no triangles in it)")
    if not np.isfinite(points).all():
        raise fail(path, "has coordinates that are not finite")
    if triangles.min() < 0 or triangles.max() >= len(points):
        raise fail(path, "has triangles that name missing vertices")
    return points, triangles


def _read_mesh_library(path: Path, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """trimesh's reader, nothing merged or dropped (``process=False``); a file of several
    objects (an OBJ's groups, a PLY's parts) as one surface."""
    import trimesh

    mesh = trimesh.load_mesh(str(path), file_type=kind, process=False)
    if isinstance(mesh, trimesh.Scene):
        mesh = mesh.dump(concatenate=True)
    points = np.asarray(mesh.vertices, dtype=float).reshape(-1, 3)
    return points, np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)


def _read_msh_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    import gmsh

    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        try:
            gmsh.merge(str(path))
        except Exception as exc:  # gmsh raises a bare Exception on unreadable files
            raise ValueError(str(exc)) from None
        tags, coords, _ = gmsh.model.mesh.getNodes()
        _, node_tags = gmsh.model.mesh.getElementsByType(2)  # 3-node triangles
    finally:
        gmsh.finalize()
    index = np.zeros(int(tags.max(initial=0)) + 1, dtype=np.int64)
    index[tags.astype(np.int64)] = np.arange(len(tags))
    return coords.astype("=f8").reshape(-1, 3), index[node_tags.astype(np.int64)].reshape(-1, 3)


def write_stl(path: Path | str, points: np.ndarray, triangles: np.ndarray) -> None:
    """A binary STL of the triangles (outward normals where the surface is oriented so)."""
    path = Path(path)
    p = np.asarray(points, dtype=float)[np.asarray(triangles)]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
    record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
    rows = np.zeros(len(p), dtype=record)
    rows["normal"], rows["v"] = normal, p
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"shapegrowth".ljust(80, b" "))
        f.write(struct.pack("<I", len(p)))
        f.write(rows.tobytes())
