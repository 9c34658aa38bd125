"""The growth-modulated Mooney-Rivlin energy psi(F, C_g) of (5.1), written in UFL.

psi is the only constitutive input: the stress P, the elasticity tensor and the
derivatives with respect to the growth parameters all come from it through
``ufl.derivative``/``ufl.diff``, and are checked against the paper's closed
forms in ``shapegrowth.closed_forms`` by the tests.

With G = C_g^(1/2), psi(F, C_g) = W0(F G^-1) det G (2.5), where
W0(F) = mu1/2 |F|^2 + mu2/2 |cof F|^2 - (mu1 + 2 mu2) log J + lambda/2 (J - 1)^2,
so psi is stress-free exactly when F^T F = C_g.
"""

from __future__ import annotations

from dataclasses import dataclass

import ufl


@dataclass(frozen=True)
class MooneyRivlin:
    """Material constants of (5.1); the paper uses mu1 = mu2 = 0.5, lambda = 3."""

    mu1: float = 0.5
    mu2: float = 0.5
    lmbda: float = 3.0

    def psi(self, F: ufl.core.expr.Expr, Cg: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """Energy density (5.1) for 3x3 tensors F (deformation gradient) and C_g."""
        det_cg = ufl.det(Cg)
        root = ufl.sqrt(det_cg)
        J = ufl.det(F)
        H = ufl.cofac(F)
        je = J / root  # det of the elastic part F G^-1
        return (self.mu1 / 2 / root * ufl.tr(F.T * F * ufl.cofac(Cg))
                + self.mu2 / 2 / root * ufl.tr(H.T * H * Cg)
                - (self.mu1 + 2 * self.mu2) * root * ufl.ln(je)
                + self.lmbda / 2 * root * (je - 1) ** 2)

    def psi_plane_strain(self, F2: ufl.core.expr.Expr, Cg2: ufl.core.expr.Expr):
        """psi for a 2D body in plane strain: F and C_g carry 1 in the X3 direction."""
        return self.psi(embed_plane(F2), embed_plane(Cg2))

    def energy_density(self, F: ufl.core.expr.Expr, Cg: ufl.core.expr.Expr):
        """psi in the body's own dimension (3D, or plane strain in 2D)."""
        return self.psi(F, Cg) if F.ufl_shape == (3, 3) else self.psi_plane_strain(F, Cg)


def embed_plane(A2: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    """The 3x3 tensor [[A2, 0], [0, 1]] of a 2x2 tensor A2 (plane strain)."""
    return ufl.as_matrix([[A2[0, 0], A2[0, 1], 0], [A2[1, 0], A2[1, 1], 0], [0, 0, 1]])


def deformation_gradient(u: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
    return ufl.Identity(len(u)) + ufl.grad(u)
