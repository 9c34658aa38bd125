"""The pair loops of phi = exp in float32 (``objective.hausdorff.precision: float32``).

The same sums as kernels.py (Z, V, P per query; the source gradients A, B), with each
pair's distance, exponential and taper in float32: a 512-bit vector holds 16 lanes
instead of 8, and exp needs a polynomial of degree 7 instead of 12.  Precision is kept
where it is lost otherwise:

- coordinates: a source is stored as its offset from its own grid cell's corner
  (``SourceGrid.local32``) and the query's offset from that corner is formed in float64,
  so the differences q - x are of numbers no larger than a cell (about 0.05 of the body
  at the bench's case) and keep float32's 7 digits of the distance itself;
- sums: each cell's terms are summed in float32 lanes and the cells' sums in float64;
  the source gradients in float32 per block of queries and the blocks in float64
  (float64 buffers made the scatter loop no faster than float64's: 0.37 -> 0.34 s against
  0.16 s at the bench's case, for 5e-6 of the largest gradient instead of 8e-7).  Sources
  are ordered by position within a cell (cellgrid.py), so the sums do not depend on how
  the points are numbered;
- range: source weights are divided by their largest, the query coefficients of the
  source gradients by theirs (the callers multiply back), and exponents are clamped at
  80 (exp(-80) is a normal float32; the taper has dropped such terms at any cutoff the
  float32 path accepts, see ``SmoothHausdorff``).

Where the sources' gradient is wanted (the target -> body and body -> body terms) one
sweep gives both (sweep32.soft_values_scatter32, built of this module's pieces): at the
bench's case the two terms took 0.24 + 0.19 s in two passes, 0.19 + 0.16 s in one.
Each cell's sources are trimmed to the query's slab in x (_slab): they are sorted by x
within their cell, and the slab's width is that of the ball where it meets the box the
cell's sources fill in y and z.

The pair loops are pairs.py's template compiled in float32.  Measured against float64 on
the bench's 50k-DOF state (38 448 + 38 448 points, alpha 200): see docs/PERFORMANCE.md,
"float32 pair sums".
"""

from __future__ import annotations

import numba
import numpy as np

from . import pairs
from .cellgrid import _cell_range, _column_cells

_F = np.float32
_ZERO = _F(0)


@numba.njit(cache=True)
def exp32_array(x):
    """pairs.exp32 over a float32 array (for its accuracy test)."""
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = pairs.exp32(x[i])
    return out


# The float32 loops over one cell's slab of sources (pairs.pair_loop)
_SUMS = pairs.pair_loop("float32", "exp", "sums")
_VALUES = pairs.pair_loop("float32", "exp", "values")
_SCATTER = pairs.pair_loop("float32", "exp", "scatter")


@numba.njit(cache=True, inline="always")
def _corner(origin, cell, ix, iy, iz, q):
    """The query's offset from the corner of cell (ix, iy, iz), formed in float64."""
    return (_F(q[0] - (origin[0] + ix * cell)), _F(q[1] - (origin[1] + iy * cell)),
            _F(q[2] - (origin[2] + iz * cell)))

@numba.njit(cache=True, inline="always")
def _first_at_least(xs, j0, j1, v):
    """The first position in [j0, j1) whose xs is >= v (j1 if none): xs sorted there."""
    lo, hi = j0, j1
    while lo < hi:
        mid = (lo + hi) >> 1
        if xs[mid] < v:
            lo = mid + 1
        else:
            hi = mid
    return lo


@numba.njit(cache=True, inline="always")
def _slab(xs, j0, j1, qx, qy, qz, radius, cell, box):
    """The sources of one cell (offsets from its corner, sorted by x within it) that the
    query's ball can reach: those with |x - qx| <= sqrt(radius^2 - by^2 - bz^2), by and bz
    the query's distances in y and z to the box of the cell's sources (SourceGrid.box32:
    tighter than the cell's own: S with its gradient at the bench's 50k-DOF state
    0.62-0.63 -> 0.60 s).  Empty (j0, j0) when the box is beyond the radius.  Pairs
    farther than the radius add exact zeros (the taper), so a margin of 1e-5 of a cell
    takes in the few the float32 rounding might leave out."""
    by = max(box[0] - qy, _ZERO, qy - box[1])
    bz = max(box[2] - qz, _ZERO, qz - box[3])
    h2 = radius * radius - by * by - bz * bz
    if h2 < _ZERO:
        return j0, j0
    h = np.sqrt(h2) + _F(1e-5) * cell
    a = _first_at_least(xs, j0, j1, qx - h)
    return a, _first_at_least(xs, a, j1, qx + h)


@numba.njit(cache=True)
def _spans(q, radius, grid, xs, box, spans, corners):
    """The sources the query's ball reaches, as the slabs (_slab) of the cells of ``grid``
    (kernels.Grid) it meets: each slab's range (j0, j1) in ``spans`` and the query's offsets
    from its cell's corner in ``corners``.  Returns how many, and the two arrays (new ones,
    twice as long, where the ones given held too few)."""
    origin, cell, shape, start = grid
    x0, x1 = _cell_range(q, radius, origin, cell, shape, 0)
    y0, y1 = _cell_range(q, radius, origin, cell, shape, 1)
    r32 = _F(radius)
    c32cell = _F(cell)
    count = 0
    for ix in range(x0, x1 + 1):
        for iy in range(y0, y1 + 1):
            c0, z0, z1 = _column_cells(q[0], q[1], q[2], radius, ix, iy, origin, cell, shape)
            for iz in range(z0, z1 + 1):
                j0, j1 = start[c0 + iz], start[c0 + iz + 1]
                if j1 == j0:
                    continue
                qx, qy, qz = _corner(origin, cell, ix, iy, iz, q)
                j0, j1 = _slab(xs, j0, j1, qx, qy, qz, r32, c32cell, box[c0 + iz])
                if j1 == j0:
                    continue
                if count == spans.shape[0]:
                    more = np.empty((2 * count, 2), dtype=np.int64)
                    more[:count] = spans
                    spans = more
                    wider = np.empty((2 * count, 3), dtype=np.float32)
                    wider[:count] = corners
                    corners = wider
                spans[count, 0] = j0
                spans[count, 1] = j1
                corners[count, 0] = qx
                corners[count, 1] = qy
                corners[count, 2] = qz
                count += 1
    return count, spans, corners


@numba.njit(cache=True)
def _summed(buf):
    """The float32 source sums of the blocks of queries, (nchunks, 4, m), summed in float64
    as (m, 4)."""
    total = np.zeros((buf.shape[2], 4))
    for k in range(buf.shape[0]):
        for c in range(4):
            total[:, c] += buf[k, c]
    return total


@numba.njit(parallel=True, cache=True)
def soft_values32(queries, sources, grid, gmin, radius, taper, with_gradient, nchunks):
    """kernels.soft_values for phi = exp in float32: ``sources`` = (local, box, w), the
    sources' offsets from their cells' corners (SourceGrid.local32), their cells' boxes
    (SourceGrid.box32) and the sorted weights divided by their largest, as float32;
    ``taper`` a float32 pairs.Taper; the queries split in ``nchunks`` blocks."""
    n = queries.shape[0]
    unused = np.zeros(0, dtype=np.float32)  # for a loop's argument its variant does not use
    Z = np.zeros(n)
    P = np.zeros(n)
    V = np.zeros((n, 3))
    local, box, w = sources
    xs, ys, zs = local[0], local[1], local[2]
    none = (unused, unused)
    acc = (unused, unused, unused, unused)
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        spans = np.empty((256, 2), dtype=np.int64)
        corners = np.empty((256, 3), dtype=np.float32)
        for i in range(k * size, min(n, (k + 1) * size)):
            count, spans, corners = _spans(queries[i], radius[i], grid, xs, box, spans,
                                           corners)
            base = _F(gmin[i])
            z = 0.0
            p = 0.0
            vx = 0.0
            vy = 0.0
            vz = 0.0
            for t in range(count):
                j0, j1 = spans[t, 0], spans[t, 1]
                qx, qy, qz = corners[t, 0], corners[t, 1], corners[t, 2]
                src = (xs[j0:j1], ys[j0:j1], zs[j0:j1])
                if with_gradient:
                    dz_, dvx, dvy, dvz, dp = _SUMS(qx, qy, qz, base, taper, _ZERO, src,
                                                   w[j0:j1], none, acc)
                else:
                    dz_, dvx, dvy, dvz, dp = _VALUES(qx, qy, qz, base, taper, _ZERO, src,
                                                     w[j0:j1], none, acc)
                z += dz_
                p += dp
                vx += dvx
                vy += dvy
                vz += dvz
            Z[i] = z
            P[i] = p
            V[i, 0] = vx
            V[i, 1] = vy
            V[i, 2] = vz
    return Z, V, P


@numba.njit(parallel=True, cache=True)
def soft_source_gradient32(queries, sources, grid, gmin, radius, taper, coef, nchunks):
    """kernels.soft_source_gradient for phi = exp in float32 (``sources`` = (local, box);
    ``coef`` divided by its largest magnitude, as float32)."""
    n = queries.shape[0]
    unused = np.zeros(0, dtype=np.float32)  # for a loop's argument its variant does not use
    local, box = sources
    m = local.shape[1]
    buf = np.zeros((nchunks, 4, m), dtype=np.float32)
    xs, ys, zs = local[0], local[1], local[2]
    none = (unused, unused)
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        ax, ay, az, b = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        spans = np.empty((256, 2), dtype=np.int64)
        corners = np.empty((256, 3), dtype=np.float32)
        for i in range(k * size, min(n, (k + 1) * size)):
            a = coef[i]
            if a == _ZERO:
                continue
            count, spans, corners = _spans(queries[i], radius[i], grid, xs, box, spans,
                                           corners)
            base = _F(gmin[i])
            for t in range(count):
                j0, j1 = spans[t, 0], spans[t, 1]
                _SCATTER(corners[t, 0], corners[t, 1], corners[t, 2], base, taper, a,
                         (xs[j0:j1], ys[j0:j1], zs[j0:j1]), unused, none,
                         (ax[j0:j1], ay[j0:j1], az[j0:j1], b[j0:j1]))
    return _summed(buf)
