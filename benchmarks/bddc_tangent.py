"""BDDC on the prestressed tangent of the bench's beam, against MUMPS's LDL^T: tried and not
kept (20-23 GMRES iterations at every size, 3.1-3.9x the LDL^T's time on 2 ranks).

    mpirun -n 2 .venv/bin/python benchmarks/bddc_tangent.py [--size 0.025]
        [--option KEY=VALUE ...]

The bench's wave growth (commands/bench.py) is grown from rest; at that equilibrium the
tangent is assembled twice: as dolfinx's parallel AIJ matrix (factored by MUMPS's LDL^T, the
reference solution) and as a MATIS, one Neumann matrix per rank (dolfinx's local assembly
into it, the clamped rows and columns made those of the identity by MatZeroRowsColumns, which
shares the diagonal between the subdomains), solved by GMRES with PCBDDC to a relative
residual of 1e-10, MUMPS on the subdomains.  One JSON line on rank 0: the sizes, the two
solvers' times, BDDC's iterations and its distance from the reference solution.
"""

from __future__ import annotations

import argparse
import json
import time

import dolfinx.fem.petsc
import numpy as np
import scipy.sparse as sp
from mpi4py import MPI
from petsc4py import PETSc

from shapegrowth import compat
from shapegrowth.commands.bench import DEFAULT_OVERRIDES
from shapegrowth.config import load
from shapegrowth.physics.model import ForwardModel
from shapegrowth.physics.pmultigrid import rigid_body_modes

BDDC = {"ksp_type": "gmres", "ksp_gmres_restart": 200, "ksp_rtol": 1e-10, "ksp_max_it": 1000,
        "pc_type": "bddc", "pc_bddc_use_faces": 1, "pc_bddc_use_deluxe_scaling": 1,
        "pc_bddc_neumann_pc_type": "lu", "pc_bddc_neumann_pc_factor_mat_solver_type": "mumps",
        "pc_bddc_neumann_mat_mumps_icntl_24": 1,
        "pc_bddc_dirichlet_pc_type": "lu",
        "pc_bddc_dirichlet_pc_factor_mat_solver_type": "mumps"}


def neumann_matrices(state) -> PETSc.Mat:
    """An empty MATIS of the state's space: a local matrix per rank over its owned and ghost
    DOFs, preallocated from its cells."""
    V = state.V
    index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    local = index_map.size_local + index_map.num_ghosts
    globals_ = index_map.local_to_global(np.arange(local, dtype=np.int32))
    lgmap = PETSc.LGMap().create(globals_.astype(PETSc.IntType), bsize=bs, comm=V.mesh.comm)
    n, N = index_map.size_local * bs, index_map.size_global * bs
    A = PETSc.Mat().createIS([(n, N), (n, N)], lgmapr=lgmap, lgmapc=lgmap, comm=V.mesh.comm)
    cells = V.dofmap.list.array.reshape(-1, V.dofmap.dof_layout.num_dofs)
    k = cells.shape[1]
    pattern = sp.coo_matrix((np.ones(cells.size * k, dtype=np.int8),
                             (np.repeat(cells, k, axis=1).ravel(), np.tile(cells, k).ravel())),
                            shape=(local, local)).tocsr()
    nnz = np.repeat(np.diff(pattern.indptr) * bs, bs).astype(PETSc.IntType)
    block = PETSc.Mat().createAIJ([local * bs, local * bs], bsize=bs, nnz=nnz,
                                  comm=MPI.COMM_SELF)
    A.setISLocalMat(block)
    A.setNearNullSpace(rigid_body_modes(V))
    return A


def assemble_neumann(state, A: PETSc.Mat) -> None:
    """The tangent into the MATIS ``A``, the clamped rows and columns the identity's."""
    A.zeroEntries()
    state.u.x.scatter_forward()
    dolfinx.fem.petsc.assemble_matrix(A, state.jacobian_form)
    A.assemble()
    V = state.V
    bs = V.dofmap.index_map_bs
    owned = np.concatenate([bc.dof_indices()[0][:bc.dof_indices()[1]] for bc in state.bcs])
    rows = V.dofmap.index_map.local_to_global((owned // bs).astype(np.int32)) * bs + owned % bs
    A.zeroRowsColumns(rows.astype(PETSc.IntType), diag=1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=float, default=0.025)
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    cfg = load("configs/beam_wave.yaml", [*DEFAULT_OVERRIDES, f"mesh.size={args.size}",
                                          "solver.linear=mumps_ldlt"])
    state = ForwardModel.build(cfg).state
    if not state.solve().converged:
        raise SystemExit("bddc_tangent: the bench's growth found no equilibrium from rest")
    b = compat.create_vector(state.residual_form)
    b.setRandom(PETSc.Random().create(comm))

    A = dolfinx.fem.petsc.create_matrix(state.jacobian_form)
    state.tangent_into(A)
    direct = PETSc.KSP().create(comm)
    direct.setOperators(A)
    direct.setType("preonly")
    direct.getPC().setType("cholesky")
    direct.getPC().setFactorSolverType("mumps")
    reference = A.createVecRight()
    tic = time.perf_counter()
    direct.solve(b, reference)
    ldlt_s = time.perf_counter() - tic

    M = neumann_matrices(state)
    tic = time.perf_counter()
    assemble_neumann(state, M)
    neumann_s = time.perf_counter() - tic
    # the same operator, on a random vector (on the solution, A x = b cancels: cond(A) eps)
    probe, Ax, Mx = A.createVecRight(), A.createVecLeft(), A.createVecLeft()
    probe.setRandom(PETSc.Random().create(comm))
    A.mult(probe, Ax)
    M.mult(probe, Mx)
    Mx.axpy(-1.0, Ax)
    same_operator = Mx.norm() / Ax.norm()

    options = PETSc.Options()
    for key, value in {**BDDC, **dict(o.split("=", 1) for o in args.option)}.items():
        options[f"dd_{key}"] = value
    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix("dd_")
    ksp.setOperators(M)
    ksp.setFromOptions()
    x = M.createVecRight()
    tic = time.perf_counter()
    ksp.setUp()
    setup_s = time.perf_counter() - tic
    tic = time.perf_counter()
    ksp.solve(b, x)
    solve_s = time.perf_counter() - tic
    x.axpy(-1.0, reference)
    distance = x.norm() / reference.norm()
    row = {"dofs": A.getSize()[0], "ranks": comm.size, "ldlt_factor_solve_s": ldlt_s,
           "neumann_assembly_s": neumann_s, "operator_difference": same_operator,
           "bddc_setup_s": setup_s, "bddc_solve_s": solve_s,
           "bddc_iterations": ksp.getIterationNumber(),
           "bddc_reason": int(ksp.getConvergedReason()), "distance": distance,
           "options": args.option}
    slowest = {k: comm.allreduce(v, MPI.MAX) for k, v in row.items() if k.endswith("_s")}
    if comm.rank == 0:
        print(json.dumps({**row, **slowest}), flush=True)


if __name__ == "__main__":
    main()
