"""What float32 pair sums would do to rho_H (not a test: it prints what it measures).

    .venv/bin/python benchmarks/hausdorff_float32.py [--points 6000] [--alpha 200]

The kernels are float64.  float32 would double the lanes of a vector (16 instead of 8
with AVX-512), so this measures the error it would bring before anyone builds it: the
soft distances s_i = -(1/alpha) log(sum_j w_j exp(-alpha r_ij) / W) of a beam-like cloud
(1 x 0.1 x 0.02) to a wave-like one, by brute force in numpy, once with coordinates,
distances, exponentials and sums in float64 and once in float32 (coordinates rounded to
float32 as a float32 kernel would read them; sums accumulated in float32 per block of
sources, as a vectorised loop would), and the change of rho_H's directed mean and of the
step a Taylor test sees.
"""

from __future__ import annotations

import argparse

import numpy as np

RNG = np.random.default_rng(3)


def cloud(n: int, wave: float) -> tuple[np.ndarray, np.ndarray]:
    p = RNG.random((n, 3)) * [1.0, 0.1, 0.02] - [0, 0.05, 0.01]
    p[:, 2] += wave * np.sin(2 * np.pi * p[:, 0])
    return p, np.full(n, 0.002 / n)


def soft(q: np.ndarray, s: np.ndarray, w: np.ndarray, alpha: float, dtype) -> np.ndarray:
    q, s, w = q.astype(dtype), s.astype(dtype), w.astype(dtype)
    out = np.empty(len(q), dtype=np.float64)
    for i0 in range(0, len(q), 256):
        r = np.sqrt(((q[i0:i0 + 256, None, :] - s[None, :, :]) ** 2).sum(-1, dtype=dtype))
        gmin = r.min(axis=1, keepdims=True)
        z = (w[None, :] * np.exp(-dtype(alpha) * (r - gmin))).sum(axis=1, dtype=dtype)
        out[i0:i0 + 256] = gmin[:, 0].astype(np.float64) \
            - np.log(z.astype(np.float64) / w.astype(np.float64).sum()) / alpha
    return out


def mean(d: np.ndarray, beta: float = 2.0) -> float:
    return float(np.mean(d**beta) ** (1 / beta))


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--points", type=int, default=6000)
    parser.add_argument("--alpha", type=float, default=200.0)
    args = parser.parse_args()
    body, wb = cloud(args.points, 0.14)
    target, _ = cloud(args.points, 0.15)
    d64 = soft(body, target, wb, args.alpha, np.float64)
    d32 = soft(body, target, wb, args.alpha, np.float32)
    D64, D32 = mean(d64), mean(d32)
    print(f"{args.points} + {args.points} points, alpha {args.alpha:g}:")
    print(f"  soft distances: max |float32 - float64| = {np.abs(d32 - d64).max():.2e} "
          f"(the distances are ~{np.median(d64):.2e})")
    print(f"  directed mean D: {D64:.10e} (float64), relative change {abs(D32 - D64) / D64:.2e}")
    moved = body.copy()
    for h in (1e-3, 1e-4, 1e-5):
        moved[:, 2] = body[:, 2] + h * np.sin(np.pi * body[:, 0])
        step64 = mean(soft(moved, target, wb, args.alpha, np.float64)) - D64
        step32 = mean(soft(moved, target, wb, args.alpha, np.float32)) - D32
        print(f"  a step of {h:.0e}: D changes by {step64:.3e} (float64), "
              f"float32 error in that change {abs(step32 - step64) / abs(step64):.1e} of it")


if __name__ == "__main__":
    main()
