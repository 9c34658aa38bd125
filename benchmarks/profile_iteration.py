"""cProfile of one optimisation iteration (not a test: it prints what it measures).

    .venv/bin/python benchmarks/profile_iteration.py [--size 0.025] [--set KEY=VALUE ...]

Scene 1 (configs/beam_wave.yaml) with the growth near its optimum that
``shapegrowth bench`` uses: the state is solved once, then one design step of 1 %
is evaluated (J and dJ/dm) under cProfile.  Compare ``--set solver.adjoint_reuse=false``
(the adjoint assembles and factors the tangent anew) with the default.
"""

from __future__ import annotations

import argparse
import cProfile
import io
import pstats

import numpy as np

from shapegrowth.commands import bench, launch
from shapegrowth.config import load
from shapegrowth.optim.problem import ReducedFunctional
from shapegrowth.optim.taylor import smooth_direction
from shapegrowth.physics.boundary import body_box
from shapegrowth.physics.model import ForwardModel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.025)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    parser.add_argument("--top", type=int, default=14)
    args = parser.parse_args()
    cfg = load(launch.shipped_configs() / bench.DEFAULT_CONFIG,
               bench.DEFAULT_OVERRIDES + [f"mesh.size={args.size}"] + args.overrides)
    model = ForwardModel.build(cfg)
    rf = ReducedFunctional(model)
    m = rf.current()
    rf.evaluate(m)
    lo, hi = body_box(model.domain.mesh)
    step = 0.01 * smooth_direction(rf.design_coordinates(), 1, float((hi - lo).max()))
    profile = cProfile.Profile()
    profile.enable()
    rf.evaluate(m * (1.0 + step))
    profile.disable()
    out = io.StringIO()
    stats = pstats.Stats(profile, stream=out).sort_stats("tottime")
    stats.print_stats(args.top)
    total = stats.get_stats_profile().total_tt  # every function's own time added up
    print(f"one iteration at mesh size {args.size} ({np.sum(rf.size)} design DOFs here), "
          f"{total:.3f} s of profiled time, by own time:")
    print("\n".join(line for line in out.getvalue().splitlines()[6:] if line.strip()))


if __name__ == "__main__":
    main()
