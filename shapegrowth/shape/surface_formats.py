"""Triangulated surface files: STL (binary or ASCII), OBJ, PLY (binary or ASCII) and gmsh
.msh read into one :class:`TriangleSurface`, duplicate vertices merged; binary STL written.

Reading only: whether a surface is closed, crosses itself, or bounds a solid is decided
by :mod:`.surface_files`, which fills or samples it.  A file that cannot be read is a
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


def read_surface(path: Path) -> TriangleSurface:
    """The triangles of a surface file, duplicate vertices merged (STL repeats them)."""
    if not path.is_file():
        raise fail(path, "not found")
    suffix = path.suffix.lower()
    if suffix not in SURFACE_FORMATS:
        raise fail(path, f"has an unknown format; give one of {', '.join(SURFACE_FORMATS)}")
    data = path.read_bytes()
    if not data.strip():
        raise fail(path, "is empty")
    try:
        if suffix == ".stl":
            points, triangles = _read_stl(data)
        elif suffix == ".obj":
            points, triangles = _read_obj(data.decode("utf-8", "replace"))
        elif suffix == ".ply":
            points, triangles = _read_ply(data)
        else:
            points, triangles = _read_msh_triangles(path)
    except (ValueError, IndexError, struct.error, UnicodeDecodeError) as exc:
        raise fail(path, f"is not a valid {suffix[1:].upper()} file ({exc})") from None
    if len(triangles) == 0:
        raise fail(path, "holds no triangles")
    if not np.isfinite(points).all():
        raise fail(path, "has coordinates that are not finite")
    if triangles.min() < 0 or triangles.max() >= len(points):
        raise fail(path, "has triangles that name missing vertices")
    return _merged(points, triangles)


def _merged(points: np.ndarray, triangles: np.ndarray) -> TriangleSurface:
    unique, inverse = np.unique(points, axis=0, return_inverse=True)
    triangles = inverse.reshape(-1)[triangles]
    keep = ((triangles[:, 0] != triangles[:, 1]) & (triangles[:, 1] != triangles[:, 2])
            & (triangles[:, 0] != triangles[:, 2]))  # triangles collapsed by the merge
    return TriangleSurface(unique.astype(float), triangles[keep].astype(np.int64))


def _read_stl(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    if len(data) >= 84:
        (count,) = struct.unpack("<I", data[80:84])
        if len(data) == 84 + 50 * count:  # binary: header, count, 50 bytes per triangle
            record = np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")])
            v = np.frombuffer(data, dtype=record, count=count, offset=84)["v"]
            return v.reshape(-1, 3).astype(float), np.arange(3 * count).reshape(-1, 3)
    text = data.decode("ascii")
    if not text.lstrip().startswith("solid"):
        raise ValueError("neither binary STL nor ASCII STL ('solid ...')")
    vertices = [line.split()[1:4] for line in text.splitlines()
                if line.strip().startswith("vertex")]
    if len(vertices) % 3:
        raise ValueError("a facet without three vertices")
    points = np.array(vertices, dtype=float).reshape(-1, 3)
    return points, np.arange(len(points)).reshape(-1, 3)


def _read_obj(text: str) -> tuple[np.ndarray, np.ndarray]:
    points: list[list[float]] = []
    triangles: list[list[int]] = []
    for line in text.splitlines():
        fields = line.split()
        if not fields:
            continue
        if fields[0] == "v":
            points.append([float(c) for c in fields[1:4]])
        elif fields[0] == "f":
            ids = [int(f.split("/")[0]) for f in fields[1:]]
            ids = [i - 1 if i > 0 else len(points) + i for i in ids]  # 1-based or relative
            triangles.extend([ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1))
    if not points and not triangles:
        raise ValueError("no 'v' or 'f' lines")
    return np.array(points, dtype=float).reshape(-1, 3), np.array(triangles,
                                                                   dtype=np.int64).reshape(-1, 3)


_PLY_TYPES = {"char": "i1", "uchar": "u1", "short": "i2", "ushort": "u2", "int": "i4",
              "uint": "u4", "float": "f4", "double": "f8", "int8": "i1", "uint8": "u1",
              "int16": "i2", "uint16": "u2", "int32": "i4", "uint32": "u4", "float32": "f4",
              "float64": "f8"}


def _read_ply(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        raise ValueError("no 'ply' header")
    header = data[:end].decode("ascii").splitlines()
    body = data[data.index(b"\n", end) + 1:]
    fmt = next(line.split()[1] for line in header if line.startswith("format"))
    elements: list[tuple[str, int, list[list[str]]]] = []
    for line in header:
        words = line.split()
        if words[:1] == ["element"]:
            elements.append((words[1], int(words[2]), []))
        elif words[:1] == ["property"] and elements:
            elements[-1][2].append(words[1:])
    if fmt == "ascii":
        return _read_ply_ascii(body.decode("ascii").split(), elements)
    order = "<" if fmt == "binary_little_endian" else ">"
    offset = 0
    points = triangles = None
    for name, count, props in elements:
        if name == "face":
            lst = props[0]
            if lst[0] != "list":
                raise ValueError("faces without a vertex list")
            n_type, i_type = order + _PLY_TYPES[lst[1]], order + _PLY_TYPES[lst[2]]
            faces: list[list[int]] = []
            for _ in range(count):
                (n,) = np.frombuffer(body, n_type, 1, offset)
                offset += np.dtype(n_type).itemsize
                ids = [int(i) for i in np.frombuffer(body, i_type, int(n), offset)]
                offset += int(n) * np.dtype(i_type).itemsize
                faces.extend([ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1))
            triangles = np.array(faces, dtype=np.int64).reshape(-1, 3)
        else:
            if any(p[0] == "list" for p in props):
                raise ValueError(f"element '{name}' with a list property")
            dtype = np.dtype([(p[1], order + _PLY_TYPES[p[0]]) for p in props])
            rows = np.frombuffer(body, dtype, count, offset)
            offset += count * dtype.itemsize
            if name == "vertex":
                points = np.column_stack([rows[c].astype(float) for c in ("x", "y", "z")])
    if points is None or triangles is None:
        raise ValueError("no vertex or face element")
    return points, triangles


def _read_ply_ascii(words: list[str], elements) -> tuple[np.ndarray, np.ndarray]:
    position = 0
    points = triangles = None
    for name, count, props in elements:
        if name == "face":
            faces: list[list[int]] = []
            for _ in range(count):
                n = int(words[position])
                ids = [int(w) for w in words[position + 1:position + 1 + n]]
                position += 1 + n
                faces.extend([ids[0], ids[k], ids[k + 1]] for k in range(1, len(ids) - 1))
            triangles = np.array(faces, dtype=np.int64).reshape(-1, 3)
        else:
            names = [p[-1] for p in props]
            rows = np.array(words[position:position + count * len(props)], dtype=float)
            position += count * len(props)
            if name == "vertex":
                rows = rows.reshape(count, len(props))
                points = rows[:, [names.index(c) for c in ("x", "y", "z")]]
    if points is None or triangles is None:
        raise ValueError("no vertex or face element")
    return points, triangles


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
