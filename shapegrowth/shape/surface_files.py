"""Triangulated surfaces from files (read by :mod:`.surface_formats`): checked, then filled
into volumes or taken as surfaces.

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
from pathlib import Path

import numpy as np

from .surface_formats import TriangleSurface, fail, read_surface


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
        raise fail(path, f"has {flat} triangles without area; remove them (a degenerate "
                    "triangle has no normal)")
    if len(np.unique(np.sort(t, axis=1), axis=0)) < len(t):
        raise fail(path, "overlaps itself: a triangle is given twice; give each once")
    counts = _edge_counts(t)
    if np.any(counts > 2):
        raise fail(path, f"overlaps itself: {int(np.sum(counts > 2))} edges bound more than "
                    "two triangles; give one surface")
    crossing = crossing_pairs(p, t)
    if len(crossing):
        a, b = crossing[0]
        raise fail(path, f"overlaps itself: {len(crossing)} pairs of triangles cross (the "
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
        raise fail(path, "is not orientable (a Moebius-like surface bounds no solid)")
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
        raise fail(path, "not found")
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
