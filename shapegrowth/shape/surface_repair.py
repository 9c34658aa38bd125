"""A surface file as it comes (a scan, a CAD export), repaired where the repair is safe.

What is repaired never moves a point of the surface: vertices given more than once (an STL
repeats each at every triangle) are merged where their coordinates are equal; triangles
without area (collapsed by the merge, or given so) and triangles given twice are dropped,
then the vertices no triangle names; the triangles are turned consistently (neighbours cross
their shared edge in opposite directions) across every edge shared by exactly two; of
several disconnected pieces the largest by area is kept unless all are asked for
(``target.pieces``).  What was done is one :class:`Repair`, which says it in one line.

Nothing else is changed: edges shared by more than two triangles (non-manifold edges) and
triangles passing through each other stay, since the area-weighted sampling of an open
surface needs neither manifold nor embedded (a closed surface to be filled is checked
further in :mod:`.surface_files`); holes stay open (filling one invents a surface).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .surface_formats import TriangleSurface, read_triangles

PIECES = ("largest", "all")
# A triangle whose area is below this fraction of the largest one has no normal worth the
# name (a sliver above it has one, and its area weights its samples)
FLAT = 1e-12


@dataclass(frozen=True)
class Repair:
    """What :func:`repaired` did to a surface, and what it left as it was."""

    cropped_triangles: int = 0  # outside target.crop
    merged_vertices: int = 0
    flat_triangles: int = 0
    duplicate_triangles: int = 0
    unreferenced_vertices: int = 0
    turned_triangles: int = 0
    pieces_dropped: int = 0
    dropped_area: float = 0.0  # the dropped pieces' share of the area
    pieces: int = 1  # kept
    open_edges: int = 0
    nonmanifold_edges: int = 0

    def line(self) -> str:
        """One line: what was repaired, then what was kept as it is."""
        done = [_counted(n, what) for n, what in (
            (self.cropped_triangles, "triangle/triangles outside target.crop dropped"),
            (self.merged_vertices, "duplicate vertex/vertices merged"),
            (self.flat_triangles, "triangle/triangles without area dropped"),
            (self.duplicate_triangles, "triangle/triangles given twice dropped"),
            (self.unreferenced_vertices, "unreferenced vertex/vertices dropped"),
            (self.turned_triangles, "triangle/triangles turned to their neighbours' "
                                    "orientation")) if n]
        if self.pieces_dropped:
            done.append(_counted(self.pieces_dropped, "smaller piece/pieces dropped")
                        + f" ({100 * self.dropped_area:.3g} % of the area; target.pieces: all "
                        "keeps them)")
        kept = [_counted(n, what) for n, what in (
            (self.pieces if self.pieces > 1 else 0, "piece/pieces"),
            (self.open_edges, "edge/edges on a rim"),
            (self.nonmanifold_edges, "edge/edges shared by more than two triangles")) if n]
        text = "repaired: " + ", ".join(done) if done else "nothing to repair"
        return text + ("; kept: " + ", ".join(kept) if kept else "")


def _counted(n: int, what: str) -> str:
    """'1 triangle ...' or '2 triangles ...' from 'triangle/triangles ...'."""
    words = [w.split("/")[0 if n == 1 else 1] if "/" in w else w for w in what.split()]
    return f"{n} " + " ".join(words)


def read_surface(path: Path, pieces: str = "all") -> TriangleSurface:
    """The surface of a file, repaired as the module says (``pieces="largest"`` keeps the
    largest piece only)."""
    return repaired(*read_triangles(path), pieces=pieces)[0]


def repaired(points: np.ndarray, triangles: np.ndarray, pieces: str = "largest",
             keep: np.ndarray | None = None) -> tuple[TriangleSurface, Repair]:
    """The surface of ``points`` (n, 3) and ``triangles`` (m, 3) as a file gives them,
    repaired as the module says, and what was done; ``keep`` (m,) the triangles inside a
    crop (the others dropped first)."""
    if pieces not in PIECES:
        raise ValueError(f"pieces: one of {PIECES}")
    points = np.asarray(points, dtype=float)
    t: np.ndarray = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    cropped = 0
    if keep is not None:
        cropped = int(len(t) - np.count_nonzero(keep))
        t = t[np.asarray(keep, dtype=bool)]
        named = np.unique(t)  # a vertex only cropped triangles name is not unreferenced
        points, t = points[named], np.searchsorted(named, t)
    named = np.unique(t)
    unique, inverse = np.unique(points[named], axis=0, return_inverse=True)
    merged = len(named) - len(unique)
    unreferenced = len(points) - len(named)
    index = np.zeros(len(points), dtype=np.int64)
    index[named] = inverse.reshape(-1)
    t = index[t]
    points = unique
    # triangles without area: collapsed by the merge, or flat
    area = _areas(points, t)
    flat = ((t[:, 0] == t[:, 1]) | (t[:, 1] == t[:, 2]) | (t[:, 0] == t[:, 2])
            | (area <= FLAT * (area.max(initial=0.0))))
    t, area = t[~flat], area[~flat]
    # triangles given twice (the same three vertices, either way round): the first kept
    first = np.unique(np.sort(t, axis=1), axis=0, return_index=True)[1]
    keep = np.zeros(len(t), dtype=bool)
    keep[first] = True
    duplicates = int(len(t) - len(first))
    t, area = t[keep], area[keep]
    # pieces: triangles joined by an edge
    label, count = _pieces(t)
    dropped, share = 0, 0.0
    if pieces == "largest" and count > 1:
        sizes = np.bincount(label, weights=area, minlength=count)
        largest = int(np.argmax(sizes))
        dropped, share = count - 1, float(1.0 - sizes[largest] / sizes.sum())
        t, label = t[label == largest], label[label == largest]
        count = 1
    # the vertices of dropped triangles and pieces that no remaining triangle names
    used = np.unique(t)
    renumber = np.zeros(len(points), dtype=np.int64)
    renumber[used] = np.arange(len(used))
    points, t = points[used], renumber[t]
    t, turned = turned_consistently(t)
    counts = edge_counts(t)
    return TriangleSurface(points, t), Repair(
        cropped_triangles=cropped, merged_vertices=int(merged), flat_triangles=int(np.sum(flat)),
        duplicate_triangles=duplicates, unreferenced_vertices=int(unreferenced),
        turned_triangles=turned, pieces_dropped=dropped, dropped_area=share, pieces=count,
        open_edges=int(np.sum(counts == 1)), nonmanifold_edges=int(np.sum(counts > 2)))


def edge_counts(triangles: np.ndarray) -> np.ndarray:
    """How many triangles each edge bounds (one entry per distinct edge)."""
    return np.unique(_edge_keys(triangles)[1], return_counts=True)[1]


def _areas(points: np.ndarray, t: np.ndarray) -> np.ndarray:
    p = points[t]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def _edge_keys(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The directed edges (3m, 2), triangle k's at rows k, m + k, 2m + k, and each one's
    undirected key (an integer)."""
    directed = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    lo, hi = directed.min(axis=1), directed.max(axis=1)
    return directed, lo * (int(t.max(initial=0)) + 1) + hi


def _pieces(t: np.ndarray) -> tuple[np.ndarray, int]:
    """Each triangle's piece (triangles sharing an edge, of any count, are one piece)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    m = len(t)
    if m == 0:
        return np.zeros(0, dtype=np.int64), 0
    _, key = _edge_keys(t)
    edge = np.unique(key, return_inverse=True)[1].reshape(-1)
    incidence = coo_matrix((np.ones(3 * m), (np.tile(np.arange(m), 3), edge))).tocsr()
    count, label = connected_components(incidence @ incidence.T, directed=False)
    return label, int(count)


def turned_consistently(t: np.ndarray) -> tuple[np.ndarray, int]:
    """The triangles turned consistently within each piece, across the edges shared by
    exactly two (a breadth-first tree from each piece's first triangle, which keeps its
    orientation), and how many were turned.  Where the surface is not orientable some pair
    stays inconsistent; the caller checks where that matters."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import breadth_first_order, connected_components

    m = len(t)
    if m == 0:
        return t, 0
    directed, key = _edge_keys(t)
    owner = np.tile(np.arange(m), 3)
    order = np.argsort(key, kind="stable")
    k = key[order]
    start = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])
    size = np.diff(np.r_[start, len(k)])
    pair = start[size == 2]  # edges shared by exactly two triangles
    a, b = order[pair], order[pair + 1]
    same = directed[a, 0] == directed[b, 0]  # both cross the edge the same way: one turns
    weight = np.where(same, 2, 1)
    # one breadth-first tree over every piece: a node m joined to each piece's first triangle
    _, component = connected_components(
        coo_matrix((weight, (owner[a], owner[b])), shape=(m, m)), directed=False)
    roots = np.unique(component, return_index=True)[1]
    rows = np.r_[owner[a], owner[b], np.full(len(roots), m), roots]
    cols = np.r_[owner[b], owner[a], roots, np.full(len(roots), m)]
    data = np.r_[weight, weight, np.ones(2 * len(roots), dtype=weight.dtype)]
    graph = coo_matrix((data, (rows, cols)), shape=(m + 1, m + 1)).tocsr()
    _, parent = breadth_first_order(graph, m, directed=False)
    parent[m] = m
    # turn[c] = turn[parent] ^ (the tree edge says so), by pointer jumping up the tree
    turn: np.ndarray = np.zeros(m + 1, dtype=bool)
    child = np.arange(m)
    turn[:m] = np.asarray(graph[child, parent[:m]]).reshape(-1) == 2
    up = parent
    while np.any(up != up[up]):
        turn ^= turn[up]
        up = up[up]
    turn = turn[:m]
    return np.ascontiguousarray(np.where(turn[:, None], t[:, ::-1], t)), int(np.sum(turn))
