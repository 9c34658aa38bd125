"""The values and the source gradient of phi = exp in one float32 sweep over the pairs
(``soft_values_scatter32``), for the terms whose sources move (target -> body and
body -> body): pairs.py's loops in float32, each pair's exponential and taper kept for
the scatter.  At the bench's case the two terms took 0.24 + 0.19 s in two passes (kernels32's
soft_values32 then soft_source_gradient32), 0.19 + 0.16 s in one (docs/PERFORMANCE.md,
"float32 pair sums")."""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from . import pairs
from .kernels32 import _F, _ZERO, _spans, _summed

# The values and the source gradient in one sweep (soft_values_scatter32): each pair's
# exponential and taper are kept, per query, in a buffer the size of its pairs (a few
# thousand floats: the cache holds them), and the scatter of the source gradient reads
# them back once the query's Z, and so its coefficient, is known.  The scatter then costs
# a few loads and stores per pair instead of a second distance, exponential and taper.
_SUMS_KEPT = pairs.pair_loop("float32", "exp", "sums_kept")
_VALUES_KEPT = pairs.pair_loop("float32", "exp", "values_kept")
_REPLAY = pairs.pair_loop("float32", "exp", "replay")


class Coefficient(NamedTuple):
    """What a query's coefficient in the source gradient is made of (float64):
    a = qscale d'^(beta - 1) / Z with d' = alpha max(d, tiny) and
    d = gmin - (log Z + lshift) / alpha."""

    qscale: np.ndarray  # per query
    alpha: float
    beta: float
    lshift: float


@numba.njit(cache=True)
def _grown(buf, need):
    """``buf``, or a new buffer (its contents not kept) of at least twice its length when
    it holds fewer than ``need``."""
    if buf.shape[0] >= need:
        return buf
    return np.empty(max(need, 2 * buf.shape[0]), dtype=buf.dtype)


@numba.njit(parallel=True, cache=True)
def soft_values_scatter32(queries, sources, grid, gmin, radius, taper, with_gradient, coef,
                          nchunks):
    """soft_values32 and soft_source_gradient32 in one sweep over the pairs, for phi = exp
    (``sources`` = (local, box, w) and ``taper`` as soft_values32's).

    The source gradient's coefficient of a query is known once its Z is (``coef``, a
    :class:`Coefficient`): with d = gmin - (log Z + lshift) / alpha (``lshift`` = log(largest
    weight / total weight): Z is of the scaled weights) it is a = qscale d'^(beta - 1) / Z,
    d' = alpha max(d, tiny)
    (the caller's coef is a times factors common to all queries, applied by the caller;
    beta >= 1 keeps a in float32's range).  Queries are split in ``nchunks`` blocks, each
    with its float32 buffers of the source sums as in soft_source_gradient32."""
    n = queries.shape[0]
    unused = np.zeros(0, dtype=np.float32)  # for a loop's argument its variant does not use
    local, box, w = sources
    m = local.shape[1]
    Z = np.zeros(n)
    P = np.zeros(n)
    V = np.zeros((n, 3))
    buf = np.zeros((nchunks, 4, m), dtype=np.float32)
    xs, ys, zs = local[0], local[1], local[2]
    qscale, alpha, beta, lshift = coef
    acc = (unused, unused, unused, unused)
    tiny = np.finfo(np.float64).tiny
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        ax, ay, az, b = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        es = np.empty(1 << 14, dtype=np.float32)
        fs = np.empty(1 << 14, dtype=np.float32)
        spans = np.empty((256, 2), dtype=np.int64)
        corners = np.empty((256, 3), dtype=np.float32)
        for i in range(k * size, min(n, (k + 1) * size)):
            count, spans, corners = _spans(queries[i], radius[i], grid, xs, box, spans,
                                           corners)
            npairs = 0
            for t in range(count):
                npairs += spans[t, 1] - spans[t, 0]
            if npairs > es.shape[0]:
                es = _grown(es, npairs)
                fs = _grown(fs, npairs)
            base = _F(gmin[i])
            z = 0.0
            p = 0.0
            vx = 0.0
            vy = 0.0
            vz = 0.0
            kept = 0
            for t in range(count):
                j0, j1 = spans[t, 0], spans[t, 1]
                qx, qy, qz = corners[t, 0], corners[t, 1], corners[t, 2]
                end = kept + j1 - j0
                src = (xs[j0:j1], ys[j0:j1], zs[j0:j1])
                keep = (es[kept:end], fs[kept:end])
                if with_gradient:
                    dz_, dvx, dvy, dvz, dp = _SUMS_KEPT(qx, qy, qz, base, taper, _ZERO, src,
                                                        w[j0:j1], keep, acc)
                else:
                    dz_, dvx, dvy, dvz, dp = _VALUES_KEPT(qx, qy, qz, base, taper, _ZERO, src,
                                                          w[j0:j1], keep, acc)
                z += dz_
                p += dp
                vx += dvx
                vy += dvy
                vz += dvz
                kept = end
            Z[i] = z
            P[i] = p
            V[i, 0] = vx
            V[i, 1] = vy
            V[i, 2] = vz
            d = gmin[i] - (np.log(z) + lshift) / alpha
            a = _F(qscale[i] * (alpha * max(d, tiny)) ** (beta - 1.0) / z)
            if a == _ZERO:
                continue
            at = 0
            for t in range(count):
                j0, j1 = spans[t, 0], spans[t, 1]
                end = at + j1 - j0
                _REPLAY(corners[t, 0], corners[t, 1], corners[t, 2], base, taper, a,
                        (xs[j0:j1], ys[j0:j1], zs[j0:j1]), unused, (es[at:end], fs[at:end]),
                        (ax[j0:j1], ay[j0:j1], az[j0:j1], b[j0:j1]))
                at = end
    return Z, V, P, _summed(buf)
