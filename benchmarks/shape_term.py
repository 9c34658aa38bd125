"""The shape term S and its gradient at the bench's state (not a test: it prints what it
measures).

    .venv/bin/python benchmarks/shape_term.py [--size 0.0125] [--repeat 10]

Builds the case `shapegrowth bench` measures at mesh size ``--size`` (scene 1, the growth
near its optimum, solved from rest: 50 715 DOFs and 38 448 + 38 448 points at 0.0125), then
times the debiased S = rho_H(B, T) - (rho_H(B, B) + rho_H(T, T)) / 2 with its gradient on
the state's clouds, as an iteration evaluates it (the target's own term computed once),
in float32 (what ``precision: auto`` takes there) and float64, and prints how far apart
the two are.  The numbers the comments in ``shape/`` quote as "S with its gradient at the
bench's 50k-DOF state" were measured this way.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from shapegrowth import config
from shapegrowth.commands import bench, launch
from shapegrowth.optim.problem import ReducedFunctional
from shapegrowth.physics.model import ForwardModel
from shapegrowth.shape.divergence import ShapeDivergence
from shapegrowth.shape.hausdorff import PointCloud, SmoothHausdorff
from shapegrowth.timing import Timer


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--size", type=float, default=0.0125)
    parser.add_argument("--repeat", type=int, default=10)
    args = parser.parse_args()
    cfg = config.load(launch.shipped_configs() / bench.DEFAULT_CONFIG,
                      [*bench.DEFAULT_OVERRIDES, f"mesh.size={args.size}"])
    rf = ReducedFunctional(ForwardModel.build(cfg), Timer())
    rf.evaluate(rf.current())  # the state from rest
    body = rf.objective.deformed()
    target = rf.objective.target
    h = cfg.objective.hausdorff
    print(f"mesh size {args.size}: {len(body.weights)} + {len(target.weights)} points, "
          f"alpha {h.alphas[0]:g}, cutoff {h.cutoff:g}")
    results = {}
    for precision in ("float32", "float64"):
        S = ShapeDivergence(SmoothHausdorff(alpha=h.alphas[0], beta=h.beta, gamma=h.gamma,
                                            cutoff=h.cutoff, taper=h.taper,
                                            precision=precision), h.form)
        S(PointCloud(body.points, body.weights), target)  # compiles; the target's own term
        seconds = []
        for _ in range(args.repeat):
            fresh = PointCloud(body.points, body.weights)  # nothing of the body kept
            tic = time.perf_counter()
            term = S(fresh, target)
            seconds.append(time.perf_counter() - tic)
        results[precision] = term
        print(f"  {precision}: S = {term.value:.10e}, with its gradient best "
              f"{min(seconds):.3f} s, median {np.median(seconds):.3f} s")
    single, double = results["float32"], results["float64"]
    assert single.grad_points is not None and double.grad_points is not None
    scale = np.abs(double.grad_points).max()
    print(f"  float32 against float64: S {abs(single.value - double.value) / double.value:.1e} "
          f"relative, gradient {np.abs(single.grad_points - double.grad_points).max() / scale:.1e}"
          f" of its largest component")


if __name__ == "__main__":
    main()
