"""The p-multigrid's iterations against the mesh size and the number of ranks
(docs/PERFORMANCE.md, "A p-multigrid for solid bodies").

    mpirun -n N [--oversubscribe] .venv/bin/python benchmarks/pmg_iterations.py [--cells 4,8,16]

Linear elasticity in a clamped unit cube of n cells a side (tests/test_pmultigrid.py's
problem), P2 on tetrahedra and Q2 on hexahedra, solved to 1e-10 by the ``pmg`` preset with
its coarse level by GAMG and factorised, and by the ``gamg`` preset on the P2 matrix.  One
JSON line per case on rank 0: the cells, n, the DOFs, the ranks and the three iteration
counts.  Ranks beyond the cores (``--oversubscribe``) count iterations, not time.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from mpi4py import MPI

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from test_pmultigrid import clamped_cube_elasticity, krylov_iterations  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", default="4,8,16", help="n, the cells a side (a list)")
    args = parser.parse_args()
    for cell in ("tet", "hex"):
        for n in (int(v) for v in args.cells.split(",")):
            V, A, b = clamped_cube_elasticity(n, cell)
            its = {"pmg_gamg_coarse": krylov_iterations(V, A, b, "pmg", 0)[0],
                   "pmg_factorised_coarse": krylov_iterations(V, A, b, "pmg", 10**9)[0],
                   "gamg": krylov_iterations(V, A, b, "gamg")[0]}
            if MPI.COMM_WORLD.rank == 0:
                print(json.dumps({"cells": cell, "n": n, "dofs": A.getSize()[0],
                                  "ranks": MPI.COMM_WORLD.size, **its}), flush=True)


if __name__ == "__main__":
    main()
