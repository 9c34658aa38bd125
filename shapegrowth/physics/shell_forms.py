"""What a growth shell is made of: its reference mid-surface with a frame on it, the
growth's rest forms, and the wall's material.

The reference is the mesh's own surface: a plane region (a triangle mesh of gdim 2, the
frame E1, E2, E3), or a surface in space (a triangle mesh of gdim 3, of second-order
geometry where it is curved) with an orthonormal frame (t1, t2, n), n its unit normal.
Tangential tensors (metrics, curvatures, growths) are 2 x 2 in (t1, t2), and the
reference's own curvature is B0 = -sym(E^T grad(n) E), E = [t1 t2] (a cylinder of
radius R with n outwards: -1/R round it).

A growth of the 3D wall that varies linearly through it, C_g(zeta) = C_m + zeta C_1 (its
tangential block in the frame; zeta the height along n), gives the grown wall at height
zeta the metric (I - zeta B0) C_g (I - zeta B0) in the mid-surface's coordinates, so

    abar = C_m,     bbar = (B0 C_m + C_m B0) / 2 - C_1 / 2,

the rest first and second fundamental forms (a shell's metric at height zeta is
a - 2 zeta b to first order; with no growth they are the reference's own, I and B0).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import dolfinx.fem
import numpy as np
import ufl

from .. import compat
from .material import Energy, MooneyRivlin


@dataclass(frozen=True)
class ShellMaterial:
    """The small-strain moduli of the wall's material (Lame's lam and mu)."""

    mu: float
    lam: float

    @property
    def plane_stress_lam(self) -> float:
        """lam_s = 2 lam mu / (lam + 2 mu): the first Lame modulus of plane stress (2 mu
        for an incompressible material, lam infinite)."""
        if math.isinf(self.lam):
            return 2.0 * self.mu
        return 2.0 * self.lam * self.mu / (self.lam + 2.0 * self.mu)

    @classmethod
    def of_energy(cls, energy: Energy) -> ShellMaterial:
        """The small-strain moduli of one of the package's energies (physics/material.py):
        for (5.1), mu = mu1 + mu2 and lam = lambda + 2 mu2 (its expansion at F = C_g = I to
        second order: lam/2 (tr e)^2 + mu e:e); for the others, their shear modulus and
        lam = kappa - 2 mu / 3.  Incompressible (no bulk modulus): lam infinite."""
        mu = float(energy.shear)
        if isinstance(energy, MooneyRivlin):
            return cls(mu, energy.lmbda + 2.0 * energy.mu2 if energy.lmbda > 0 else math.inf)
        bulk = float(energy.bulk)
        return cls(mu, bulk - 2.0 * mu / 3.0 if bulk > 0 else math.inf)


@dataclass(frozen=True)
class Reference:
    """The shell's reference mid-surface: the points of ``mesh`` and an orthonormal frame
    (t1, t2, n) on them (UFL 3-vectors); on a plane region (gdim 2), E1, E2, E3."""

    mesh: Any
    tangents: tuple[ufl.core.expr.Expr, ufl.core.expr.Expr]
    normal: ufl.core.expr.Expr

    @classmethod
    def plane(cls, mesh) -> Reference:
        """A plane region of the (X1, X2) plane, its normal E3."""
        if mesh.geometry.dim != 2 or mesh.topology.dim != 2:
            raise ValueError("a plane shell's reference is a triangle mesh of gdim 2")
        e1, e2, e3 = (ufl.as_vector([float(i == j) for j in range(3)]) for i in range(3))
        return cls(mesh, (e1, e2), e3)

    @classmethod
    def surface(cls, mesh, normal: ufl.core.expr.Expr,
                axis: tuple[float, float, float] = (0.0, 0.0, 1.0)) -> Reference:
        """A surface in space (a triangle mesh of gdim 3) of unit normal ``normal`` (a UFL
        expression or a Function, continuous over the surface), the frame t1 = ``axis``
        projected onto the tangent plane (nowhere along n), t2 = n x t1."""
        if mesh.geometry.dim != 3 or mesh.topology.dim != 2:
            raise ValueError("a shell's surface in space is a triangle mesh of gdim 3")
        a = ufl.as_vector(list(axis))
        along = a - ufl.dot(a, normal) * normal
        t1 = along / ufl.sqrt(ufl.dot(along, along))
        return cls(mesh, (t1, ufl.cross(normal, t1)), normal)

    @property
    def curved(self) -> bool:
        """Whether the reference lies in space (gdim 3) rather than on a plane."""
        return int(self.mesh.geometry.dim) == 3

    def position(self) -> ufl.core.expr.Expr:
        """The reference point X as a 3-vector."""
        X = ufl.SpatialCoordinate(self.mesh)
        return X if self.curved else ufl.as_vector([X[0], X[1], 0.0])

    @property
    def frame(self) -> ufl.core.expr.Expr:
        """E = [t1 t2], the tangents as columns (3 x 2)."""
        t1, t2 = self.tangents
        return ufl.as_matrix([[t1[i], t2[i]] for i in range(3)])

    def derivative(self, f: ufl.core.expr.Expr) -> ufl.core.expr.Expr:
        """The derivative of a 3-vector field along the frame's tangents (3 x 2)."""
        return ufl.grad(f) * self.frame if self.curved else ufl.grad(f)

    def cell_diameter(self) -> dolfinx.fem.Function:
        """Each cell's diameter (its longest edge between corners) as a DG0 Function: UFL's
        CellDiameter is not generated for curved (second-order) cells."""
        mesh = self.mesh
        space = compat.scalar_space(mesh, 0, "DG")
        tdim = mesh.topology.dim
        nodes = compat.geometry_nodes(mesh)[:, :tdim + 1]  # each cell's corners come first
        x = mesh.geometry.x[nodes]
        longest = np.zeros(len(nodes))
        for i in range(tdim + 1):
            for j in range(i + 1, tdim + 1):
                longest = np.maximum(longest, np.linalg.norm(x[:, i] - x[:, j], axis=1))
        h = dolfinx.fem.Function(space)
        dofs = np.array([space.dofmap.cell_dofs(c)[0] for c in range(len(nodes))],
                        dtype=np.int64)
        h.x.array[dofs] = longest
        return h

    @property
    def curvature(self) -> ufl.core.expr.Expr:
        """B0 = -sym(E^T grad(n) E): the reference's own second fundamental form (zero on a
        plane)."""
        if not self.curved:
            return ufl.as_matrix([[0.0, 0.0], [0.0, 0.0]])
        return -ufl.sym(self.frame.T * self.derivative(self.normal))


def turned(theta: ufl.core.expr.Expr, frame: tuple) -> tuple:
    """The frame (a1, a2, a3) turned by the director's two angles, Q = R_2(th2) R_1(th1) in
    it: its third vector sin th2 cos th1 a1 - sin th1 a2 + cos th2 cos th1 a3 is the
    director (FEniCSx-Shells' nonlinear Naghdi director, in the frame); the chart is
    singular where th1 reaches +-pi/2."""
    a1, a2, a3 = frame
    c1, s1, c2, s2 = ufl.cos(theta[0]), ufl.sin(theta[0]), ufl.cos(theta[1]), ufl.sin(theta[1])
    return (c2 * a1 - s2 * a3, (s1 * s2) * a1 + c1 * a2 + (s1 * c2) * a3,
            (s2 * c1) * a1 - s1 * a2 + (c2 * c1) * a3)


@dataclass(frozen=True)
class RestForms:
    """The growth's rest forms, UFL 2 x 2 tensors in the reference's frame: ``metric``
    abar = C_m and ``curvature`` bbar = sym(B0 C_m) - C_1 / 2."""

    metric: ufl.core.expr.Expr
    curvature: ufl.core.expr.Expr

    @classmethod
    def of_growth(cls, middle: ufl.core.expr.Expr, gradient: ufl.core.expr.Expr,
                  reference: Reference | None = None) -> RestForms:
        """From the growth's tangential block at the mid-surface (C_m) and its derivative
        through the thickness (C_1), on ``reference`` (None: a plane)."""
        curvature = -0.5 * gradient
        if reference is not None and reference.curved:
            B0 = reference.curvature
            curvature = curvature + 0.5 * (B0 * middle + middle * B0)
        return cls(middle, curvature)

    @classmethod
    def of_stretches(cls, frame: ufl.core.expr.Expr, middle: ufl.core.expr.Expr,
                     slope: ufl.core.expr.Expr, reference: Reference | None = None
                     ) -> RestForms:
        """A growth of principal stretches lam_i(zeta) = middle_i + zeta slope_i along the
        orthonormal tangential directions ``frame`` (rows v_1, v_2, in the reference's
        frame): C_g = sum lam_i^2 v_i v_i, so C_m = sum middle_i^2 v_i v_i and
        C_1 = sum 2 middle_i slope_i v_i v_i."""
        v = [ufl.as_vector([frame[i, 0], frame[i, 1]]) for i in range(2)]
        metric = sum(middle[i] ** 2 * ufl.outer(v[i], v[i]) for i in range(2))
        gradient = sum(2.0 * middle[i] * slope[i] * ufl.outer(v[i], v[i]) for i in range(2))
        return cls.of_growth(metric, gradient, reference)
