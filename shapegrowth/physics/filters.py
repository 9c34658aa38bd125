"""The Helmholtz filter of (5.7): rho_hat - l^2 Laplace(rho_hat) = rho, zero flux.

On the growth space (scalar, or a vector of fields filtered each alone) with mass matrix
M and K = M + l^2 S (S the stiffness matrix), the filtered nodal values are
rho_hat = K^-1 M rho (``forward``).  A
derivative with respect to rho_hat (a dual vector) is carried back to rho by the
transpose, M K^-1 (``backward``; K and M are symmetric).  l = 0 is the identity.
The solver takes the options ``filter_...`` (CG + Jacobi by default: K is a
well-conditioned SPD matrix, about as cheap as a mass matrix; CG + the multigrid with
``solver.linear: gamg | hypre``).
"""

from __future__ import annotations

import dolfinx.fem
import dolfinx.fem.petsc
import ufl
from petsc4py import PETSc

from .. import compat
from .linear import preset_options
from .options import SolverOptions


class HelmholtzFilter:
    role = "filter_"  # the prefix of this solver's keys in solver.petsc_options

    def __init__(self, space, length: float, petsc_options: dict | None = None,
                 preset: str = "mumps"):
        self.space, self.length = space, float(length)
        if self.length == 0.0:
            return
        u, v = ufl.TrialFunction(space), ufl.TestFunction(space)
        # the growth fields are at most quadratic: degree 4 integrates the mass matrix exactly
        dx = ufl.Measure("dx", domain=space.mesh, metadata={"quadrature_degree": 4})
        l2 = compat.constant(space.mesh, self.length**2)
        self.K = dolfinx.fem.petsc.assemble_matrix(
            dolfinx.fem.form((ufl.inner(u, v) + l2 * ufl.inner(ufl.grad(u), ufl.grad(v))) * dx))
        self.K.assemble()
        self.M = dolfinx.fem.petsc.assemble_matrix(dolfinx.fem.form(ufl.inner(u, v) * dx))
        self.M.assemble()
        self.ksp = PETSc.KSP().create(space.mesh.comm)
        self.options = SolverOptions(self.role, preset_options(preset, self.role),
                                     petsc_options)
        self.ksp.setOptionsPrefix(self.options.prefix)
        self.ksp.setOperators(self.K)
        with self.options.pushed():
            self.ksp.setFromOptions()
        self._work = self.K.createVecRight()

    @property
    def active(self) -> bool:
        return self.length > 0.0

    def forward(self, rho: dolfinx.fem.Function, out: dolfinx.fem.Function) -> None:
        """out <- K^-1 M rho."""
        if not self.active:
            out.x.array[:] = rho.x.array
            return
        self.M.mult(compat.petsc_vec(rho), self._work)
        with self.options.pushed():
            self.ksp.solve(self._work, compat.petsc_vec(out))
        out.x.scatter_forward()

    def backward(self, dual: PETSc.Vec, out: PETSc.Vec) -> None:
        """out <- M K^-1 dual (both dual vectors: derivatives with respect to nodal values)."""
        if not self.active:
            dual.copy(out)
            return
        with self.options.pushed():
            self.ksp.solve(dual, self._work)
        self.M.mult(self._work, out)
