"""A growth shell's growth carried onto the 3D wall it stands for, grown there from rest,
and the 3D wall's departure from the shell.

The shell (physics/shell.py) of a plate grows by the stretches lam_i(zeta) = m_i + zeta
s_i along E1 and E2 (its design: m_1, m_2, s_1, s_2 over the plane).  The 3D box of the
same plane and thickness, its mid-plane at zeta = 0, takes at each growth node X the
eigenvalues (m_i + zeta s_i)^2 of C_g in the Cartesian frame, zeta = X3 - the mid-plane's
height, and 1 across the wall: the growth linear through the wall that the shell's rest
forms abar = C_m, bbar = -C_1 / 2 are the expansion of.  The 3D state is then solved from
rest by continuation, as every lift.

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
from ..physics.boundary import body_box
from ..physics.model import ForwardModel
from ..physics.paths import solve_watched
from ..physics.shell import GrowthShell, sub_function
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


def lift_shell_growth(stretches: dolfinx.fem.Function, solid: ForwardModel) -> None:
    """Set the 3D box's growth to the shell's ``stretches`` (m_1, m_2, s_1, s_2) linear
    through the wall (collective)."""
    growth = solid.growth
    if growth.frame != "cartesian" or len(growth.eigenvalues) != 3 or growth.angles:
        raise ValueError("a shell's growth lifts onto a 3D body of the Cartesian frame")
    mid = _mid_plane(solid)
    parts = [_on_solid(sub_function(stretches, i), growth.space) for i in range(4)]
    zeta = growth.space.tabulate_dof_coordinates()[:, 2] - mid
    for i in range(2):
        growth.eigenvalues[i].x.array[:] = (parts[i] + zeta * parts[i + 2]) ** 2
    growth.eigenvalues[2].x.array[:] = 1.0


def _mid_plane(solid: ForwardModel) -> float:
    lo, hi = body_box(solid.domain.mesh)
    return 0.5 * float(lo[2] + hi[2])


def departure(shell: GrowthShell, solid: ForwardModel) -> float:
    """The largest distance of a 3D node from phi + zeta d of the shell, over the body's
    size (collective)."""
    u3 = solid.state.u
    space = u3.function_space
    mesh = space.mesh
    u, theta = shell.displacement(), shell.angles()
    shell_u = _on_solid(u, space).reshape(-1, 3)
    angles = _on_solid(theta, compat.vector_space(mesh, compat.space_degree(space), 2)
                       ).reshape(-1, 2)
    t1, t2 = angles[:, 0], angles[:, 1]
    director = np.column_stack([np.sin(t2) * np.cos(t1), -np.sin(t1),
                                np.cos(t2) * np.cos(t1)])
    X = space.tabulate_dof_coordinates()
    zeta = X[:, 2] - _mid_plane(solid)
    plane = X.copy()
    plane[:, 2] = 0.0
    expected = plane + shell_u + zeta[:, None] * director
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
