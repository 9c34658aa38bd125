"""Bodies as weighted point clouds at quadrature points, and the way back to the mesh.

The deformed body is sampled at the quadrature points X_q of the owned cells:
points Phi(X_q) = X_q + u(X_q), weights J(X_q) w_q (w_q the physical quadrature
weights of the reference cells), so that sums over the cloud are integrals over
the deformed body.  A derivative of a function of the cloud with respect to its
points (g_x) and weights (g_w) becomes a derivative with respect to u through

    dJ/du [v] = sum_q g_x(q) . v(X_q) + g_w(q) w_q cof F(X_q) : grad v(X_q),

which is assembled as an ordinary form from quadrature-element functions.
"""

from __future__ import annotations

import dolfinx.fem
import dolfinx.fem.petsc
import numpy as np
import ufl
from petsc4py import PETSc

from .. import compat
from .hausdorff import PointCloud


class QuadratureCloud:
    """Quadrature points of degree ``degree`` on the owned cells of ``mesh``."""

    def __init__(self, mesh, degree: int, weight: ufl.core.expr.Expr | float = 1.0):
        """``weight``: the reference measure per mesh measure (2 pi R on the section of a body
        of revolution), a factor of every weight."""
        self.mesh, self.degree = mesh, degree
        self.ref_points, ref_weights = compat.reference_quadrature(mesh, degree)
        self.nq = len(ref_weights)
        tdim = mesh.topology.dim
        self.cells = np.arange(mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self.gdim = mesh.geometry.dim
        x = ufl.SpatialCoordinate(mesh)
        self.X = self._eval(x).reshape(-1, self.gdim)  # reference positions X_q
        detJ = self._eval(abs(ufl.JacobianDeterminant(mesh))).reshape(-1, self.nq)
        self.w = (detJ * ref_weights).ravel()  # physical weights of the reference cells
        self.weight = weight
        if not isinstance(weight, float):
            self.w *= self._eval(weight).reshape(-1)
        self.Q = compat.quadrature_space(mesh, degree)
        self.QV = compat.quadrature_space(mesh, degree, vector=True)
        self.dofs = np.array([self.Q.dofmap.cell_dofs(c) for c in self.cells],
                             dtype=np.int64).reshape(-1)
        self.dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": degree,
                                                           "quadrature_rule": "default"})
        self._compiled: dict[str, dolfinx.fem.Expression] = {}

    def __len__(self) -> int:
        return len(self.w)

    def _eval(self, expr) -> np.ndarray:
        return compat.evaluate_expression(expr, self.ref_points, self.mesh, self.cells)

    def reference(self) -> PointCloud:
        return PointCloud(self.X.copy(), self.w.copy())

    def _volume_ratio(self, u: dolfinx.fem.Function,
                      ratio: ufl.core.expr.Expr | None) -> ufl.core.expr.Expr:
        return ufl.det(ufl.Identity(self.gdim) + ufl.grad(u)) if ratio is None else ratio

    def deformed_factory(self, u: dolfinx.fem.Function,
                         volume_ratio: ufl.core.expr.Expr | None = None):
        """A function returning the deformed cloud for the current values of ``u``;
        ``volume_ratio``: deformed per reference measure (default det F)."""
        position = compat.expression_evaluator(ufl.SpatialCoordinate(self.mesh) + u,
                                               self.ref_points, self.mesh, self.cells)
        jacobian = compat.expression_evaluator(self._volume_ratio(u, volume_ratio),
                                               self.ref_points, self.mesh, self.cells)

        def deformed() -> PointCloud:
            points = position().reshape(-1, self.gdim)
            J = jacobian().reshape(-1)
            return PointCloud(points, J * self.w)

        return deformed

    def pullback_form(self, u: dolfinx.fem.Function,
                      volume_ratio: ufl.core.expr.Expr | None = None):
        """(form, fill): ``fill(g_x, g_w)`` loads the cloud derivatives, then assembling
        ``form`` gives dJ/du as a vector on u's space."""
        gx = dolfinx.fem.Function(self.QV)
        gw = dolfinx.fem.Function(self.Q)
        v = ufl.TestFunction(u.function_space)
        if volume_ratio is None:  # d(det F)[v] = cof F : grad v
            F = ufl.Identity(self.gdim) + ufl.grad(u)
            d_ratio = ufl.inner(ufl.cofac(F), ufl.grad(v))
        else:
            d_ratio = ufl.derivative(volume_ratio, u, v)
        form = dolfinx.fem.form((ufl.dot(gx, v) + gw * d_ratio) * self.weight * self.dx)
        bs = self.gdim

        def fill(grad_points: np.ndarray, grad_weights: np.ndarray) -> None:
            gx.x.array[:] = 0.0
            gw.x.array[:] = 0.0
            values = grad_points / self.w[:, None]
            for k in range(bs):
                gx.x.array[self.dofs * bs + k] = values[:, k]
            gw.x.array[self.dofs] = grad_weights

        return form, fill


def assemble(form) -> PETSc.Vec:
    vec = dolfinx.fem.petsc.assemble_vector(form)
    vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return vec
