"""Compiled pair kernels of the smooth Hausdorff distance (numba, float64).

For a query point q and weighted sources (x_s, w_s) the soft distance of (2.9) is

    s(q) = g_min - (1/alpha) log( sum_s w_s exp(-alpha (g(r_s) - g_min)) / W ),

with r_s = |q - x_s|, W = sum_s w_s, g(r) = r for phi(t) = exp(-t) and
g(r) = log(1 + r) for phi(t) = 1/(1 + t) (then the distance is exp(s) - 1).
Shifting by g_min = min_s g(r_s) keeps every exponent <= 0: the sum is finite at
any alpha, and no |x|^2 + |y|^2 - 2xy expansion is used.

Sources are bucketed in the uniform cell grid of cellgrid.py.  A query visits
only the cells within its cutoff radius, the r where alpha (g(r) - g_min) = c; each
term is multiplied by a smooth step S(alpha (g(r) - g_min)) that falls from 1 to 0 over
the last e-folds before c (pairs.taper_of), so the sum is a C^1 function of the points whichever
pairs the grid skips, and the brute force (a single cell) gives the same numbers.
For phi = exp the pair loops vectorise (AVX-512 here): exp is written out as
arithmetic (pairs.exp64) and the sums may be reassociated; the pair loops themselves are
pairs.py's one template.  Measured brute-force
throughput on this 2-core machine (benchmarks/hausdorff.py): 1.19e9 pairs/s for
values with query gradients, 1.12e9 for source gradients, against 3.6e8 and 3.4e8
with libm's scalar exp.
"""

from __future__ import annotations

import os

import numba
import numpy as np
from mpi4py import MPI

from . import pairs
from .cellgrid import _cell_range, _column

# Default cutoff c: a term below exp(-c) of the nearest is dropped, and terms fade out
# smoothly (continuously differentiable) over the TAPER e-folds before it, so rho_H with the
# cutoff is one C^1 function, differentiated exactly (the fade-out moves with each query's
# nearest source, and that shift is in the gradient).  Measured on scene 1's beam at 50k
# DOFs, alpha 200, against no cutoff: c = 20: rho_H - (rho_H(B, B))/2 within 1.7e-9, its
# gradient 2.4e-8; c = 14: 6.9e-7 and 9.2e-6; c = 10: 2.8e-5, 4.9e-4; c = 6: 6.5e-4,
# 2.6e-2 (docs/PERFORMANCE.md).
CUTOFF = 14.0
TAPER = 2.0
# Exponents are clamped at 100: a term below exp(-100) of the largest changes nothing,
# and exp takes a slow path for larger arguments (the brute force at alpha * size = 1000
# ran at 2.2e8 pairs/s with the clamp at 600, 4.0e8 with it at 100).


_threads_decided = False


def one_thread_per_rank() -> None:
    """Under MPI the ranks already fill the cores: numba threads would oversubscribe them
    (2 ranks x 2 threads on 2 cores: rho_H no faster than on one rank).  NUMBA_NUM_THREADS,
    when set, decides.  The threading layer is OpenMP's (or numba's workqueue) before TBB's:
    at exit TBB's scheduler waits for its workers, which only yield, and on a machine whose
    cores other jobs fill a finished serial run hung there for minutes (measured: still
    waiting after 5 min beside a 2-rank run on 2 cores); NUMBA_THREADING_LAYER, when set,
    decides.  Called before the kernels run (not at import: importing changes nothing)."""
    global _threads_decided
    if not _threads_decided:
        _threads_decided = True
        if "NUMBA_THREADING_LAYER" not in os.environ:
            numba.config.THREADING_LAYER_PRIORITY = ["omp", "workqueue", "tbb"]
        if MPI.COMM_WORLD.size > 1 and "NUMBA_NUM_THREADS" not in os.environ:
            numba.set_num_threads(1)


@numba.njit(cache=True)
def exp_array(x):
    """pairs.exp64 over an array (for its accuracy test)."""
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = pairs.exp64(x[i])
    return out


_taper = pairs.taper_of("float64")


@numba.njit(cache=True)
def taper_array(u, cut, width):
    """S(u) and -dS/du over an array (for its tests)."""
    s = np.empty_like(u)
    ds = np.empty_like(u)
    for i in range(u.shape[0]):
        s[i], ds[i] = _taper(u[i], cut, 1.0 / width)
    return s, ds


# The float64 loops over one span of sources (pairs.pair_loop): with the grid's slices as
# bounds LLVM vectorises them (with bounds loaded from the grid's offsets it did not)
_SUMS = pairs.pair_loop("float64", "exp", "sums")
_VALUES = pairs.pair_loop("float64", "exp", "values")
_RATIONAL = pairs.pair_loop("float64", "rational", "sums")
_SCATTER = pairs.pair_loop("float64", "exp", "scatter")
_SCATTER_RATIONAL = pairs.pair_loop("float64", "rational", "scatter")


@numba.njit(parallel=True, cache=True, fastmath=pairs.FAST)
def soft_values(queries, sources, grid, gmin, radius, taper, rational, with_gradient):
    """Per query: Z = sum w e S, V = sum w e (S - S') g'(r) (q - x)/r and P = -sum w e S'
    with e = exp(-alpha (g - gmin)) and the taper S (pairs.Taper), so that ds/dq = V / Z at
    a fixed gmin and ds/dgmin = -P / Z (V may be left zero for phi = exp when
    ``with_gradient`` is false).  ``sources``: (xyz, w) sorted by the cells of ``grid``
    (cellgrid.Grid)."""
    n = queries.shape[0]
    unused = np.zeros(0)  # for a loop's argument its variant does not use
    Z = np.zeros(n)
    P = np.zeros(n)
    V = np.zeros((n, 3))
    xyz, w = sources
    xs, ys, zs = xyz[0], xyz[1], xyz[2]
    origin, cell, shape, start = grid
    none = (unused, unused)
    acc = (unused, unused, unused, unused)
    for i in numba.prange(n):
        qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
        x0, x1 = _cell_range(queries[i], radius[i], origin, cell, shape, 0)
        y0, y1 = _cell_range(queries[i], radius[i], origin, cell, shape, 1)
        base = gmin[i]
        z = 0.0
        p = 0.0
        vx = 0.0
        vy = 0.0
        vz = 0.0
        for ix in range(x0, x1 + 1):
            for iy in range(y0, y1 + 1):
                j0, j1 = _column(qx, qy, qz, radius[i], ix, iy, origin, cell, shape, start)
                src = (xs[j0:j1], ys[j0:j1], zs[j0:j1])
                if rational:
                    dz_, dvx, dvy, dvz, dp = _RATIONAL(qx, qy, qz, base, taper, 0.0, src,
                                                       w[j0:j1], none, acc)
                elif with_gradient:
                    dz_, dvx, dvy, dvz, dp = _SUMS(qx, qy, qz, base, taper, 0.0, src,
                                                   w[j0:j1], none, acc)
                else:
                    dz_, dvx, dvy, dvz, dp = _VALUES(qx, qy, qz, base, taper, 0.0, src,
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


@numba.njit(parallel=True, cache=True, fastmath=pairs.FAST)
def soft_source_gradient(queries, xyz, grid, gmin, radius, taper, rational, coef, nchunks):
    """Given coef_q = cotangent_q * mu_q / Z_q, accumulate per source (sorted order)
    A_s = sum_q coef_q e (S - S') g'(r) (q - x_s)/r   (columns 0-2) and
    B_s = sum_q coef_q e S                             (column 3),
    e = exp(-alpha (g - gmin_q)), S the taper (the shift's own derivative is the caller's).
    Queries are split in nchunks blocks with a buffer each, so the sums do not race
    and their order is fixed."""
    n = queries.shape[0]
    unused = np.zeros(0)  # for a loop's argument its variant does not use
    m = xyz.shape[1]
    buf = np.zeros((nchunks, 4, m))
    xs, ys, zs = xyz[0], xyz[1], xyz[2]
    origin, cell, shape, start = grid
    none = (unused, unused)
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        ax, ay, az, b = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        for i in range(k * size, min(n, (k + 1) * size)):
            a = coef[i]
            if a == 0.0:
                continue
            qx, qy, qz = queries[i, 0], queries[i, 1], queries[i, 2]
            x0, x1 = _cell_range(queries[i], radius[i], origin, cell, shape, 0)
            y0, y1 = _cell_range(queries[i], radius[i], origin, cell, shape, 1)
            base = gmin[i]
            for ix in range(x0, x1 + 1):
                for iy in range(y0, y1 + 1):
                    j0, j1 = _column(qx, qy, qz, radius[i], ix, iy, origin, cell, shape, start)
                    src = (xs[j0:j1], ys[j0:j1], zs[j0:j1])
                    acc = (ax[j0:j1], ay[j0:j1], az[j0:j1], b[j0:j1])
                    if rational:
                        _SCATTER_RATIONAL(qx, qy, qz, base, taper, a, src, unused, none, acc)
                    else:
                        _SCATTER(qx, qy, qz, base, taper, a, src, unused, none, acc)
    total = np.zeros((m, 4))
    for k in range(nchunks):
        for c in range(4):
            total[:, c] += buf[k, c]
    return total
