"""rho_H (2.9) of a growth shell's wall: the wall as a weighted point cloud, and the way back
to the shell's design through its adjoint.

The wall is sampled at the quadrature points X_q of the mid-surface's owned cells and at
the Gauss-Legendre heights zeta_k through it: points phi(X_q) + zeta_k d(X_q), weights
w_q c_k sqrt(det a(X_q)) (w_q the reference surface's quadrature weights, c_k = t/2 times
the rule's weight, a = F^T F the deformed metric in the reference's orthonormal frame), so
that a sum over the cloud is the deformed wall's volume to first order in its thickness
(the wall's own thickness strain and the height's share of the area are left out, as the
shell leaves them out).  A derivative of a function of the cloud with respect to its points
(g_x) and weights (g_w) is the derivative in the shell's unknowns q of the form

    S(q) = sum_k  integral of  G_x,k . (phi + zeta_k d) + G_w,k sqrt(det a),

G_x,k = g_x / w_q and G_w,k = c_k g_w held fixed as quadrature functions; the shell's
adjoint (:meth:`GrowthShell.gradient`) carries it to the design.
"""

from __future__ import annotations

from collections.abc import Callable

import dolfinx.fem
import numpy as np
import ufl

from .. import compat
from ..physics.shell import GrowthShell
from ..shape.clouds import QuadratureCloud
from ..shape.divergence import ShapeDivergence, ShapeTerm
from ..shape.hausdorff import HausdorffResult, PointCloud, SmoothHausdorff


class ShellCloud:
    """The wall of ``shell`` at quadrature points of ``degree`` on its mid-surface and
    ``layers`` Gauss-Legendre heights through it."""

    def __init__(self, shell: GrowthShell, degree: int = 4, layers: int = 2):
        self.shell = shell
        self.base = QuadratureCloud(shell.mesh, degree)
        nodes, weights = np.polynomial.legendre.leggauss(layers)
        self.heights = 0.5 * shell.thickness * nodes
        self.shares = 0.5 * shell.thickness * weights
        reference = shell.reference
        director = shell.director
        F = reference.derivative(shell.phi)
        ratio = ufl.sqrt(ufl.det(F.T * F))
        base = self.base
        layer_points = [shell.phi + float(z) * director for z in self.heights]
        self._points = [compat.expression_evaluator(x, base.ref_points, shell.mesh, base.cells)
                        for x in layer_points]
        self._ratio = compat.expression_evaluator(ratio, base.ref_points, shell.mesh,
                                                  base.cells)
        # the derivative's fixed factors, three components and a weight a height
        self._gx = [[dolfinx.fem.Function(base.Q) for _ in range(3)] for _ in self.heights]
        self._gw = [dolfinx.fem.Function(base.Q) for _ in self.heights]
        terms = [(sum(g * x[c] for c, g in enumerate(gx)) + gw * ratio) * base.dx
                 for x, gx, gw in zip(layer_points, self._gx, self._gw)]
        self.surrogate = sum(terms[1:], terms[0])

    def __len__(self) -> int:
        return len(self.base) * len(self.heights)

    def deformed(self) -> PointCloud:
        """The deformed wall's cloud (this rank's points, height after height)."""
        ratio = self._ratio().reshape(-1)
        points = np.concatenate([p().reshape(-1, 3) for p in self._points])
        weights = np.concatenate([c * ratio * self.base.w for c in self.shares])
        return PointCloud(points, weights)

    def reference(self) -> PointCloud:
        """The undeformed wall's cloud: the deformed one at q = 0."""
        saved = self.shell.q.x.array.copy()
        self.shell.q.x.array[:] = 0.0
        try:
            return self.deformed()
        finally:
            self.shell.q.x.array[:] = saved

    def mapped(self, target_map: Callable[[np.ndarray], np.ndarray]) -> PointCloud:
        """A target given as a map of the body, sampled where the wall is sampled: the
        undeformed wall's points X (this rank's, (n, 3)) carried to ``target_map(X)`` (n, 3),
        weighted by the undeformed weights times |det grad map| (the target's own volume
        measure; central differences of 1e-6 of the body's scale).  A wall that takes the
        target shape then has this cloud for its own, point for point (to the shell's first
        order in the thickness), where two clouds sampled apart lie as far apart as their
        spacing (the wall's mid-surface points against a 3D body's)."""
        rest = self.reference()
        X = rest.points
        points = np.asarray(target_map(X), dtype=float)
        if points.shape != X.shape or not np.isfinite(points).all():
            raise ValueError(f"the target map gives {points.shape} values, finite: "
                             f"{bool(np.isfinite(points).all())}; it must give (n, 3) finite "
                             "points for (n, 3)")
        step = 1e-6 * max(float(np.abs(X).max(initial=0.0)), 1.0)
        grad = np.empty((len(X), 3, 3))
        for j in range(3):
            shift = np.zeros(3)
            shift[j] = step
            grad[:, :, j] = (np.asarray(target_map(X + shift))
                             - np.asarray(target_map(X - shift))) / (2.0 * step)
        return PointCloud(points, rest.weights * np.abs(np.linalg.det(grad)))

    def _fill(self, grad_points: np.ndarray, grad_weights: np.ndarray) -> None:
        n, dofs, w = len(self.base), self.base.dofs, self.base.w
        for k, (gx, gw, share) in enumerate(zip(self._gx, self._gw, self.shares)):
            rows = slice(k * n, (k + 1) * n)
            for c, g in enumerate(gx):
                g.x.array[:] = 0.0
                g.x.array[dofs] = grad_points[rows, c] / w
                g.x.scatter_forward()
            gw.x.array[:] = 0.0
            gw.x.array[dofs] = share * grad_weights[rows]
            gw.x.scatter_forward()

    def hausdorff(self, target: PointCloud, rho: SmoothHausdorff, gradient: bool = True
                  ) -> tuple[HausdorffResult, dolfinx.fem.Function | None]:
        """rho_H of the wall at the shell's current equilibrium against ``target`` (this
        rank's share of it), and, where ``gradient``, its gradient with respect to the
        shell's design (None otherwise; collective)."""
        term, dJ = self.shape_term(target, ShapeDivergence(rho, "paper"), gradient)
        return term.pair, dJ

    def shape_term(self, target: PointCloud, divergence: ShapeDivergence, gradient: bool = True
                   ) -> tuple[ShapeTerm, dolfinx.fem.Function | None]:
        """The shape term of ``divergence`` (rho_H, or rho_H debiased) of the wall at the
        shell's current equilibrium against ``target``, and, where ``gradient``, its gradient
        with respect to the shell's design (None otherwise; collective)."""
        term = divergence(self.deformed(), target, self.shell.mesh.comm, gradient=gradient)
        if not gradient:
            return term, None
        assert term.grad_points is not None and term.grad_weights is not None
        self._fill(term.grad_points, term.grad_weights)
        return term, self.shell.gradient(self.surrogate)[1]
