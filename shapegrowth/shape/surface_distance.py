"""The exact Hausdorff distance between a face and a surface, surface to surface.

Between two point clouds the Hausdorff distance is at least the gap a sparse cloud leaves:
a face sampled at its facets' quadrature points (spacing h / 3 on P2 facets) is that far from
a scan sampled a hundred times more densely even where the two surfaces coincide (measured on
a plate of h = 0.1 grown by a relief's exact growth: 3.3 % of the relief's size, all of it
sampling).  Here each side's points are measured against the other side's triangles
(segments in 2D): the deformed face as its facets subdivided into flat pieces
(:meth:`FacetCloud.lattice`), a surface file as its triangles, a map's image of the face as
the image of the same pieces.

A point's distance to a set of simplices is the smallest of its exact distances to the
simplices whose centroids are among its k nearest; where a simplex farther out could still be
closer (the distance found plus the largest centroid-to-vertex radius reaches past the k-th
centroid), all the simplices whose centroids lie within that reach are measured.  Of a cloud
of points, only the largest distance is needed: a point's distance to the simplices of its k
nearest centroids bounds it from above (and mostly is it), so the points are settled in the
order of that bound until it falls below the largest found (a few batches of a scan's 10^5
vertices).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI
from scipy.spatial import cKDTree

NEAREST = 16  # simplices measured first per point


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray,
                         c: np.ndarray) -> np.ndarray:
    """The points of the triangles (a, b, c) closest to the points p (all (n, 3)): Ericson's
    regions (Real-Time Collision Detection, 5.1.5), vectorised."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("ij,ij->i", ab, ap), np.einsum("ij,ij->i", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("ij,ij->i", ab, bp), np.einsum("ij,ij->i", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("ij,ij->i", ab, cp), np.einsum("ij,ij->i", ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v = np.where(denom != 0, vb / denom, 0.0)
        w = np.where(denom != 0, vc / denom, 0.0)
        out = a + ab * v[:, None] + ac * w[:, None]  # inside the face
        # the edges and vertices, from the last region Ericson tests to the first, so that the
        # first that holds wins
        bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        out = np.where(bc[:, None], b + (c - b) * np.nan_to_num(t)[:, None], out)
        on_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
        out = np.where(on_ac[:, None], a + ac * np.nan_to_num(d2 / (d2 - d6))[:, None], out)
        out = np.where(((d6 >= 0) & (d5 <= d6))[:, None], c, out)
        on_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
        out = np.where(on_ab[:, None], a + ab * np.nan_to_num(d1 / (d1 - d3))[:, None], out)
        out = np.where(((d3 >= 0) & (d4 <= d3))[:, None], b, out)
        out = np.where(((d1 <= 0) & (d2 <= 0))[:, None], a, out)
    return out


def closest_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    length2 = np.einsum("ij,ij->i", ab, ab)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(length2 > 0, np.einsum("ij,ij->i", p - a, ab) / length2, 0.0)
    return a + ab * np.clip(t, 0.0, 1.0)[:, None]


class Simplices:
    """Triangles (m, 3, dim) or segments (m, 2, dim), searchable by their centroids."""

    def __init__(self, corners: np.ndarray):
        self.corners = np.asarray(corners, dtype=float)
        self.centroids = self.corners.mean(axis=1)
        self.radius = float(np.max(np.linalg.norm(self.corners - self.centroids[:, None],
                                                  axis=2), initial=0.0))
        self.tree = cKDTree(self.centroids) if len(self.corners) else None

    def __len__(self) -> int:
        return len(self.corners)

    def _distances(self, points: np.ndarray, which: np.ndarray) -> np.ndarray:
        s = self.corners[which]
        if s.shape[1] == 3:
            closest = closest_on_triangles(points, s[:, 0], s[:, 1], s[:, 2])
        else:
            closest = closest_on_segments(points, s[:, 0], s[:, 1])
        return np.linalg.norm(points - closest, axis=1)

    def _nearest(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each point's distance to the simplices of its k nearest centroids (an upper bound
        of its distance), and whether that is its distance (no farther centroid within the
        distance plus the largest radius)."""
        assert self.tree is not None
        k = min(NEAREST, len(self))
        reach, index = self.tree.query(points, k=k)
        reach, index = reach.reshape(len(points), k), index.reshape(len(points), k)
        d = np.min([self._distances(points, index[:, j]) for j in range(k)], axis=0)
        exact = np.full(len(points), True) if k == len(self) else \
            d + self.radius <= reach[:, -1]
        return d, exact

    def _settle(self, points: np.ndarray, d: np.ndarray, which: np.ndarray,
                chunk: int = 1 << 20) -> None:
        """d[which] made exact: the points measured against every simplex whose centroid
        lies within their bound plus the largest radius."""
        if len(which) == 0:
            return
        assert self.tree is not None
        near = self.tree.query_ball_point(points[which], d[which] + self.radius)
        counts = np.array([len(n) for n in near])
        owner = np.repeat(which, counts)
        candidates = np.concatenate([np.asarray(n, dtype=np.int64) for n in near])
        for lo in range(0, len(owner), chunk):
            o, c = owner[lo:lo + chunk], candidates[lo:lo + chunk]
            np.minimum.at(d, o, self._distances(points[o], c))

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Each point's distance to the nearest simplex (inf where there are none)."""
        points = np.asarray(points, dtype=float)
        if self.tree is None or len(points) == 0:
            return np.full(len(points), np.inf)
        d, exact = self._nearest(points)
        self._settle(points, d, np.flatnonzero(~exact))
        return d

    def farthest(self, points: np.ndarray, batch: int = 64) -> float:
        """The largest of the points' distances to the simplices (0 for no points), settled
        exactly for the few points that can hold it: the distance to the simplices of the k
        nearest centroids bounds a point's distance from above (and mostly is it), so the
        points are settled in the order of that bound, until the bound falls to the largest
        distance found."""
        points = np.asarray(points, dtype=float)
        if len(points) == 0:
            return 0.0
        if self.tree is None:
            return np.inf
        d, exact = self._nearest(points)
        order = np.argsort(-d)
        found = 0.0
        for start in range(0, len(order), batch):
            chunk = order[start:start + batch]
            if d[chunk[0]] <= found:
                break
            self._settle(points, d, chunk[~exact[chunk]])
            found = max(found, float(d[chunk].max()))
        return found


def surface_hausdorff(a_points: np.ndarray, a: Simplices, b_points: np.ndarray, b: Simplices,
                      comm: MPI.Comm) -> float:
    """max(sup of this rank's a_points' distances to b, sup of b_points' to a), over the
    ranks; the simplices whole on every rank."""
    local = max(b.farthest(a_points), a.farthest(b_points))
    return comm.allreduce(float(local), MPI.MAX)
