"""Benchmark of the rho_H kernels (not a test: it prints what it measures).

    .venv/bin/python benchmarks/hausdorff.py [--sizes 10000 100000]

Brute-force pair throughput of each kernel, and value + gradient of rho_H for
two beam-like clouds (1 x 0.1 x 0.02) at alpha * size = 1000, near (1e-3 apart,
as close to an optimum) and far (flat beam against the wave target of scene 1).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from shapegrowth.shape import cellgrid, kernels, pairs
from shapegrowth.shape.hausdorff import PointCloud, SmoothHausdorff

RNG = np.random.default_rng(2)


def beam(n: int, wave: float = 0.0, noise: float = 0.0) -> PointCloud:
    p = RNG.random((n, 3)) * [1.0, 0.1, 0.02] - [0, 0.05, 0.01]
    p[:, 2] += wave * np.sin(2 * np.pi * p[:, 0]) + noise * RNG.standard_normal(n)
    return PointCloud(p, np.full(n, 0.002 / n))


def timed(fn, repeat: int = 2) -> float:
    fn()  # compile / warm up
    best = np.inf
    for _ in range(repeat):
        tic = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - tic)
    return best


def throughput(n: int = 20000) -> None:
    a, b = beam(n), beam(n, wave=0.15)
    grid = cellgrid.SourceGrid.build(a.points, a.weights, None)
    q = cellgrid.as3(b.points)
    gmin = np.zeros(n)
    radius = np.full(n, np.inf)
    taper = pairs.Taper.of(1000.0, kernels.CUTOFF, kernels.TAPER)
    args = (q, (grid.xyz, grid.weights), grid.cells, gmin, radius, taper, False, True)
    t_val = timed(lambda: kernels.soft_values(*args))
    src = (q, grid.xyz, grid.cells, gmin, radius, taper, False, np.ones(n), 8)
    t_src = timed(lambda: kernels.soft_source_gradient(*src))
    print(f"brute force, {n} x {n} pairs, float64:")
    print(f"  values + query gradients: {n * n / t_val:.3g} pairs/s")
    print(f"  source gradients:         {n * n / t_src:.3g} pairs/s")


def rho(sizes: list[int]) -> None:
    H = SmoothHausdorff(alpha=1000.0)
    print(f"rho_H value + gradient, alpha * size = 1000, cutoff exp(-{kernels.CUTOFF:g}):")
    for n in sizes:
        for label, (a, b) in {"near": (beam(n), beam(n, noise=1e-3)),
                              "far": (beam(n), beam(n, wave=0.15))}.items():
            # a fresh body cloud per call, as in an optimisation (the target's KD-tree is
            # built once and kept)
            t = timed(lambda: H(PointCloud(a.points, a.weights), b), repeat=1)
            brute = ""
            if n <= 20000:
                brute_force = SmoothHausdorff(alpha=1000.0, truncate=False)
                tb = timed(lambda: brute_force(PointCloud(a.points, a.weights), b), repeat=1)
                brute = f"   (brute force {tb:.3f} s, {tb / t:.1f}x slower)"
            print(f"  n = m = {n:>6} {label:>4}: {t:.3f} s{brute}")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[10000, 100000])
    args = parser.parse_args()
    throughput()
    rho(args.sizes)
