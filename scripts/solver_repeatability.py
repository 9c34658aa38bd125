"""Is the state's linear solve repeatable bit for bit?  Factor one tangent several times.

    [mpirun -n 2] .venv/bin/python scripts/solver_repeatability.py [CONFIG] [--repeats 6]
                                                              [--set KEY=VALUE ...]

Solves the config's state at its initial growth, assembles the tangent there and solves one
system with it ``--repeats`` times, each with a fresh factorisation by the state's linear
solver.  Prints the largest difference between the solutions relative to their size.
Serial factorisations repeat exactly; MUMPS on several ranks schedules its factorisation
dynamically, so the solutions can differ in their last digits from one factorisation to the
next, and a long optimisation under MPI drifts accordingly (docs/REPRODUCIBILITY.md).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import dolfinx.fem.petsc
import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from shapegrowth.config import load
from shapegrowth.physics.model import ForwardModel

ROOT = Path(__file__).resolve().parent.parent


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("config", nargs="?", default=ROOT / "configs" / "beam_bend.yaml")
    parser.add_argument("--repeats", type=int, default=6)
    parser.add_argument("--set", dest="overrides", action="append", default=[])
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    model = ForwardModel.build(load(args.config, args.overrides))
    state = model.state
    state.solve()
    A = dolfinx.fem.petsc.assemble_matrix(state.jacobian_form, bcs=state.bcs)
    A.assemble()
    b = A.createVecRight()
    b.set(1.0)  # a load on every unknown: the solution involves the whole factor
    solutions = []
    for _ in range(args.repeats):
        ksp = PETSc.KSP().create(comm)
        ksp.setOperators(A)
        ksp.setOptionsPrefix(state.newton.options.prefix)  # the state's linear solver and options
        x = b.duplicate()
        with state.newton.options.pushed():
            ksp.setFromOptions()
            ksp.solve(b, x)
        solutions.append(x.array.copy())
        ksp_name = f"{ksp.getType()}/{ksp.getPC().getType()} ({ksp.getPC().getFactorSolverType()})"
        ksp.destroy()
    spread = max(np.abs(s - solutions[0]).max(initial=0.0) for s in solutions)
    size = np.abs(solutions[0]).max(initial=0.0)
    spread, size = comm.allreduce(spread, MPI.MAX), comm.allreduce(size, MPI.MAX)
    if comm.rank == 0:
        print(f"{ksp_name} on {A.getSize()[0]} unknowns, {comm.size} rank(s), "
              f"{args.repeats} factorisations: largest difference {spread / size:.2e} of the "
              "solution's size")
    return 0


if __name__ == "__main__":
    sys.exit(main())
