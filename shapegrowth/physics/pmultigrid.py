"""The p-multigrid of ``solver.linear: pmg``: two levels on one mesh, the state's P2 (Q2)
displacements and the P1 (Q1) ones of the same cells.

The fine level is smoothed by Chebyshev with Jacobi; the coarse operator is the Galerkin
product A_1 = P^T A P (P interpolates P1 into P2: :func:`compat.interpolation_matrix`),
formed here at every tangent assembly rather than by PCMG, so that it carries the P1 nodes'
rigid-body modes as its near-nullspace; smoothed aggregation (GAMG) with those modes solves
it.  Aggregation sees the vertices it was made for: on a P2 tangent the edge midpoints'
couplings mislead it (tests/test_pmultigrid.py, linear elasticity in a clamped unit cube
from 2 187 to 14 739 DOFs, to 1e-10: on tetrahedra this two-level method takes 19 -> 19
iterations, GAMG on the P2 matrix 25 -> 27; on Q2 hexahedra 15 -> 17 against 23 -> 24).

The options are the preset's (physics/linear.py, ``pmg``); :class:`PMultigrid` supplies
what options cannot: the interpolation and the coarse operator with its modes.
"""

from __future__ import annotations

import dolfinx
import numpy as np
import ufl
from mpi4py import MPI
from petsc4py import PETSc

from .. import compat


def rigid_body_modes(V) -> PETSc.NullSpace:
    """Translations and infinitesimal rotations, the near-nullspace for GAMG."""
    gdim = V.mesh.geometry.dim
    index_map, bs = V.dofmap.index_map, V.dofmap.index_map_bs
    n = index_map.size_local
    x = V.tabulate_dof_coordinates()[:n]
    modes = np.zeros((6 if gdim == 3 else 3, n, bs))
    for i in range(gdim):
        modes[i, :, i] = 1.0
    if gdim == 3:
        modes[3, :, 0], modes[3, :, 1] = -x[:, 1], x[:, 0]
        modes[4, :, 0], modes[4, :, 2] = x[:, 2], -x[:, 0]
        modes[5, :, 2], modes[5, :, 1] = x[:, 1], -x[:, 2]
    else:
        modes[2, :, 0], modes[2, :, 1] = -x[:, 1], x[:, 0]
    vecs: list[PETSc.Vec] = []
    for mode in modes:  # Gram-Schmidt with PETSc's (global) products: dolfinx.la's
        vec = compat.index_map_vector(index_map, bs)  # orthonormalize takes
        vec.array[:] = mode.ravel()  # PETSc vectors in 0.5.2, its own in 0.9
        for other in vecs:
            vec.axpy(-vec.dot(other), other)
        vec.normalize()
        vecs.append(vec)
    return PETSc.NullSpace().create(vectors=vecs)


# Up to this many coarse (P1) DOFs the coarse level is factorised (MUMPS LDL^T) rather than
# solved by GAMG: exact there, it leaves the iterations to the smoother alone, and its factor
# is small beside the P2 one a direct solve of the state would need (the P1 problem has an
# eighth of the unknowns and sparser rows).  On a thin P2 beam, where aggregation of the
# locking P1 operator is poor, the two-level method took 82 MINRES iterations with the
# factorised coarse level against 324 with GAMG (1 953 DOFs); on a few dozen equations
# GAMG's own coarsest level can be singular.
DIRECT_COARSE_DOFS = 50_000


def elements_across(mesh) -> float:
    """How many cells a 3D body is across: 2 V / A (its thickness, for a wall; a third of
    the side, for a cube) over the cells' size (the edge of a regular tetrahedron, or of a
    cube, of the mean cell volume).  ``solver.linear: auto`` sends a body of degree 2 to the
    p-multigrid where it is solid by this measure (physics/linear.py, :func:`choose`)."""
    one = compat.constant(mesh, 1.0)
    volume, area = (mesh.comm.allreduce(
        dolfinx.fem.assemble_scalar(dolfinx.fem.form(one * measure)), op=MPI.SUM)
        for measure in (ufl.dx(domain=mesh), ufl.ds(domain=mesh)))
    cells = mesh.topology.index_map(mesh.topology.dim).size_global
    per_cell = volume / cells
    regular = 6 * np.sqrt(2) if mesh.topology.cell_type.name == "tetrahedron" else 1.0
    return float(2 * volume / area / np.cbrt(regular * per_cell))


class PMultigrid:
    """The coarse space of a displacement space of degree 2, its interpolation ``P`` and the
    coarse space's rigid-body modes (:meth:`of` makes them), and the coarse operator of one
    solver's tangent."""

    def __init__(self, coarse_space, P: PETSc.Mat, modes: PETSc.NullSpace, direct_coarse: bool):
        self.coarse_space, self.P, self._modes = coarse_space, P, modes
        self.direct_coarse = direct_coarse
        self._coarse: PETSc.Mat | None = None

    @classmethod
    def of(cls, V, direct_coarse_dofs: int | None = None) -> PMultigrid:
        """The p-multigrid of the displacement space ``V`` (degree 2), its coarse level
        factorised up to ``direct_coarse_dofs`` (default :data:`DIRECT_COARSE_DOFS`)."""
        if direct_coarse_dofs is None:
            direct_coarse_dofs = DIRECT_COARSE_DOFS
        if compat.space_degree(V) != 2:
            raise ValueError("the p-multigrid coarsens P2 (Q2) displacements to P1 (Q1)")
        coarse_space = compat.vector_space(V.mesh, 1)
        P = compat.interpolation_matrix(coarse_space, V)
        P.assemble()
        return cls(coarse_space, P, rigid_body_modes(coarse_space),
                   int(P.getSize()[1]) <= direct_coarse_dofs)

    def sibling(self) -> PMultigrid:
        """Another solver's multigrid on the same space (the adjoint's, beside the state's):
        the coarse space, the interpolation and the modes shared, the coarse operator its
        own (each solver's tangent is its own)."""
        return PMultigrid(self.coarse_space, self.P, self._modes, self.direct_coarse)

    def coarse_options(self) -> dict[str, object]:
        """The options (without a prefix) that replace the preset's GAMG on the coarse level
        by MUMPS's LDL^T where the coarse problem is small (:data:`DIRECT_COARSE_DOFS`)."""
        if not self.direct_coarse:
            return {}
        return {"mg_coarse_pc_type": "cholesky", "mg_coarse_pc_factor_mat_solver_type": "mumps",
                "mg_coarse_mat_mumps_icntl_14": 30}

    @property
    def coarse_size(self) -> int:
        return int(self.P.getSize()[1])

    def coarse_operator(self, A: PETSc.Mat) -> PETSc.Mat:
        """P^T A P of the assembled ``A``, in the matrix of the previous call where there
        is one (its sparsity is the same), with the rigid-body modes of the P1 nodes."""
        if self._coarse is None:
            self._coarse = A.PtAP(self.P)
            self._coarse.setNearNullSpace(self._modes)
        else:
            A.PtAP(self.P, self._coarse)
        return self._coarse

    def prepare(self, ksp: PETSc.KSP, A: PETSc.Mat) -> None:
        """Before ``ksp`` (preset ``pmg``, its options read) solves with the tangent ``A``
        just assembled: the interpolation (again: a reset KSP forgets it) and the coarse
        operator of ``A``."""
        pc = ksp.getPC()
        if pc.getType() != PETSc.PC.Type.MG:  # the exact fallback's KSP
            return
        pc.setMGInterpolation(1, self.P)
        pc.getMGCoarseSolve().setOperators(self.coarse_operator(A))
