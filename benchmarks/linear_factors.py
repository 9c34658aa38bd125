"""The state tangent's factor by each direct preset on a config's mesh: MUMPS's own memory
(INFOG(22), MB effectively used, all ranks) and factor entries (INFOG(29); INFOG(35) after
block low-rank compression), the time to factor and to solve, and the relative residual of
one solve (docs/PERFORMANCE.md, "Linear solvers").

    mpirun -n 2 .venv/bin/python benchmarks/linear_factors.py CONFIG [--refine N]
        [--set KEY=VALUE ...] [--presets mumps,mumps_ldlt,mumps_blr] [--analyse]

With ``--analyse`` nothing is factored: MUMPS's analysis alone gives what the factorisation
would need, for a mesh too large to factor here (the check a run's refined-twice
verification would make; ``shapegrowth.physics.linear.analyse``): the factor's entries
(INFOG(3)), the working memory in core and out of core (INFOG(16)/(17), INFOG(26)/(27): the
largest rank's and all ranks' MB) and the elimination's flops (RINFOG(1)).  A factorisation
prints the same estimates beside what it took, and its flops (RINFOG(3)), so that a
measured rate (flops per second of ``factor_s``) can be set against a larger mesh's
analysis.

The tangent is the one at rest (C_g = I: the pattern and the fill of every tangent of the
model); one JSON line per preset on rank 0.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

from mpi4py import MPI

from shapegrowth import compat
from shapegrowth.config import load
from shapegrowth.physics import linear
from shapegrowth.physics.model import ForwardModel


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config")
    parser.add_argument("--refine", type=int, default=0)
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--presets", default="mumps,mumps_ldlt,mumps_blr")
    parser.add_argument("--analyse", action="store_true",
                        help="MUMPS's analysis alone: its estimates, nothing factored")
    args = parser.parse_args()
    cfg = load(args.config, [*args.set, f"mesh.refine={args.refine}"])
    state = ForwardModel.build(cfg).state
    A = state.A
    state.assemble_tangent(compat.petsc_vec(state.u), A)
    b, x, r = A.createVecRight(), A.createVecRight(), A.createVecRight()
    b.set(1.0)
    comm = MPI.COMM_WORLD
    for name in args.presets.split(","):
        row: dict[str, object] = {"config": args.config, "refine": args.refine, "preset": name,
                                  "dofs": A.getSize()[0], "ranks": comm.size}
        if args.analyse:  # the analysis alone (linear.analyse), nothing factored
            tic = time.perf_counter()
            estimate = linear.analyse(A, name)
            row |= {"analysis_s": round(time.perf_counter() - tic, 3),
                    **dataclasses.asdict(estimate)}
            if comm.rank == 0:
                print(json.dumps(row), flush=True)
            continue
        with linear.preset_ksp(A, name, "factors_") as ksp:  # the factor
            tic = time.perf_counter()
            ksp.setUp()
            factor_s = time.perf_counter() - tic
            tic = time.perf_counter()
            ksp.solve(b, x)
            solve_s = time.perf_counter() - tic
            F = ksp.getPC().getFactorMatrix()
            row |= {"factor_mb": F.getMumpsInfog(22), "factor_entries": F.getMumpsInfog(29),
                    "compressed_entries": F.getMumpsInfog(35), "ordering": F.getMumpsInfog(7),
                    "factor_s": round(factor_s, 3), "solve_s": round(solve_s, 4),
                    "factor_flops": F.getMumpsRinfog(3),
                    "estimate": dataclasses.asdict(linear.factor_estimate(F))}
        A.mult(x, r)
        r.axpy(-1.0, b)
        row["relative_residual"] = r.norm() / b.norm()
        if comm.rank == 0:
            print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
