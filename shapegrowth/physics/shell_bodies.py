"""The growth shell of a config's thin body (``model: {dim: 2, reduction: shell}``): the
mid-surface of the box (the plane X3 = 0), of the tube (the cylinder about X1 halfway
through its wall) or of the cylinder shell (about X3), the wall's thickness, the config's
material reduced to the shell, the clamp, and the design: the growth on the wall's two
faces, the stretches a_1, a_2 along the shell's tangents (along the axis, or X1, then round
it, or X2) on the inner face (zeta = -t/2: X3 = -t/2 of the box, a cylinder's inner face)
and b_1, b_2 on the outer one, linear between them.  The shell's growth is then
lam_i(zeta) = m_i + zeta s_i with m_i = (a_i + b_i) / 2 and s_i = (b_i - a_i) / t, whose
C_g eigenvalues are lam_i^2, and 1 across the wall (optim/shell_lift.py carries it back
onto the 3D body; config.shell_checks.SHELL_KINDS names the eigenvalues).  Each face's
stretch is bounded as the 3D growth is, by the square roots of growth.eigenvalues.bounds: a
stretch between the faces then stays within them, where a bound on the slope s_i alone let
a face's stretch pass through zero (measured on the tiny arc: the shell at 2.4 %, its 3D
body 41.5 % away).

The mesh has ceil(extent / mesh.size) cells along each of the mid-surface's directions (at
least 2), doubled by each of mesh.refine.  The config's growth.eigenvalues.initial sets
the design where it starts: sqrt(lam_i) on the two faces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import dolfinx.fem
import dolfinx.mesh
import numpy as np
import ufl
from mpi4py import MPI

from .. import compat
from ..config import Config
from ..config.expressions import evaluate
from ..config.sections import resolved
from ..config.shell_checks import SHELL_KINDS
from .material import material_of
from .mid_surfaces import tube_surface
from .shell import GrowthShell, RestForms, ShellMaterial
from .shell_forms import Reference

FIELDS = 4  # a_1, a_2 (the inner face's stretches), b_1, b_2 (the outer face's)


@dataclass(frozen=True)
class ShellBody:
    """A config's shell: the shell, its design (the faces' four stretch fields), the wall's
    thickness and the body's size (its largest extent)."""

    shell: GrowthShell
    faces: dolfinx.fem.Function
    thickness: float
    size: float

    def stretches(self) -> dolfinx.fem.Function:
        """The growth as m_1, m_2, s_1, s_2 (the mid-surface's stretches and their slopes
        through the wall, optim/shell_lift.py's), from the faces' stretches."""
        out = dolfinx.fem.Function(self.faces.function_space)
        a = self.faces.x.array.reshape(-1, FIELDS)
        m = out.x.array.reshape(-1, FIELDS)
        m[:, :2] = 0.5 * (a[:, :2] + a[:, 2:])
        m[:, 2:] = (a[:, 2:] - a[:, :2]) / self.thickness
        return out


def _cells(extent: float, cfg: Config) -> int:
    return max(2, math.ceil(extent / cfg.mesh.size - 1e-9)) * 2 ** cfg.mesh.refine


def _reference(cfg: Config, comm: MPI.Comm) -> tuple[Reference, float]:
    """The mid-surface with its frame, and the body's size."""
    geo = cfg.geometry
    if geo.kind == "box":
        width = resolved(geo.width)
        mesh = dolfinx.mesh.create_rectangle(
            comm, [np.array([0.0, -width / 2]), np.array([resolved(geo.length), width / 2])],
            [_cells(resolved(geo.length), cfg), _cells(width, cfg)],
            dolfinx.mesh.CellType.triangle)
        return Reference.plane(mesh), max(resolved(geo.length), width, resolved(geo.thickness))
    axis = SHELL_KINDS[geo.kind].axis
    assert axis is not None
    extent = resolved(geo.length if axis == 0 else geo.height)
    middle = resolved(geo.radius) - resolved(geo.thickness) / 2
    reference = tube_surface(comm, middle, extent, _cells(2 * np.pi * middle, cfg),
                             _cells(extent, cfg), axis=axis)
    return reference, max(extent, 2 * resolved(geo.radius))


def _clamped(cfg: Config):
    """Where the config's clamp holds the mid-surface: at its ends (config.shell_checks)."""
    ends = SHELL_KINDS[cfg.geometry.kind].ends
    at = []
    for name in cfg.boundary.clamped:
        coordinate, key = ends[name]
        at.append((coordinate, 0.0 if key is None else float(getattr(cfg.geometry, key))))
    return lambda x: np.any([np.isclose(x[c], a) for c, a in at], axis=0)


def _faces(cfg: Config, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The 3D points (3, n) of the wall's two faces, zeta = -t/2 and +t/2, over mid-surface
    points (n, 3) (a plane mesh's third coordinate 0)."""
    half = 0.5 * resolved(cfg.geometry.thickness)
    axis = SHELL_KINDS[cfg.geometry.kind].axis
    across = np.zeros_like(points)
    if axis is None:
        across[:, 2] = 1.0
    else:
        a, b = [i for i in range(3) if i != axis]
        r = np.hypot(points[:, a], points[:, b])
        across[:, a], across[:, b] = points[:, a] / r, points[:, b] / r
    return (points - half * across).T, (points + half * across).T


def set_initial(cfg: Config, faces: dolfinx.fem.Function) -> None:
    """The design from growth.eigenvalues.initial: sqrt(lambda_i) on the inner and the outer
    face (collective)."""
    initial = cfg.growth.eigenvalues.initial or (1.0, 1.0, 1.0)
    points = faces.function_space.tabulate_dof_coordinates()
    inner, outer = _faces(cfg, points)
    params, axis = cfg.expression_params, cfg.cylinder_axis
    values = faces.x.array.reshape(-1, FIELDS)
    for i, eigenvalue in enumerate(SHELL_KINDS[cfg.geometry.kind].tangents):
        values[:, i] = np.sqrt(evaluate(initial[eigenvalue], inner, params, axis))
        values[:, 2 + i] = np.sqrt(evaluate(initial[eigenvalue], outer, params, axis))
    faces.x.scatter_forward()


def design_bounds(cfg: Config) -> tuple[list[float], list[float]]:
    """Each face's stretches within the square roots of growth.eigenvalues.bounds."""
    lo, hi = (math.sqrt(b) for b in cfg.growth.eigenvalues.bounds)
    return [lo] * FIELDS, [hi] * FIELDS


def shell_body(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> ShellBody:
    """The shell of ``cfg``'s box or tube, at rest, its design set from the config's initial
    growth (collective)."""
    if cfg.geometry.kind not in SHELL_KINDS:
        raise ValueError(f"a shell is built for {', '.join(SHELL_KINDS)}, not "
                         f"{cfg.geometry.kind}")
    reference, size = _reference(cfg, comm)
    mesh = reference.mesh
    faces = dolfinx.fem.Function(compat.vector_space(mesh, cfg.growth.degree or 1, FIELDS))
    thickness = resolved(cfg.geometry.thickness)
    middle = ufl.as_vector([0.5 * (faces[i] + faces[2 + i]) for i in range(2)])
    slope = ufl.as_vector([(faces[2 + i] - faces[i]) / thickness for i in range(2)])
    rest = RestForms.of_stretches(ufl.Identity(2), middle, slope,
                                  reference if reference.curved else None)
    material = ShellMaterial.of_energy(material_of(cfg))
    shell = GrowthShell(mesh, thickness, material, rest, _clamped(cfg), design=faces,
                        reference=reference if reference.curved else None)
    set_initial(cfg, faces)
    return ShellBody(shell, faces, thickness, size)
