"""The pair loops of the smooth Hausdorff distance (2.9), from one template.

For a query q, a source x at r = |q - x| and the shift g_min of the query's soft minimum,
a pair gives e = exp(-u), u = alpha (g(r) - g_min) clamped, g(r) = r (phi = exp) or
log(1 + r) (phi = rational), and the taper's S(u) and -dS/du (:func:`taper_of`).  A query
gathers over its sources

    Z = sum w e S,   P = sum w e (-dS/du),   V = sum w e (S - dS/du) g'(r) (q - x) / r,

so that ds/dq = V / Z at a fixed shift and ds/dg_min = -P / Z; the source gradient
scatters the transpose, A_x += a e (S - dS/du) g'(r) (q - x) / r and B_x += a e S, with the
query's coefficient a.  :func:`pair_loop` writes that loop once; the variant is fixed
when numba compiles it (each flag a constant of the closure, its dead branches pruned):

- ``precision``: "float64" or "float32" (kernels32.py: offsets from a cell's corner,
  exp by a polynomial of degree 7, 16 lanes of a 512-bit vector);
- ``phi``: "exp" (exp written as arithmetic, so the loop vectorises: :func:`exp64`) or
  "rational" (libm's log1p and exp: a scalar loop; float64 only);
- ``mode``: "sums" (Z, V, P), "values" (Z, P: queries that do not move), "scatter" (the
  transpose), "sums_kept" and "values_kept" (the gathers, each pair's e S and
  e (S - dS/du) / r kept without its weight) and "replay" (the scatter from what was kept:
  sweep32.py).

Each variant is one flat loop with its own fastmath flags, which LLVM vectorises (a shared
helper with a runtime branch or a callback inside the loop kept it scalar); numba caches
each variant on disk, its flags in the cache's key.  The taper and the pair's arithmetic
constants travel as a :class:`Taper` record, the sources and the sums as tuples of arrays.
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any, NamedTuple

import numba
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

# Pair loops of phi = exp are vectorised: "reassoc" lets LLVM split the sums over SIMD
# lanes and the exponential is plain arithmetic, so no libm call stays in the loop (with
# libm's scalar exp, packing and unpacking the lanes made the vector loop 2.6x slower than
# the scalar one).  No nnan/ninf: inputs stay checked.  The rational phi needs log1p from
# libm and keeps the scalar loop.
FAST = {"contract", "arcp", "afn"}
VECTOR = FAST | {"reassoc"}

MODES = ("sums", "values", "scatter", "sums_kept", "values_kept", "replay")

_LOG2E = 1.4426950408889634
_LN2_HI = 6.93147180369123816490e-01  # ln 2 split in two (Cody-Waite): n * _LN2_HI is exact
_LN2_LO = 1.90821492927058770002e-10
_F32 = np.float32
_LOG2E_32 = _F32(1.4426950408889634)
_LN2_HI_32 = _F32(0.693359375)  # ln 2 = _LN2_HI_32 + _LN2_LO_32, with 9 bits: n * hi exact
_LN2_LO_32 = _F32(-2.12194440e-4)
_HALF_32, _ONE_32 = _F32(0.5), _F32(1)
_C2, _C3, _C4, _C5, _C6, _C7 = (_F32(1 / 2), _F32(1 / 6), _F32(1 / 24), _F32(1 / 120),
                                _F32(1 / 720), _F32(1 / 5040))


@intrinsic
def _bits_as_float(typingctx, bits):
    """Reinterpret an int64 bit pattern as a float64 (vectorises to a no-op)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())
    return types.float64(types.int64), codegen


@intrinsic
def _bits_as_float32(typingctx, bits):
    """Reinterpret an int32 bit pattern as a float32 (vectorises to a no-op)."""
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.FloatType())
    return types.float32(types.int32), codegen


@numba.njit(cache=True, fastmath=VECTOR, inline="always")
def exp64(x):
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


@numba.njit(cache=True, fastmath=VECTOR, inline="always")
def exp32(x):
    """exp(x) for -80 <= x <= 0 in float32 arithmetic: x = n ln2 + r, |r| <= ln2 / 2, exp(r)
    by its Taylor polynomial of degree 7 (remainder < 6e-9), 2^n in the exponent bits.
    np.floor, not math.floor: numba's math.floor returns an int64 and the polynomial then
    ran in float64 (1.25x over the float64 loop instead of 2.5x)."""
    n = np.floor(x * _LOG2E_32 + _HALF_32)
    r = (x - n * _LN2_HI_32) - n * _LN2_LO_32
    r2 = r * r
    p = (_ONE_32 + r) + r2 * ((_C2 + r * _C3) + r2 * ((_C4 + r * _C5) + r2 * (_C6 + r * _C7)))
    return p * _bits_as_float32((np.int32(n) + np.int32(127)) << np.int32(23))


@cache
def taper_of(precision: str):
    """The smooth cutoff S(u) and -dS/du in the precision named: S = 1 up to u = cut - width,
    0 from u = cut, the cubic smoothstep between: continuously differentiable with a bounded
    second derivative, so J stays C^1 with a Lipschitz gradient (what a Taylor test's rate 2
    needs); branch-free so the pair loops still vectorise (the quintic, C^2, cost 2-6 % more
    per pair)."""
    F = np.float32 if precision == "float32" else np.float64
    ZERO, ONE, TWO, THREE, SIX = F(0), F(1), F(2), F(3), F(6)

    @numba.njit(cache=True, fastmath=VECTOR, inline="always")
    def taper(u, cut, inv_width):
        t = min(max((cut - u) * inv_width, ZERO), ONE)
        s = t * t * (THREE - TWO * t)
        ds = SIX * t * (ONE - t) * inv_width  # -dS/du
        return s, ds

    return taper


class Taper(NamedTuple):
    """What every pair of a sweep shares: alpha of (2.9), the cutoff c (in e-folds of the
    nearest term) and 1 / the taper's width, in the loop's precision."""

    alpha: Any
    cut: Any
    inv_width: Any

    @classmethod
    def of(cls, alpha: float, cut: float, width: float, precision: str = "float64") -> Taper:
        f = np.float32 if precision == "float32" else np.float64
        return cls(f(alpha), f(cut), f(1.0 / width))


@cache
def pair_loop(precision: str, phi: str, mode: str):
    """The loop over one span of sources for the variant named (see the module's text):

        z, vx, vy, vz, p = loop(qx, qy, qz, base, taper, a, (xs, ys, zs), w, (es, fs),
                                (ax, ay, az, b))

    ``base`` is the query's g_min; ``a`` the scatter's coefficient (unused by a gather);
    ``w`` the sources' weights (unused by a scatter); ``(es, fs)`` the kept e S and
    e (S - dS/du) / r (written by the kept gathers, read by the replay); the scatter and
    the replay add to ``(ax, ay, az, b)``.  A gather returns its sums, the others zeros.
    An argument a variant does not use may be any array of the precision's type."""
    if precision not in ("float64", "float32") or phi not in ("exp", "rational") \
            or mode not in MODES or (phi == "rational" and precision == "float32"):
        raise ValueError(f"no pair loop for {precision}, {phi}, {mode}")
    single = precision == "float32"
    F = np.float32 if single else np.float64
    ZERO, ONE = F(0.0), F(1.0)
    CLAMP = F(80.0) if single else F(100.0)  # exp(-80) is a normal float32
    TINY = F(1e-30) if single else F(1e-300)
    EXP = exp32 if single else (exp64 if phi == "exp" else math.exp)
    TAPER = taper_of(precision)
    RATIONAL = phi == "rational"
    REPLAY = mode == "replay"
    KEEP = mode in ("sums_kept", "values_kept")
    SCATTER = mode == "scatter"
    GRADIENT = mode in ("sums", "sums_kept")

    @numba.njit(cache=True, fastmath=FAST if RATIONAL else VECTOR)
    def loop(qx, qy, qz, base, taper, a, src, w, kept, acc):
        alpha, cut, inv_width = taper
        xs, ys, zs = src
        es, fs = kept
        ax, ay, az, b = acc
        z = ZERO
        p = ZERO
        vx = ZERO
        vy = ZERO
        vz = ZERO
        for j in range(xs.shape[0]):
            dx = qx - xs[j]
            dy = qy - ys[j]
            dz = qz - zs[j]
            if REPLAY:
                f = a * fs[j]
                b[j] += a * es[j]
                ax[j] += f * dx
                ay[j] += f * dy
                az[j] += f * dz
            else:
                r = np.sqrt(dx * dx + dy * dy + dz * dz)
                if RATIONAL:
                    u = min(alpha * (math.log1p(r) - base), CLAMP)
                    den = max(r, TINY) * (ONE + r)
                else:
                    u = min(alpha * (r - base), CLAMP)
                    den = max(r, TINY)
                if SCATTER:
                    e = a * EXP(-u)
                elif KEEP:
                    e = EXP(-u)
                else:
                    e = w[j] * EXP(-u)
                s, ds = TAPER(u, cut, inv_width)
                if KEEP:
                    f = e * (s + ds) / den
                    es[j] = e * s
                    fs[j] = f
                    z += w[j] * (e * s)
                    p += w[j] * (e * ds)
                    if GRADIENT:
                        vx += w[j] * f * dx
                        vy += w[j] * f * dy
                        vz += w[j] * f * dz
                elif SCATTER:
                    f = e * (s + ds) / den
                    b[j] += e * s
                    ax[j] += f * dx
                    ay[j] += f * dy
                    az[j] += f * dz
                else:
                    z += e * s
                    p += e * ds
                    if GRADIENT:
                        f = e * (s + ds) / den
                        vx += f * dx
                        vy += f * dy
                        vz += f * dz
        return z, vx, vy, vz, p

    return loop
