"""The values and the source gradient of phi = exp in one float32 sweep over the pairs
(``soft_values_scatter32``), for the terms whose sources move (target -> body and
body -> body): kernels32.py's pair arithmetic, each pair's exponential and taper kept for
the scatter.  At the bench's case the two terms took 0.24 + 0.19 s in two passes (kernels32's
soft_values32 then soft_source_gradient32), 0.19 + 0.16 s in one (docs/PERFORMANCE.md,
"float32 pair sums")."""

from __future__ import annotations

import numba
import numpy as np

from .kernels import _VECTOR
from .kernels32 import _CLAMP, _F, _TINY, _ZERO, _exp32, _spans, _summed, _taper32

# The values and the source gradient in one sweep (soft_values_scatter32): each pair's
# exponential and taper are kept, per query, in a buffer the size of its pairs (a few
# thousand floats: the cache holds them), and the scatter of the source gradient reads
# them back once the query's Z, and so its coefficient, is known.  The scatter then costs
# a few loads and stores per pair instead of a second distance, exponential and taper.

@numba.njit(cache=True, fastmath=_VECTOR)
def _cell_sums_kept(qx, qy, qz, base, alpha, cut, inv_width, xs, ys, zs, w, es, fs):
    """_cell_sums, keeping each pair's e S and e (S - S') / r (e without the weight)."""
    z = _ZERO
    p = _ZERO
    vx = _ZERO
    vy = _ZERO
    vz = _ZERO
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (r - base), _CLAMP)
        e = _exp32(-u)
        s, ds = _taper32(u, cut, inv_width)
        f = e * (s + ds) / max(r, _TINY)
        es[j] = e * s
        fs[j] = f
        z += w[j] * (e * s)
        p += w[j] * (e * ds)
        vx += w[j] * f * dx
        vy += w[j] * f * dy
        vz += w[j] * f * dz
    return z, vx, vy, vz, p


@numba.njit(cache=True, fastmath=_VECTOR)
def _cell_values_kept(qx, qy, qz, base, alpha, cut, inv_width, xs, ys, zs, w, es, fs):
    """_cell_values, keeping each pair's e S and e (S - S') / r (e without the weight)."""
    z = _ZERO
    p = _ZERO
    for j in range(xs.shape[0]):
        dx = qx - xs[j]
        dy = qy - ys[j]
        dz = qz - zs[j]
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        u = min(alpha * (r - base), _CLAMP)
        e = _exp32(-u)
        s, ds = _taper32(u, cut, inv_width)
        es[j] = e * s
        fs[j] = e * (s + ds) / max(r, _TINY)
        z += w[j] * (e * s)
        p += w[j] * (e * ds)
    return z, _ZERO, _ZERO, _ZERO, p


@numba.njit(cache=True, fastmath=_VECTOR)
def _cell_replay(qx, qy, qz, a, xs, ys, zs, es, fs, ax, ay, az, b):
    """_cell_scatter from the kept e S and e (S - S') / r of the pairs."""
    for j in range(xs.shape[0]):
        f = a * fs[j]
        b[j] += a * es[j]
        ax[j] += f * (qx - xs[j])
        ay[j] += f * (qy - ys[j])
        az[j] += f * (qz - zs[j])


@numba.njit(cache=True)
def _grown(buf, need):
    """``buf``, or a new buffer (its contents not kept) of at least twice its length when
    it holds fewer than ``need``."""
    if buf.shape[0] >= need:
        return buf
    return np.empty(max(need, 2 * buf.shape[0]), dtype=buf.dtype)


@numba.njit(parallel=True, cache=True)
def soft_values_scatter32(queries, local, box, w, origin, cell, shape, start, gmin, radius, alpha,
                          cut, width, with_gradient, qscale, beta, lshift, nchunks):
    """soft_values32 and soft_source_gradient32 in one sweep over the pairs, for phi = exp.

    The source gradient's coefficient of a query is known once its Z is: with
    d = gmin - (log Z + lshift) / alpha (``lshift`` = log(largest weight / total weight):
    Z is of the scaled weights) it is a = qscale d'^(beta - 1) / Z, d' = alpha max(d, tiny)
    (the caller's coef is a times factors common to all queries, applied by the caller;
    beta >= 1 keeps a in float32's range).  Queries are split in ``nchunks`` blocks, each
    with its float32 buffers of the source sums as in soft_source_gradient32."""
    n = queries.shape[0]
    m = local.shape[1]
    Z = np.zeros(n)
    P = np.zeros(n)
    V = np.zeros((n, 3))
    buf = np.zeros((nchunks, 4, m), dtype=np.float32)
    xs, ys, zs = local[0], local[1], local[2]
    a32, c32, iw32 = _F(alpha), _F(cut), _F(1.0 / width)
    tiny = np.finfo(np.float64).tiny
    size = (n + nchunks - 1) // nchunks
    for k in numba.prange(nchunks):
        ax, ay, az, b = buf[k, 0], buf[k, 1], buf[k, 2], buf[k, 3]
        es = np.empty(1 << 14, dtype=np.float32)
        fs = np.empty(1 << 14, dtype=np.float32)
        spans = np.empty((256, 2), dtype=np.int64)
        corners = np.empty((256, 3), dtype=np.float32)
        for i in range(k * size, min(n, (k + 1) * size)):
            q = queries[i]
            count, spans, corners = _spans(q, radius[i], origin, cell, shape, start, xs, box,
                                           spans, corners)
            pairs = 0
            for t in range(count):
                pairs += spans[t, 1] - spans[t, 0]
            if pairs > es.shape[0]:
                es = _grown(es, pairs)
                fs = _grown(fs, pairs)
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
                span = (xs[j0:j1], ys[j0:j1], zs[j0:j1], w[j0:j1], es[kept:end], fs[kept:end])
                if with_gradient:
                    dz_, dvx, dvy, dvz, dp = _cell_sums_kept(qx, qy, qz, base, a32, c32, iw32,
                                                             *span)
                else:
                    dz_, dvx, dvy, dvz, dp = _cell_values_kept(qx, qy, qz, base, a32, c32,
                                                               iw32, *span)
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
                _cell_replay(corners[t, 0], corners[t, 1], corners[t, 2], a, xs[j0:j1],
                             ys[j0:j1], zs[j0:j1], es[at:end], fs[at:end], ax[j0:j1],
                             ay[j0:j1], az[j0:j1], b[j0:j1])
                at = end
    return Z, V, P, _summed(buf)
