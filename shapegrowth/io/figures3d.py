"""3D views of a deformed body over its translucent target (a run's shape3d.png).

A 3D model draws its boundary.  A section model is swept back into the 3D body it stands
for: the section's boundary extruded across the body (a plane section of a box) or
revolved about X3 (a body of revolution), its displacement carried along.  A target map
is drawn as the image Phi_d of the same reference surface, so body and target share their
triangles; a target from a file is drawn as its sample points.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..config import Config
from ..config.expressions import evaluate
from .plotting import Place, Surface, draw, equal_axes_3d, placed, surface

REVOLUTION_SEGMENTS = 64


@dataclass(frozen=True)
class View:
    """Elevation and azimuth of the camera, degrees (matplotlib's convention)."""

    elevation: float = 24.0
    azimuth: float = -62.0


def boundary_edges(triangles: np.ndarray) -> np.ndarray:
    """The edges (m, 2) that bound one triangle only: a 2D mesh's boundary."""
    edges = np.sort(np.concatenate([triangles[:, [0, 1]], triangles[:, [1, 2]],
                                    triangles[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1]


def _extruded(section: Surface, axes: tuple[int, ...], across: int,
              span: tuple[float, float]) -> Surface:
    """The plane section's boundary extruded along the 3D axis ``across`` over ``span``,
    closed by the section's own triangles at both ends."""
    n = len(section.reference)
    edges = boundary_edges(section.triangles)

    def lift(points2: np.ndarray, value: float) -> np.ndarray:
        out = np.zeros((len(points2), 3))
        out[:, axes[0]], out[:, axes[1]] = points2[:, 0], points2[:, 1]
        out[:, across] = value
        return out

    reference = np.vstack([lift(section.reference, s) for s in span])
    deformed = np.vstack([lift(section.deformed, s) for s in span])
    sides = np.vstack([np.column_stack([edges[:, 0], edges[:, 1], edges[:, 1] + n]),
                       np.column_stack([edges[:, 0], edges[:, 1] + n, edges[:, 0] + n])])
    triangles = np.vstack([sides, section.triangles, section.triangles + n])
    values = None if section.values is None else np.concatenate([section.values] * 2)
    return Surface(reference, deformed, triangles, values)


def _revolved(section: Surface, segments: int = REVOLUTION_SEGMENTS) -> Surface:
    """The (R, Z) section's boundary revolved about X3 (the hoop displacement is zero)."""
    edges = boundary_edges(section.triangles)
    used = np.unique(edges)
    index = np.full(len(section.reference), -1)
    index[used] = np.arange(len(used))
    m = len(used)
    theta = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)

    def revolve(points2: np.ndarray) -> np.ndarray:
        r, z = points2[used, 0], points2[used, 1]
        return np.concatenate([np.column_stack([r * np.cos(t), r * np.sin(t), z])
                               for t in theta])

    a, b = index[edges[:, 0]], index[edges[:, 1]]
    triangles = []
    for k in range(segments):
        here, there = k * m, ((k + 1) % segments) * m
        triangles += [np.column_stack([a + here, b + here, b + there]),
                      np.column_stack([a + here, b + there, a + there])]
    values = None if section.values is None else np.tile(section.values[used], segments)
    return Surface(revolve(section.reference), revolve(section.deformed),
                   np.vstack(triangles), values)


def body_surface(cfg: Config, u, field, place: Place | None = None) -> Surface | None:
    """The deformed body's 3D boundary coloured by ``field`` (collective), placed by
    ``place`` (a section's points before they are lifted); None for a plane body, which is
    its own 2D picture (shape.png)."""
    section = cfg.section
    drawn = placed(surface(u, field), place, u.function_space.mesh.geometry.dim)
    if cfg.dim == 3:
        return drawn
    if not section.reduced:
        return None
    if section.axisymmetric:
        return _revolved(drawn)
    across = ({0, 1, 2} - set(section.axes)).pop()
    g = cfg.geometry
    half = float((g.width if across == 1 else g.thickness) or 0.0) / 2  # centred across
    return _extruded(drawn, section.axes, across, (-half, half))


def map_target(cfg: Config, body: Surface, place: Place | None = None) -> Surface | None:
    """Phi_d on the body's reference surface, where the target is a map (placed by
    ``place``, a 3D body's)."""
    target = cfg.target
    if target is None or target.map is None:
        return None
    X = body.reference.T
    points = np.column_stack([evaluate(e, X, cfg.expression_params, cfg.cylinder_axis)
                              for e in target.map])
    if place is not None and cfg.dim == 3:
        points = place(points)
    return Surface(body.reference, points, body.triangles, None)


def write_shape3d_png(path, cfg: Config, u, field, target_points: np.ndarray, label: str,
                      view: View = View(), places: tuple[Place | None, Place | None] = (None,
                                                                                      None)
                      ) -> bool:
    """The deformed body (coloured by ``field``) over its translucent target, in 3D
    (collective; rank 0 writes); ``places``: how the body and a map's image are placed
    (objective.placement: fitted).  False where the body is a plane body (nothing written)."""
    comm = u.function_space.mesh.comm
    body = body_surface(cfg, u, field, places[0])
    if body is None:
        return False
    target = map_target(cfg, body, places[1])
    cloud = None if target is not None else np.concatenate(comm.allgather(target_points))
    if comm.rank != 0:
        return True
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7.0, 5.6), dpi=120)
    # the translucent target painted over the body wherever they overlap (a good fit would
    # otherwise hide it inside the body)
    ax: Any = fig.add_subplot(projection="3d", computed_zorder=False)  # an Axes3D
    dense = len(body.triangles) > 3000  # edges would hide the colours
    artist = draw(ax, body, edgecolor=(0, 0, 0, 0.3), linewidth=0.0 if dense else 0.1)
    everything = [body.deformed]
    if target is not None:
        shade = draw(ax, target, alpha=0.18, linewidth=0.0, facecolor=(0.45, 0.45, 0.45))
        shade.set_zorder(2)
        everything.append(target.deformed)
    elif cloud is not None and len(cloud):
        every = max(1, len(cloud) // 6000)
        shown = cloud[::every]
        ax.scatter(shown[:, 0], shown[:, 1], shown[:, 2], s=0.5, c="0.3", alpha=0.25,
                   depthshade=False)
        everything.append(cloud)
    equal_axes_3d(ax, np.vstack(everything))
    ax.view_init(elev=view.elevation, azim=view.azimuth)
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    ax.set_zlabel("$x_3$")
    fig.colorbar(artist, ax=ax, label=label, shrink=0.6, pad=0.1)
    ax.set_title("deformed body over the target (grey)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    return True

