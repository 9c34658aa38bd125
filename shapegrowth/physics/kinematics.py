"""The model's kinematics in 3x3 form: what the 2D models keep of the 3D body.

Every model evaluates the same energy psi(F, C_g) of (5.1) with 3x3 tensors; a 2D model
only says what the third direction does (config/reduction.py):

* a plane body (rectangle, X1-X2) in plane strain: F = [[F2, 0], [0, 1]], C_g = [[C2, 0],
  [0, 1]]; in plane stress the third stretch s is the one at which that direction carries no
  stress (below);
* the section of a box (X1-X3, X2 out of plane): C_g keeps its three eigenvalues, its X2
  eigenvalue lambda_2 as the third entry; plane strain holds s = 1, plane stress frees it;
* the (R, Z) section of a body of revolution about X3: the third stretch is the hoop
  stretch s = (R + u_R)/R, and every integral carries the weight 2 pi R.

The third direction is an eigenvector of C_g in every allowed frame (checks.py), so the 3x3
tensors are block diagonal in (plane, third) and only that block structure is used.

Plane stress in closed form.  With A2 = F2 G2^-1, j2 = det A2 and a = s / sqrt(lambda_3),
the energy (5.1) per unit grown volume is W0 = mu1/2 (|A2|^2 + a^2) + mu2/2 (j2^2 +
a^2 |A2|^2) - (mu1 + 2 mu2) ln(j2 a) + lambda/2 (j2 a - 1)^2, and dW0/da = 0 is, times a,
the quadratic c a^2 - lambda j2 a - (mu1 + 2 mu2) = 0 with c = mu1 + mu2 |A2|^2 +
lambda j2^2, whose positive root is the stress-free stretch.  It enters F exactly, and its
derivatives come from UFL like every other.

An incompressible body in plane stress (``material.incompressible``, any energy): J of the
elastic part is 1, so j2 a = 1 fixes the third stretch, a = 1 / j2, and the plane-stress
condition is what determines the pressure (the incompressible membrane: no pressure unknown,
no volumetric part, the displacement element free of locking).
"""

from __future__ import annotations

import math

import ufl
from ufl.core.expr import Expr

from ..config.reduction import Section
from .material import Material, MooneyRivlin


def block(A2: Expr, third: Expr | float) -> Expr:
    """[[A2, 0], [0, third]] (3x3) of a 2x2 tensor."""
    return ufl.as_matrix([[A2[0, 0], A2[0, 1], 0], [A2[1, 0], A2[1, 1], 0], [0, 0, third]])


class Kinematics:
    """F, C_g and the volume measure of one model (a ``Section``) on one mesh."""

    def __init__(self, section: Section, mesh, material: Material,
                 incompressible: bool = False):
        self.section, self.material = section, material
        self.incompressible = incompressible
        self.x = ufl.SpatialCoordinate(mesh)
        self.solid = section.kind == "solid"

    def weight(self) -> Expr | float:
        """The reference measure per mesh measure: 2 pi R for a body of revolution, else 1."""
        return 2 * math.pi * self.x[0] if self.section.axisymmetric else 1.0

    def growth(self, Cg: Expr) -> Expr:
        """C_g (or any tensor of the growth's frame, e.g. G^-1) in the model's 3x3 form."""
        if self.solid:
            return Cg
        if not self.section.reduced:
            return block(Cg, 1.0)
        a, b = self.section.axes
        out = self.section.out_of_plane
        return ufl.as_matrix([[Cg[a, a], Cg[a, b], 0], [Cg[b, a], Cg[b, b], 0],
                              [0, 0, Cg[out, out]]])

    def third_stretch(self, F: Expr, u: Expr, Cg3: Expr) -> Expr | float:
        """The stretch of the third direction: 1, the plane-stress root (1 / j2 where
        incompressible), or (R + u_R)/R."""
        if self.section.axisymmetric:
            return (self.x[0] + u[0]) / self.x[0]
        if not self.section.stress_free:
            return 1.0
        if self.incompressible:
            C2 = ufl.as_matrix([[Cg3[0, 0], Cg3[0, 1]], [Cg3[1, 0], Cg3[1, 1]]])
            return ufl.sqrt(ufl.det(C2) * Cg3[2, 2]) / ufl.det(F)
        m = self.material
        assert isinstance(m, MooneyRivlin)  # config.material_checks: else incompressible
        C2 = ufl.as_matrix([[Cg3[0, 0], Cg3[0, 1]], [Cg3[1, 0], Cg3[1, 1]]])
        det_c2 = ufl.det(C2)
        norm2 = ufl.tr(F.T * F * ufl.cofac(C2)) / det_c2  # |A2|^2
        j2 = ufl.det(F) / ufl.sqrt(det_c2)
        c = m.mu1 + m.mu2 * norm2 + m.lmbda * j2 ** 2
        root = ufl.sqrt((m.lmbda * j2) ** 2 + 4 * c * (m.mu1 + 2 * m.mu2))
        a = (m.lmbda * j2 + root) / (2 * c)
        return a * ufl.sqrt(Cg3[2, 2])

    def deformation(self, F: Expr, u: Expr, Cg3: Expr) -> Expr:
        """F in 3x3 form, for the mesh's F = I + grad u and C_g in 3x3 form."""
        return F if self.solid else block(F, self.third_stretch(F, u, Cg3))

    def psi(self, F: Expr, u: Expr, Cg: Expr) -> Expr:
        """psi(F, C_g) of (5.1) per unit reference volume, for the mesh's F and the growth's
        own tensor C_g."""
        Cg3 = self.growth(Cg)
        return self.material.psi(self.deformation(F, u, Cg3), Cg3)

    def psi_mixed(self, F: Expr, u: Expr, Cg: Expr, p: Expr, incompressible: bool) -> Expr:
        """The mixed formulation's psi(F, p, C_g) (material.Energy.psi_mixed) per unit
        reference volume (plane stress is refused with it: config.material_checks)."""
        Cg3 = self.growth(Cg)
        return self.material.psi_mixed(self.deformation(F, u, Cg3), Cg3, p, incompressible)

    def volume_ratio(self, F: Expr, u: Expr) -> Expr:
        """The deformed per reference measure of the model's clouds and volumes: det F, times
        the hoop stretch for a body of revolution (a plane section's area ratio in plane
        stress: the clouds measure the section's shape)."""
        J = ufl.det(F)
        if self.section.axisymmetric:
            return J * (self.x[0] + u[0]) / self.x[0]
        return J
