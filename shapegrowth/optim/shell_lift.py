"""A growth shell's growth carried onto the 3D wall it stands for, grown there from rest,
and the 3D wall's departure from the shell.

The shell (physics/shell.py) grows by the stretches lam_i(zeta) = m_i + zeta s_i along its
frame's tangents (its design: m_1, m_2, s_1, s_2 over the mid-surface).  The 3D wall of the
same mid-surface and thickness takes at each growth node X the eigenvalues
(m_i + zeta s_i)^2 of C_g, the shell's fields read at the mid-surface's point nearest X,
zeta the height of X above it, and 1 across the wall: the growth linear through the wall
whose expansion the shell's rest forms are.  A plate's lifts onto the 3D box (its
Cartesian frame: E1, E2, E3), a tube's about X1 onto the 3D tube (its tube frame: along,
round, across).  The 3D state is then solved from rest by continuation, as every lift.

The departure is the largest distance, over the 3D body's nodes, between the node's place
and the place the shell gives it, phi(X1, X2) + zeta d(X1, X2) (the director carries the
wall's fibres, unstretched across it), relative to the body's size.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import dolfinx.fem
import numpy as np
from mpi4py import MPI

from .. import compat
from ..config.shell_checks import SHELL_KINDS
from ..physics.boundary import body_box
from ..physics.model import ForwardModel
from ..physics.paths import solve_watched
from ..physics.shell import GrowthShell, sub_function
from ..physics.surface_points import surface_values
from ..physics.transfer import interpolate_between_meshes

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class ShellLift:
    """The 3D wall grown by a shell's growth: whether it reached an equilibrium, its DOFs,
    and its departure from the shell (relative to the body's size; None without one)."""

    converged: bool
    dofs: int
    departure: float | None


def _plane(points: np.ndarray) -> np.ndarray:
    return points[:, :2]


def _on_solid(source: dolfinx.fem.Function, space) -> np.ndarray:
    """``source`` (on the shell's plane) at the nodes of ``space`` (on the 3D body)."""
    target = dolfinx.fem.Function(space)
    interpolate_between_meshes(source, target, _plane)
    return target.x.array


def _across(points: np.ndarray, axis: int) -> tuple[np.ndarray, np.ndarray]:
    """The distance of points (n, 3) from the coordinate ``axis`` and the unit vectors away
    from it (n, 3)."""
    a, b = [i for i in range(3) if i != axis]
    r = np.hypot(points[:, a], points[:, b])
    away = np.zeros_like(points)
    away[:, a], away[:, b] = points[:, a] / r, points[:, b] / r
    return r, away


def _wall_radius(mesh, axis: int) -> float:
    """The radius of a curved shell's mid-surface about ``axis`` (its nodes'), refused where
    the mesh is not such a cylinder."""
    r = _across(mesh.geometry.x, axis)[0]
    comm = mesh.comm
    hi = comm.allreduce(float(r.max(initial=0.0)), op=MPI.MAX)
    lo = comm.allreduce(float(r.min(initial=np.inf)), op=MPI.MIN)
    if hi - lo > 1e-9 * hi:
        raise ValueError("a curved shell lifts onto the 3D tube or cylinder shell: its "
                         "mid-surface a cylinder about X1 or X3 (mid_surfaces.tube_surface)")
    return hi


def lift_shell_growth(stretches: dolfinx.fem.Function, solid: ForwardModel) -> None:
    """Set the 3D wall's growth to the shell's ``stretches`` (m_1, m_2, s_1, s_2) linear
    through the wall (collective): a plate's onto the box of the Cartesian frame, a tube's
    onto the tube of the tube frame, a cylinder shell's onto its body of the cylindrical
    frame (the shell's tangents along and round the axis are that frame's lambda_3 and
    lambda_2, lambda_1 across: config.shell_checks.SHELL_KINDS)."""
    growth = solid.growth
    curved = stretches.function_space.mesh.geometry.dim == 3
    kind = SHELL_KINDS.get(solid.cfg.geometry.kind)
    if kind is None or (kind.axis is not None) != curved or growth.frame != kind.frame \
            or len(growth.eigenvalues) != 3 or growth.angles:
        raise ValueError("a shell's growth lifts onto its own 3D body: a plate's onto a box "
                         "(Cartesian frame), a tube's onto a tube (tube frame), a cylinder "
                         "shell's onto a cylinder shell (cylindrical frame)")
    points = growth.space.tabulate_dof_coordinates()
    if kind.axis is not None:
        radius = _wall_radius(stretches.function_space.mesh, kind.axis)
        zeta = _across(points, kind.axis)[0] - radius
        values = surface_values([stretches], points)[0][0]
        parts = [values[:, i] for i in range(4)]
    else:
        zeta = points[:, 2] - _mid_plane(solid)
        parts = [_on_solid(sub_function(stretches, i), growth.space) for i in range(4)]
    for i, eigenvalue in enumerate(kind.tangents):
        growth.eigenvalues[eigenvalue].x.array[:] = (parts[i] + zeta * parts[i + 2]) ** 2
    growth.eigenvalues[kind.across].x.array[:] = 1.0


def _mid_plane(solid: ForwardModel) -> float:
    lo, hi = body_box(solid.domain.mesh)
    return 0.5 * float(lo[2] + hi[2])


def departure(shell: GrowthShell, solid: ForwardModel) -> float:
    """The largest distance of a 3D node from phi + zeta d of the shell, over the body's
    size (collective)."""
    u3 = solid.state.u
    space = u3.function_space
    mesh = space.mesh
    X = space.tabulate_dof_coordinates()
    axis = SHELL_KINDS[solid.cfg.geometry.kind].axis
    if shell.reference.curved:
        assert axis is not None, "a curved shell's 3D body is a tube or a cylinder shell"
        radius = _wall_radius(shell.mesh, axis)
        r, across = _across(X, axis)
        zeta = r - radius
        middle = X - zeta[:, None] * across  # the mid-surface's point below each node
        (moved, director), _ = surface_values(
            [shell.nodal_displacement(), shell.director_field()], middle)
    else:
        zeta = X[:, 2] - _mid_plane(solid)
        middle = X.copy()
        middle[:, 2] = 0.0
        moved = _on_solid(shell.displacement(), space).reshape(-1, 3)
        director = _on_solid(shell.director_field(), space).reshape(-1, 3)
    expected = middle + moved + zeta[:, None] * director
    placed = X + u3.x.array.reshape(-1, 3)
    owned = space.dofmap.index_map.size_local
    local = float(np.linalg.norm((placed - expected)[:owned], axis=1).max(initial=0.0))
    lo, hi = body_box(mesh)
    return mesh.comm.allreduce(local, op=MPI.MAX) / float((hi - lo).max())


def lift_shell(shell: GrowthShell, stretches: dolfinx.fem.Function,
               solid: ForwardModel) -> ShellLift:
    """The shell's growth on the 3D wall ``solid`` (at rest), solved from rest there, and its
    departure from the shell's equilibrium (collective)."""
    lift_shell_growth(stretches, solid)
    report, _, _ = solve_watched(solid.state)
    dofs = compat.global_size(solid.state.V)
    if not report.converged:
        log.warning("shell lift: no equilibrium of the 3D wall from rest: %s", report.reason)
        return ShellLift(False, dofs, None)
    return ShellLift(True, dofs, departure(shell, solid))
