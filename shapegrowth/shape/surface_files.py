"""Triangulated surfaces from files (STL, OBJ, PLY, gmsh .msh): filled into volumes, or
taken as surfaces.

A target given as a surface (``target.surface``) compared with the body's volume
(``objective.compare: volume``) is a solid: rho_H (2.9) compares the deformed body's volume
measure with the target's, so the closed surface is filled with tetrahedra by gmsh and
measured like a volume mesh.  An open surface is refused there: a surface cloud against a
volume cloud does not vanish when the shapes coincide, so the optimum would not be the
target.  Compared with a face of the body (``objective.compare: top``, ``boundary``, ...),
a surface, open or closed, is sampled with its area measure (:func:`surface_triangles`).

The filled polyhedron's volume, centroid and second moments are determined by the
surface alone (the divergence theorem), whatever tetrahedra gmsh chooses; the fill is
checked against that volume.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config import ConfigError

SURFACE_FORMATS = (".stl", ".obj", ".ply", ".msh")
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


def _fail(path: Path, what: str) -> ConfigError:
    return ConfigError([f"{KEY}: '{path}' {what}"])


# ---- readers ---------------------------------------------------------------------------------

def read_surface(path: Path) -> TriangleSurface:
    """The triangles of a surface file, duplicate vertices merged (STL repeats them)."""
    if not path.is_file():
        raise _fail(path, "not found")
    suffix = path.suffix.lower()
    if suffix not in SURFACE_FORMATS:
        raise _fail(path, f"has an unknown format; give one of {', '.join(SURFACE_FORMATS)}")
    data = path.read_bytes()
    if not data.strip():
        raise _fail(path, "is empty")
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
        raise _fail(path, f"is not a valid {suffix[1:].upper()} file ({exc})") from None
    if len(triangles) == 0:
        raise _fail(path, "holds no triangles")
    if not np.isfinite(points).all():
        raise _fail(path, "has coordinates that are not finite")
    if triangles.min() < 0 or triangles.max() >= len(points):
        raise _fail(path, "has triangles that name missing vertices")
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


# ---- closed surfaces and their fill ----------------------------------------------------------

def _edge_counts(triangles: np.ndarray) -> np.ndarray:
    """How many triangles each edge bounds (one entry per distinct edge)."""
    t = triangles
    edges = np.sort(np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    return np.unique(edges, axis=0, return_counts=True)[1]


def surface_triangles(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """The points and triangles of a surface, open or closed, to be sampled with its area
    measure (objective.compare: a face): refused where a triangle has no area or where the
    surface overlaps itself (a triangle twice, an edge of more than two triangles, or two
    triangles passing through each other)."""
    surface = read_surface(path)
    p, t = surface.points, surface.triangles
    areas = np.linalg.norm(np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]), axis=1)
    flat = int(np.sum(areas <= 1e-12 * np.max(areas))) if areas.size else 0
    if flat:
        raise _fail(path, f"has {flat} triangles without area; remove them (a degenerate "
                    "triangle has no normal)")
    if len(np.unique(np.sort(t, axis=1), axis=0)) < len(t):
        raise _fail(path, "overlaps itself: a triangle is given twice; give each once")
    counts = _edge_counts(t)
    if np.any(counts > 2):
        raise _fail(path, f"overlaps itself: {int(np.sum(counts > 2))} edges bound more than "
                    "two triangles; give one surface")
    crossing = crossing_pairs(p, t)
    if len(crossing):
        a, b = crossing[0]
        raise _fail(path, f"overlaps itself: {len(crossing)} pairs of triangles cross (the "
                    f"first: triangles {a} and {b}); give a surface that does not pass "
                    "through itself")
    return p, t


def crossing_pairs(points: np.ndarray, triangles: np.ndarray) -> np.ndarray:
    """The pairs of triangles (m, 2) that pass through each other: an edge of one crossing
    the other's interior (Moller-Trumbore, strictly inside both), among the pairs whose
    bounding spheres meet, which share no vertex (neighbours touch, they do not cross), and
    neither of which lies strictly on one side of the other's plane.
    Two flat triangles overlapping in one plane, and a crossing exactly through an edge or a
    vertex, are not seen (a triangle given twice is)."""
    from scipy.spatial import cKDTree

    corners = points[triangles]  # (n, 3, 3)
    centres = corners.mean(axis=1)
    radius = np.linalg.norm(corners - centres[:, None], axis=2).max(axis=1)
    pairs = cKDTree(centres).query_pairs(2 * float(np.max(radius, initial=0.0)),
                                         output_type="ndarray")
    if len(pairs) == 0:
        return np.zeros((0, 2), dtype=np.int64)
    i, j = pairs[:, 0], pairs[:, 1]
    near = np.linalg.norm(centres[i] - centres[j], axis=1) <= radius[i] + radius[j]
    shared = (triangles[i][:, :, None] == triangles[j][:, None, :]).any(axis=(1, 2))
    i, j = i[near & ~shared], j[near & ~shared]
    # A pair with one triangle strictly on one side of the other's plane cannot cross: on a
    # smooth surface that is nearly every pair, at a sixth of the six edge tests' cost (the
    # open cap of 51 200 slivers in tests/test_surface_distance.py: 16.8 s -> 3.8 s)
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    apart = _one_side(normals, corners, i, j) | _one_side(normals, corners, j, i)
    i, j = i[~apart], j[~apart]
    hit = np.zeros(len(i), dtype=bool)
    for first, second in ((i, j), (j, i)):
        for e in range(3):
            start, end = corners[first, e], corners[first, (e + 1) % 3]
            hit |= _segment_crosses(start, end, corners[second])
    return np.column_stack([i[hit], j[hit]])


def _one_side(normals: np.ndarray, corners: np.ndarray, i: np.ndarray,
              j: np.ndarray) -> np.ndarray:
    """Whether each triangle j lies strictly on one side of its triangle i's plane."""
    side = np.einsum("ij,ikj->ik", normals[i], corners[j] - corners[i, 0][:, None])
    return np.all(side > 0, axis=1) | np.all(side < 0, axis=1)


def _segment_crosses(start: np.ndarray, end: np.ndarray, tri: np.ndarray,
                     eps: float = 1e-9) -> np.ndarray:
    """Whether each segment start-end passes through the interior of its triangle."""
    direction = end - start
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    h = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, h)
    ok = np.abs(det) > eps * np.linalg.norm(direction, axis=1) * np.linalg.norm(e1, axis=1) \
        * np.linalg.norm(e2, axis=1)  # not parallel to the plane
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = start - tri[:, 0]
    u = inv * np.einsum("ij,ij->i", s, h)
    q = np.cross(s, e1)
    v = inv * np.einsum("ij,ij->i", direction, q)
    t = inv * np.einsum("ij,ij->i", e2, q)
    return ok & (u > eps) & (v > eps) & (u + v < 1 - eps) & (t > eps) & (t < 1 - eps)


def check_closed(surface: TriangleSurface, path: Path) -> None:
    """Every edge bounds exactly two triangles (a closed, manifold surface)."""
    counts = _edge_counts(surface.triangles)
    open_edges, shared = int(np.sum(counts == 1)), int(np.sum(counts > 2))
    if open_edges:
        raise _fail(path, f"is not closed: {open_edges} edges bound one triangle only; close "
                    "the surface (a solid's boundary), give a volume mesh as target.mesh, or "
                    "compare a face of the body with it (objective.compare: top, boundary, ...)")
    if shared:
        raise _fail(path, f"is not a manifold: {shared} edges bound more than two triangles; "
                    "give one closed surface per solid")


def oriented(surface: TriangleSurface, path: Path) -> TriangleSurface:
    """The closed ``surface`` with its triangles turned consistently (neighbours cross
    their shared edge in opposite directions) and outward (positive enclosed volume):
    files often mix orientations, and the enclosed volume needs one."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    t = surface.triangles
    m = len(t)
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    owner = np.tile(np.arange(m), 3)
    key = np.sort(directed, axis=1)
    order = np.lexsort((key[:, 1], key[:, 0]))  # each closed edge: two consecutive rows
    a, b = order[0::2], order[1::2]
    same = directed[a, 0] == directed[b, 0]  # both cross the edge the same way: one flips
    graph = coo_matrix((np.where(same, 2, 1), (owner[a], owner[b])), shape=(m, m)).tocsr()
    graph = graph + graph.T
    flip = np.zeros(m, dtype=bool)
    seen = np.zeros(m, dtype=bool)
    _, component = connected_components(graph, directed=False)
    for start in np.unique(component, return_index=True)[1]:
        visit, parent = breadth_first_order(graph, start, directed=False)
        for cell in visit[1:]:
            flip[cell] = flip[parent[cell]] ^ (graph[cell, parent[cell]] == 2)
        seen[visit] = True
    turned = np.where(flip[:, None], t[:, ::-1], t)
    # a consistent orientation: every shared edge now crossed both ways
    d = np.concatenate([turned[:, [0, 1]], turned[:, [1, 2]], turned[:, [2, 0]]])
    if len(np.unique(d, axis=0)) != len(d):
        raise _fail(path, "is not orientable (a Moebius-like surface bounds no solid)")
    p = surface.points[turned]
    if np.einsum("ij,ij->i", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() < 0:
        turned = turned[:, ::-1]
    return TriangleSurface(surface.points, np.ascontiguousarray(turned))


@functools.lru_cache(maxsize=8)
def _filled(path: str, mtime_ns: int, size: int) -> tuple[np.ndarray, np.ndarray]:
    del mtime_ns, size  # the cache key: a changed file is read again
    surface = read_surface(Path(path))
    check_closed(surface, Path(path))
    surface = oriented(surface, Path(path))
    nodes, tets = fill(surface, Path(path))
    return nodes, tets


def filled_surface(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(nodes, tetrahedra) of the solid a closed surface file bounds (cached per file)."""
    if not path.is_file():
        raise _fail(path, "not found")
    stat = path.stat()
    return _filled(str(path.resolve()), stat.st_mtime_ns, stat.st_size)


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
            raise _fail(path, f"could not be filled with tetrahedra by gmsh ({exc}); check that "
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
        raise _fail(path, f"was filled with volume {filled:.6g} where the surface encloses "
                    f"{enclosed:.6g}; check that it does not intersect itself")
    return nodes, tets


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
