"""The p-multigrid's iterations against the mesh size and the number of ranks
(docs/PERFORMANCE.md, "A p-multigrid for solid bodies").

    mpirun -n N [--oversubscribe] .venv/bin/python benchmarks/pmg_iterations.py [--cells 4,8,16]

Linear elasticity in a clamped unit cube of n cells a side (tests/test_pmultigrid.py's
problem), P2 on tetrahedra and Q2 on hexahedra, solved to 1e-10 by the ``pmg`` preset with
its coarse level by GAMG and factorised, and by the ``gamg`` preset on the P2 matrix.  One
JSON line per case on rank 0: the cells, n, the DOFs, the ranks, the three iteration counts
and, from PETSc's log, each rank's work in the first (the coarse operator P^T A P and the
solve, its set-up included): Mflop, messages sent, MB sent and global reductions, the
largest over the ranks and their mean.  Ranks beyond the cores (``--oversubscribe``)
count iterations and work, not time.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpi4py import MPI
from petsc4py import PETSc

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_pmultigrid import clamped_cube_elasticity, krylov_iterations  # noqa: E402

EVENTS = ("MatPtAP", "KSPSolve")  # the coarse operator, and the solve with its set-up
FIELDS = {"flops": ("mflop", 1e-6), "numMessages": ("messages", 1.0),
          "messageLength": ("mb_sent", 1e-6), "numReductions": ("reductions", 1.0)}


def _logged() -> dict[str, float]:
    """This rank's totals of :data:`EVENTS` so far, in PETSc's log."""
    totals = dict.fromkeys(FIELDS, 0.0)
    for name in EVENTS:
        info = PETSc.Log.Event(name).getPerfInfo()
        for key in FIELDS:
            totals[key] += float(info[key])
    return totals


def _per_rank(before: dict[str, float]) -> dict[str, float]:
    """Each rank's work since ``before``: the largest over the ranks and the mean."""
    now, comm, out = _logged(), MPI.COMM_WORLD, {}
    for key, (name, scale) in FIELDS.items():
        mine = (now[key] - before[key]) * scale
        out[f"{name}_max"] = round(comm.allreduce(mine, MPI.MAX), 3)
        out[f"{name}_mean"] = round(comm.allreduce(mine, MPI.SUM) / comm.size, 3)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="4,8,16", help="n, the cells a side (a list)")
    args = parser.parse_args()
    PETSc.Log.begin()
    for cell in ("tet", "hex"):
        for n in (int(v) for v in args.cells.split(",")):
            V, A, b = clamped_cube_elasticity(n, cell)
            before = _logged()
            its: dict[str, object] = {"pmg_gamg_coarse": krylov_iterations(V, A, b, "pmg", 0)[0]}
            work = _per_rank(before)
            its |= {"pmg_factorised_coarse": krylov_iterations(V, A, b, "pmg", 10**9)[0],
                    "gamg": krylov_iterations(V, A, b, "gamg")[0], "per_rank": work}
            if MPI.COMM_WORLD.rank == 0:
                print(json.dumps({"cells": cell, "n": n, "dofs": A.getSize()[0],
                                  "ranks": MPI.COMM_WORLD.size, **its}), flush=True)


if __name__ == "__main__":
    main()
