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
the last e-folds before c (_taper), so the sum is a C^1 function of the points whichever
pairs the grid skips, and the brute force (a single cell) gives the same numbers.
For phi = exp the pair loops vectorise (AVX-512 here): exp is written out as
arithmetic (_exp) and the sums may be reassociated.  Measured brute-force
throughput on this 2-core machine (benchmarks/hausdorff.py): 1.19e9 pairs/s for
values with query gradients, 1.12e9 for source gradients, against 3.6e8 and 3.4e8
with libm's scalar exp.
"""

from __future__ import annotations

import math
import os

import numba
import numpy as np
from llvmlite import ir
from mpi4py import MPI
from numba.core import types
from numba.extending import intrinsic

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


# Pair loops of phi = exp are vectorised: "reassoc" lets LLVM split the sums over
# SIMD lanes and _exp below is plain arithmetic, so no libm call stays in the loop
# (with libm's scalar exp, packing and unpacking the lanes made the vector loop 2.6x
# slower than the scalar one).  No nnan/ninf: inputs stay checked.  The rational phi
# needs log1p from libm and keeps the scalar loop.
_FAST = {"contract", "arcp", "afn"}
_VECTOR = _FAST | {"reassoc"}


_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # ln 2 split in two (Cody-Waite): n * _LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10


@intrinsic
def _bits_as_float(typingctx, bits):
    """Reinterpret an int64 bit pattern as a float64 (vectorises to a no-op)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return types.float64(types.int64), codegen


@numba.njit(cache=True, fastmath=_VECTOR, inline="always")
def _exp(x):
    """exp(x) for -700 <= x <= 0 in arithmetic that vectorises: x = n ln2 + r with
    |r| <= ln2 / 2, exp(r) by its Taylor polynomial of degree 12 (remainder < 2e-16),
    2^n built in the exponent bits.  Max relative error 4.4e-16 on [-100, 0]
    (tests/test_hausdorff.py).  The polynomial is evaluated by Estrin's scheme: its
    short dependency chains need fewer live vector registers than Horner's rule
    (value + gradient pair loop: 1.19e9 against 0.90e9 pairs/s)."""
    n = math.floor(x * _LOG2E + 0.5)
    r = (x - n * _LN2_HI) - n * _LN2_LO
    r2 = r * r
    r4 = r2 * r2
    p01 = 1.0 + r
    p23 = 1.0 / 2.0 + r * (1.0 / 6.0)
    p45 = 1.0 / 24.0 + r * (1.0 / 120.0)
    p67 = 1.0 / 720.0 + r * (1.0 / 5040.0)
    p89 = 1.0 / 40320.0 + r * (1.0 / 362880.0)
    p1011 = 1.0 / 3628800.0 + r * (1.0 / 39916800.0)
    p03 = p01 + r2 * p23
    p47 = p45 + r2 * p67
    p811 = p89 + r2 * p1011
    p812 = p811 + r4 * (1.0 / 479001600.0)
    p = (p03 + r4 * p47) + (r4 * r4) * p812
    return p * _bits_as_float((int(n) + 1023) << 52)  # a numba intrinsic


@numba.njit(cache=True)
def exp_array(x):
    """_exp over an array (for its accuracy test)."""
    out = np.empty_like(x)
    for i in range(x.shape[0]):
        out[i] = _exp(x[i])
    return out


@numba.njit(cache=True, fastmath=_VECTOR, inline="always")
def _taper(u, cut, inv_width):
    """The smooth cutoff S(u) and -dS/du: S = 1 up to u = cut - width, 0 from u = cut, the
    cubic smoothstep between: continuously differentiable with a bounded second derivative,
    so J stays C^1 with a Lipschitz gradient (what a Taylor test's rate 2 needs); branch-free
    so the pair loops still vectorise (the quintic, C^2, cost 2-6 % more per pair)."""
    t = min(max((cut - u) * inv_width, 0.0), 1.0)
    s = t * t * (3.0 - 2.0 * t)
    ds = 6.0 * t * (1.0 - t) * inv_width  # -dS/du
    return s, ds


@numba.njit(cache=True)
def taper_array(u, cut, width):
    """S(u) and -dS/du over an array (for its tests)."""
    s = np.empty_like(u)
    ds = np.empty_like(u)
    for i in range(u.shape[0]):
        s[i], ds[i] = _taper(u[i], cut, 1.0 / width)
    return s, ds


# Each pair gives e = w exp(-u), u = alpha (g(r) - base) clamped at 100, with
# g(r) = r (exp) or log(1 + r) (rational), and the taper's S(u) and -dS/du.  The sums are
#   Z = sum e S,   P = sum e (-dS/du),   V = sum e (S - dS/du) g'(r) (q - x) / r,
# so that ds/dq = V / Z at a fixed shift and ds/d(base) = -P / Z.  r = 0 only where
# dx = dy = dz = 0, so 1 / max(r, tiny) multiplies zeros there.  The loops run over
# slices: with bounds loaded from the grid's offsets LLVM did not vectorise them.  The
# four pair loops below are spelled out one by one on purpose: each must be a single flat
# loop with its own fastmath flags for LLVM to vectorise it (a shared helper with a
# branch or a callback inside the loop kept it scalar).

@numba.njit(cache=True, fastmath=_VECTOR)
def _span_exp(qx, qy, qz, base, alpha, cut, inv_width, xs, ys, zs, w):
    """Sums over the given sources: Z, V and P (see soft_values)."""
    z = 0.0
    p = 0.0
    vx = 0.0
    vy = 0.0
    vz = 0.0
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (r - base), 100.0)
        e = w[j] * _exp(-u)
        s, ds = _taper(u, cut, inv_width)
        z += e * s
        p += e * ds
        f = e * (s + ds) / max(r, 1e-300)
        vx += f * dx
        vy += f * dy
        vz += f * dz
    return z, vx, vy, vz, p


@numba.njit(cache=True, fastmath=_VECTOR)
def _span_exp_value(qx, qy, qz, base, alpha, cut, inv_width, xs, ys, zs, w):
    """Z and P alone (for queries that are not design points: no V needed)."""
    z = 0.0
    p = 0.0
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (r - base), 100.0)
        e = w[j] * _exp(-u)
        s, ds = _taper(u, cut, inv_width)
        z += e * s
        p += e * ds
    return z, 0.0, 0.0, 0.0, p


@numba.njit(cache=True, fastmath=_FAST)
def _span_rational(qx, qy, qz, base, alpha, cut, inv_width, xs, ys, zs, w):
    z = 0.0
    p = 0.0
    vx = 0.0
    vy = 0.0
    vz = 0.0
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (math.log1p(r) - base), 100.0)
        e = w[j] * math.exp(-u)
        s, ds = _taper(u, cut, inv_width)
        z += e * s
        p += e * ds
        f = e * (s + ds) / (max(r, 1e-300) * (1.0 + r))
        vx += f * dx
        vy += f * dy
        vz += f * dz
    return z, vx, vy, vz, p


@numba.njit(cache=True, fastmath=_VECTOR)
def _scatter_exp(qx, qy, qz, base, alpha, cut, inv_width, a, xs, ys, zs, ax, ay, az, b):
    """The transpose of _span_exp over the given sources."""
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (r - base), 100.0)
        e = a * _exp(-u)
        s, ds = _taper(u, cut, inv_width)
        f = e * (s + ds) / max(r, 1e-300)
        b[j] += e * s
        ax[j] += f * dx
        ay[j] += f * dy
        az[j] += f * dz


@numba.njit(cache=True, fastmath=_FAST)
def _scatter_rational(qx, qy, qz, base, alpha, cut, inv_width, a, xs, ys, zs, ax, ay, az, b):
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = math.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (math.log1p(r) - base), 100.0)
        e = a * math.exp(-u)
        s, ds = _taper(u, cut, inv_width)
        f = e * (s + ds) / (max(r, 1e-300) * (1.0 + r))
        b[j] += e * s
        ax[j] += f * dx
        ay[j] += f * dy
        az[j] += f * dz


@numba.njit(parallel=True, cache=True, fastmath=_FAST)
def soft_values(queries, xyz, w, origin, cell, shape, start, gmin, radius, alpha, cut, width,
                rational, with_gradient):
    """Per query: Z = sum w e S, V = sum w e (S - S') g'(r) (q - x)/r and P = -sum w e S'
    with e = exp(-alpha (g - gmin)) and the taper S over the last ``width`` of ``cut``
    (see _taper), so that ds/dq = V / Z at a fixed gmin and ds/dgmin = -P / Z (V may be
    left zero for phi = exp when ``with_gradient`` is false)."""
    n = queries.shape[0]
    Z = np.zeros(n)
    P = np.zeros(n)
    V = np.zeros((n, 3))
    xs, ys, zs = xyz[0], xyz[1], xyz[2]
    inv_width = 1.0 / width
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
                span = (xs[j0:j1], ys[j0:j1], zs[j0:j1], w[j0:j1])
                if rational:
                    dz_, dvx, dvy, dvz, dp = _span_rational(qx, qy, qz, base, alpha, cut,
                                                            inv_width, *span)
                elif with_gradient:
                    dz_, dvx, dvy, dvz, dp = _span_exp(qx, qy, qz, base, alpha, cut,
                                                       inv_width, *span)
                else:
                    dz_, dvx, dvy, dvz, dp = _span_exp_value(qx, qy, qz, base, alpha, cut,
                                                             inv_width, *span)
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


@numba.njit(parallel=True, cache=True, fastmath=_FAST)
def soft_source_gradient(queries, xyz, origin, cell, shape, start, gmin, radius, alpha, cut,
                         width, rational, coef, nchunks):
    """Given coef_q = cotangent_q * mu_q / Z_q, accumulate per source (sorted order)
    A_s = sum_q coef_q e (S - S') g'(r) (q - x_s)/r   (columns 0-2) and
    B_s = sum_q coef_q e S                             (column 3),
    e = exp(-alpha (g - gmin_q)), S the taper (the shift's own derivative is the caller's).
    Queries are split in nchunks blocks with a buffer each, so the sums do not race
    and their order is fixed."""
    n = queries.shape[0]
    m = xyz.shape[1]
    buf = np.zeros((nchunks, 4, m))
    xs, ys, zs = xyz[0], xyz[1], xyz[2]
    inv_width = 1.0 / width
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
                    span = (xs[j0:j1], ys[j0:j1], zs[j0:j1], ax[j0:j1], ay[j0:j1], az[j0:j1],
                            b[j0:j1])
                    if rational:
                        _scatter_rational(qx, qy, qz, base, alpha, cut, inv_width, a, *span)
                    else:
                        _scatter_exp(qx, qy, qz, base, alpha, cut, inv_width, a, *span)
    total = np.zeros((m, 4))
    for k in range(nchunks):
        for c in range(4):
            total[:, c] += buf[k, c]
    return total
