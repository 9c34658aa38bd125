"""The uniform cell grid the pair kernels walk, and nearest distances on it (numba).

Sources are sorted by cell and stored as three contiguous coordinate rows with the
CSR offsets of the cells, so a query streams through memory over the cells its
ball reaches.  The same grid gives each query's nearest source: the shift and the
cutoff radius of its soft minimum, and the exact Hausdorff distance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

_FAST_MIN = {"contract", "arcp", "afn", "reassoc", "nnan", "nsz"}  # finite points: no NaN
# The nearest-source search runs on a grid of its own, of cells SPACINGS x the sources'
# median spacing (the sums' grid has cells of ~0.6 cutoff radii, which a search for one
# source scans whole).  Both directions at the bench's 50k-DOF state, the grid's build
# included: 1.5: 0.84 s, 2: 0.47, 3: 0.27, 4: 0.20, 6: 0.14-0.21, 8: 0.14, 12: 0.15,
# 16: 0.18, 24: 0.22 (the sums' grid: 0.31 s, and its sizing sample 0.04 s); with the
# search's one pass (nearest_source): 3: 0.19, 4: 0.15, 6: 0.11, 8: 0.11, 12: 0.13, 16: 0.14
SPACINGS = 8.0
# Cells of the float32 sums' grid, in cutoff radii: each cell's sources are trimmed to the
# query's slab in x (kernels32._slab), so a larger cell costs fewer pairs than it would
# whole, and fewer calls of the pair loop (each ~35 ns besides its pairs).  S with its
# gradient at the bench's 50k-DOF state: 0.6: 0.86 s, 0.8: 0.82, 1.0: 0.79, 1.2: 0.80,
# 1.5: 0.81 (0.92 s at 0.6 without the slab)
SLAB_CELL = 1.0
# Queries dealt to threads in blocks of this many neighbours (SourceGrid.locality_order):
# 16, 64, 256 and 1024 measured the same
QUERY_BLOCK = 64


class Grid(NamedTuple):
    """The cell grid a query walks: its lowest corner, the cell's edge, the cells along
    each axis and the CSR offsets of the sorted sources by cell (a record the pair sweeps
    take whole)."""

    origin: np.ndarray
    cell: float
    shape: np.ndarray
    start: np.ndarray


@dataclass
class SourceGrid:
    """Sources sorted by cell, with the CSR offsets of the cells."""

    xyz: np.ndarray  # (3, m) sorted coordinates
    weights: np.ndarray  # (m,) sorted weights
    order: np.ndarray  # (m,) sorted position -> original index
    origin: np.ndarray  # (3,)
    cell: float
    shape: np.ndarray  # (3,) int64
    start: np.ndarray  # (ncells + 1,) int64
    # (3, m) float32: each sorted source's offset from its own cell's lowest corner, for the
    # float32 pair loops (kernels32.py): offsets of at most a cell keep 7 digits of a distance
    local32: np.ndarray | None = None
    # (ncells, 4) float32 with local32: the lowest and highest y and z offsets of each
    # cell's sources, the box kernels32._slab trims a cell's sources by
    box32: np.ndarray | None = None

    @property
    def cells(self) -> Grid:
        """The grid the pair sweeps walk."""
        return Grid(self.origin, float(self.cell), self.shape, self.start)

    @classmethod
    def build(cls, points: np.ndarray, weights: np.ndarray, cell: float | None,
              local32: bool = False, lexical: np.ndarray | None = None) -> SourceGrid:
        """``cell=None``: one cell holding everything (brute force); ``local32``: keep the
        float32 offsets of the sources from their cells' corners too; ``lexical``: the
        points' order by (x, y, z) (lexical_order), where the caller keeps it."""
        pts = as3(points)
        lo, hi = bounding_box(pts)
        if cell is None or not np.isfinite(cell) or cell <= 0:
            cell = max(float((hi - lo).max()), 1.0) * 2.0
        shape = np.maximum(np.ceil((hi - lo) / cell).astype(np.int64), 1)
        idx = np.minimum(((pts - lo) / cell).astype(np.int64), shape - 1)
        flat = (idx[:, 0] * shape[1] + idx[:, 1]) * shape[2] + idx[:, 2]
        # within a cell by position: the order (and so every float32 sum) does not depend on
        # how the points were numbered; a stable sort by cell of the points' order by
        # position (at 38k points 1.5 ms against 8.3 ms for the four keys' lexsort)
        if lexical is None:
            lexical = lexical_order(pts)
        order = lexical[np.argsort(flat[lexical], kind="stable")]
        counts = np.bincount(flat, minlength=int(np.prod(shape)))
        start = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        ordered = pts[order]
        local = box = None
        if local32:
            local = np.ascontiguousarray((ordered - (lo + idx[order] * cell)).T,
                                         dtype=np.float32)
            box = _cell_boxes(local, start)
        return cls(np.ascontiguousarray(ordered.T), np.ascontiguousarray(weights[order]),
                   order, lo, float(cell), shape, start, local, box)

    @property
    def ncells(self) -> int:
        return int(np.prod(self.shape))

    def locality_order(self, queries: np.ndarray, parts: int = 1) -> np.ndarray:
        """An order of the queries by grid cell: neighbours in turn reuse cached sources.

        ``parts`` > 1: blocks of QUERY_BLOCK neighbours are dealt in turn to ``parts``
        parts, each part one contiguous range of the order, so that a static split of the
        queries (or of ``parts`` chunks) among threads gives each thread queries from all
        over the cloud.  Split by position, one of two threads had the costlier half: S
        with its gradient at the bench's 50k-DOF state 0.60 -> 0.56 s dealt (the pair sums
        0.025 s, the nearest-source search 0.015 s)."""
        idx = np.clip(((queries - self.origin) / self.cell).astype(np.int64), 0, self.shape - 1)
        flat = (idx[:, 0] * self.shape[1] + idx[:, 1]) * self.shape[2] + idx[:, 2]
        order = np.argsort(flat, kind="stable")
        if parts <= 1:
            return order
        blocks = np.arange(-(-len(order) // QUERY_BLOCK))
        dealt = np.concatenate([blocks[k::parts] for k in range(parts)])
        at = (dealt[:, None] * QUERY_BLOCK + np.arange(QUERY_BLOCK)).ravel()
        return order[at[at < len(order)]]


@numba.njit(cache=True)
def _cell_boxes(local, start):
    """The lowest and highest y and z offsets of each cell's sources (zeros for none)."""
    box = np.zeros((start.shape[0] - 1, 4), dtype=np.float32)
    for c in range(start.shape[0] - 1):
        j0, j1 = start[c], start[c + 1]
        if j1 > j0:
            box[c, 0] = box[c, 1] = local[1, j0]
            box[c, 2] = box[c, 3] = local[2, j0]
            for j in range(j0 + 1, j1):
                box[c, 0] = min(box[c, 0], local[1, j])
                box[c, 1] = max(box[c, 1], local[1, j])
                box[c, 2] = min(box[c, 2], local[2, j])
                box[c, 3] = max(box[c, 3], local[2, j])
    return box


def lexical_order(points: np.ndarray) -> np.ndarray:
    """The points' order by x, then y, then z."""
    pts = as3(points)
    return np.lexsort((pts[:, 2], pts[:, 1], pts[:, 0]))


def bounding_box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest coordinates of (n, k) points (zeros for none): one pass
    (numpy's min and max along axis 0 of an (n, 3) array took 0.7 ms each at 38k points,
    some 25 ms of an evaluation of S at the bench's case)."""
    if len(points) == 0:
        return np.zeros(points.shape[1]), np.zeros(points.shape[1])
    return _box(np.ascontiguousarray(points, dtype=np.float64))


@numba.njit(cache=True)
def _box(pts):
    lo = pts[0].copy()
    hi = pts[0].copy()
    for i in range(1, pts.shape[0]):
        for k in range(pts.shape[1]):
            lo[k] = min(lo[k], pts[i, k])
            hi[k] = max(hi[k], pts[i, k])
    return lo, hi


def as3(points: np.ndarray) -> np.ndarray:
    """Points as contiguous (n, 3) float64 (2D points get X3 = 0)."""
    pts = np.asarray(points, dtype=np.float64)
    if pts.shape[1] == 3:
        return np.ascontiguousarray(pts)
    out = np.zeros((len(pts), 3))
    out[:, :pts.shape[1]] = pts
    return out


def search_cell(sources: np.ndarray, size: int = 128) -> float | None:
    """Cell size of the grid that nearest_source searches: SPACINGS x the sources' median
    spacing (the distance from a sample of them to the nearest other one), or None (one
    cell) for a cloud too small to need one."""
    pts = as3(sources)
    if len(pts) < 2000:
        return None
    sample = np.arange(0, len(pts), max(1, len(pts) // size))
    spacing = float(np.median(_spacing(sample, np.ascontiguousarray(pts.T))))
    if spacing <= 0:
        return None
    return max(SPACINGS * spacing, _floor_cell(pts, 0.25))  # <= 4 cells a source


def _floor_cell(pts: np.ndarray, per_cell: float) -> float:
    """The cell of a grid with ``per_cell`` sources a cell on average, were they spread over
    their bounding box (its flat directions left out): the smallest cell a grid takes."""
    lo, hi = bounding_box(pts)
    extent = hi - lo
    filled = extent[extent > 1e-12 * max(extent.max(), 1.0)]
    volume = float(np.prod(filled)) if len(filled) else 1.0
    return (volume / (len(pts) / per_cell)) ** (1.0 / max(len(filled), 1))


@numba.njit(parallel=True, cache=True)
def _spacing(sample, xyz):
    out = np.empty(sample.shape[0])
    for k in numba.prange(sample.shape[0]):
        i = sample[k]
        best = np.inf
        for j in range(xyz.shape[1]):
            d = (xyz[0, i] - xyz[0, j]) ** 2 + (xyz[1, i] - xyz[1, j]) ** 2 + (
                xyz[2, i] - xyz[2, j]) ** 2
            if j != i and d < best:
                best = d
        out[k] = math.sqrt(best)
    return out


def auto_cell(sources: np.ndarray, radii: np.ndarray, per_radius: float = 0.6) -> float | None:
    """Grid cell size for the given cutoff radii, ``per_radius`` x their median, or None
    when a grid would not prune."""
    pts = as3(sources)
    if len(pts) < 2000 or len(radii) == 0:
        return None
    lo, hi = bounding_box(pts)
    extent = hi - lo
    typical = float(np.median(radii))
    if typical >= 0.5 * float(extent.max()):
        return None  # most queries see most sources
    # float64 (whole cells summed): 0.6 x the typical cutoff radius (value + gradient at
    # 1e5 points: 0.35: 1.10 s, 0.45: 0.99 s, 0.6: 0.95 s, 0.8: 0.97 s; spans of ~160
    # sources keep the vector loops busy); float32 trims each cell to the query's slab
    # (kernels32._slab) and takes larger cells (SLAB_CELL); never more cells than
    # ~ sources / 16
    return max(per_radius * typical, _floor_cell(pts, 16.0))


@numba.njit(cache=True, inline="always")
def _cell_range(q, radius, origin, cell, shape, k):
    """Cells along axis k that the ball of the query reaches (clamped to the grid)."""
    a = int(math.floor((q[k] - radius - origin[k]) / cell))
    b = int(math.floor((q[k] + radius - origin[k]) / cell))
    return min(max(a, 0), shape[k] - 1), min(max(b, 0), shape[k] - 1)


@numba.njit(cache=True, inline="always")
def _column_cells(qx, qy, qz, radius, ix, iy, origin, cell, shape):
    """Cells z0..z1 of column (ix, iy) that the ball of the query reaches, and the flat
    index of the column's first cell; z1 < z0 when the column's box is beyond the radius."""
    bx = max(origin[0] + ix * cell - qx, 0.0, qx - origin[0] - (ix + 1) * cell)
    by = max(origin[1] + iy * cell - qy, 0.0, qy - origin[1] - (iy + 1) * cell)
    rem = radius * radius - bx * bx - by * by
    c0 = (ix * shape[1] + iy) * shape[2]
    if rem < 0.0:
        return c0, 0, -1
    h = math.sqrt(rem)
    z0 = min(max(int(math.floor((qz - h - origin[2]) / cell)), 0), shape[2] - 1)
    z1 = min(max(int(math.floor((qz + h - origin[2]) / cell)), 0), shape[2] - 1)
    return c0, z0, z1


@numba.njit(cache=True, inline="always")
def _column(qx, qy, qz, radius, ix, iy, origin, cell, shape, start):
    """Source range of column (ix, iy) within the ball of the query: empty when the
    column's box is farther than the radius, else only the cells the ball reaches."""
    c0, z0, z1 = _column_cells(qx, qy, qz, radius, ix, iy, origin, cell, shape)
    if z1 < z0:
        return 0, 0
    return start[c0 + z0], start[c0 + z1 + 1]


@numba.njit(cache=True, fastmath=_FAST_MIN)
def _min_square(qx, qy, qz, xs, ys, zs):
    best = np.inf
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        best = min(best, dx * dx + dy * dy + dz * dz)
    return best


@numba.njit(cache=True)
def _argmin_square(qx, qy, qz, xs, ys, zs):
    """Position of the nearest source in a span (a scalar loop: run once per query, over the
    span the vectorised minimum found it in)."""
    best = np.inf
    at = 0
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        d = dx * dx + dy * dy + dz * dz
        if d < best:
            best = d
            at = j
    return at


@numba.njit(parallel=True, cache=True)
def nearest_source(queries, xyz, origin, cell, shape, start, nchunks=64):
    """Distance from each query to its nearest source, and that source's position in the
    grid's sorted order.  The ball around the query is that of the distance to the source
    nearest the query before it (queries in locality order: that bound is close), scanned
    once, column by column, each column against the nearest found so far; a block's first
    query doubles its ball from one cell until it holds a source no farther than its
    radius.  At the bench's 50k-DOF state on a grid of 8 spacings, both directions: the
    doubling alone 0.30 s, the doubling bounded by the last query's nearest 0.10 s, one
    pass over the bound's shrinking ball 0.07 s.  Queries are split in ``nchunks`` blocks,
    each searched in turn."""
    n = queries.shape[0]
    out = np.empty(n)
    index = np.empty(n, dtype=np.int64)
    xs, ys, zs = xyz[0], xyz[1], xyz[2]
    reach = cell * math.sqrt(float(shape[0] ** 2 + shape[1] ** 2 + shape[2] ** 2))
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        last = -1
        for i in range(k * size, min(n, (k + 1) * size)):
            qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
            bound = np.inf
            if last >= 0:  # no farther than the last query's nearest source (a margin for
                dx = qx - xs[last]  # the rounding of the ball's cell ranges)
                dy = qy - ys[last]
                dz = qz - zs[last]
                bound = math.sqrt(dx * dx + dy * dy + dz * dz) * (1.0 + 1e-9) + 1e-300
            # with a bound, one pass over its ball, which shrinks to the nearest found so
            # far (no doubling: each round rescanned the cells of the one before)
            rho = bound if last >= 0 else cell
            best = np.inf
            at0 = 0
            at1 = 0
            while True:
                x0, x1 = _cell_range(queries[i], rho, origin, cell, shape, 0)
                y0, y1 = _cell_range(queries[i], rho, origin, cell, shape, 1)
                reach_now = rho
                for ix in range(x0, x1 + 1):
                    for iy in range(y0, y1 + 1):
                        if best < reach_now * reach_now:
                            reach_now = math.sqrt(best) * (1.0 + 1e-9) + 1e-300
                        j0, j1 = _column(qx, qy, qz, reach_now, ix, iy, origin, cell, shape,
                                         start)
                        # blocks of 64: the vectorised minimum of each, the block that holds
                        # the nearest kept for the scalar search of its position
                        for b0 in range(j0, j1, 64):
                            b1 = min(b0 + 64, j1)
                            here = _min_square(qx, qy, qz, xs[b0:b1], ys[b0:b1], zs[b0:b1])
                            if here < best:
                                best = here
                                at0 = b0
                                at1 = b1
                if best <= rho * rho or rho >= bound or rho > 2.0 * reach + _distance_to_box(
                        queries[i], origin, cell, shape):
                    break
                rho = min(2.0 * rho, bound)
            out[i] = math.sqrt(best)
            index[i] = at0 + _argmin_square(qx, qy, qz, xs[at0:at1], ys[at0:at1],
                                            zs[at0:at1])
            last = index[i]
    return out, index


def nearest_distance(queries, xyz, origin, cell, shape, start) -> np.ndarray:
    """Distance from each query to its nearest source (see nearest_source)."""
    return nearest_source(queries, xyz, origin, cell, shape, start)[0]


@numba.njit(cache=True, inline="always")
def _distance_to_box(q, origin, cell, shape):
    d = 0.0
    for k in range(3):
        lo = origin[k]
        hi = origin[k] + shape[k] * cell
        e = max(lo - q[k], 0.0, q[k] - hi)
        d += e * e
    return math.sqrt(d)
