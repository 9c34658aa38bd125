"""How a model's mesh stands for the body: the 3D solid itself, a plane body, or the section
of a 3D body reduced by plane strain, plane stress or axial symmetry (``model.reduction``).

A *section* keeps the 3D body's coordinates, growth and target: its 2D mesh lies in the plane
``model.plane`` (x1x3: mesh coordinates (X1, X3); axisymmetric: (R, Z) with R along X1 and the
axis X3), a mesh point stands for the 3D point (X1, 0, X3) (the mid-plane X2 = 0, or the
meridian theta = 0), the growth keeps its three eigenvalues in the 3D frame there, and the
target map gives 3D points, of which the section keeps the plane's two coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SOLID, PLANE_BODY, SHELL = "solid", "plane_body", "shell"
SECTIONED = ("box", "annulus", "cylinder_shell")  # 3D bodies that have a 2D section model


@dataclass(frozen=True)
class Section:
    """``kind``: ``solid`` (3D), ``plane_body`` (a 2D body in X1-X2, two growth eigenvalues),
    or the reduction of a sectioned 3D body (``plane_strain``, ``plane_stress``,
    ``axisymmetric``); ``stress_free`` says whether the third direction is free of stress
    (plane stress) - for a plane body too; ``axes``: the 3D axes (0-based) of the mesh
    coordinates."""

    kind: str
    axes: tuple[int, ...]
    stress_free: bool = False

    @property
    def reduced(self) -> bool:
        """A 2D model of a 3D body (its growth and target are the 3D body's)."""
        return self.kind not in (SOLID, PLANE_BODY, SHELL)

    @property
    def axisymmetric(self) -> bool:
        return self.kind == "axisymmetric"

    @property
    def out_of_plane(self) -> int:
        """The 3D axis the mesh does not span (X2 for x1x3; the hoop direction at theta = 0)."""
        return next(i for i in range(3) if i not in self.axes)

    def embed(self, X: np.ndarray) -> np.ndarray:
        """The 3D points (3, n) that mesh points X (at least (len(axes), n)) stand for."""
        out = np.zeros((3, X.shape[1]))
        for k, axis in enumerate(self.axes):
            out[axis] = X[k]
        return out

    def in_plane(self, points: np.ndarray) -> np.ndarray:
        """The mesh coordinates (n, len(axes)) of 3D points (n, 3) that lie in the plane (a
        target map's values at the section's points)."""
        return np.ascontiguousarray(points[:, list(self.axes)])

    def coordinates_of(self, points: np.ndarray) -> np.ndarray:
        """The mesh point (n, 2) that 3D points (n, 3) of the body are carried from (the
        lift): the projection on the plane, or (R, Z) for a body of revolution."""
        if self.axisymmetric:
            return np.column_stack([np.hypot(points[:, 0], points[:, 1]), points[:, 2]])
        return self.in_plane(points)

    def deformed_points(self, points: np.ndarray, u: np.ndarray) -> np.ndarray:
        """The deformed 3D positions (n, 3) of 3D points (n, 3) of the body, given the
        section's displacement u (n, 2) at their section points: in the plane, the
        out-of-plane coordinate kept (the section's mid-plane map); for a body of revolution,
        the section's motion turned to each point's own angle."""
        if self.axisymmetric:
            R = np.hypot(points[:, 0], points[:, 1])
            theta = np.arctan2(points[:, 1], points[:, 0])
            r = R + u[:, 0]
            return np.column_stack([r * np.cos(theta), r * np.sin(theta), points[:, 2] + u[:, 1]])
        out = points.copy()
        for k, axis in enumerate(self.axes):
            out[:, axis] += u[:, k]
        return out


def section_of(dim: int, kind: str, reduction: str) -> Section:
    """The Section of a config's model keys (checked by checks.py; a section's plane is
    x1x3, the only one a sectioned body has)."""
    if dim == 3:
        return Section(SOLID, (0, 1, 2))
    if reduction == SHELL:  # a thin 3D body's mid-surface (physics/shell_bodies.py)
        return Section(SHELL, (0, 1, 2))
    if kind not in SECTIONED:
        return Section(PLANE_BODY, (0, 1), stress_free=reduction == "plane_stress")
    return Section(reduction, (0, 2), stress_free=reduction == "plane_stress")
