"""Pictures of bodies with matplotlib: the deformed boundary surface (3D) or the deformed
mesh (2D), coloured by a field, and eigenvector glyphs.  For notebooks and figures of
small meshes: everything is gathered on every rank, and rank 0 draws.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import dolfinx.fem
import numpy as np

from .. import compat
from ..shape.facet_clouds import boundary_facets


@dataclass
class Surface:
    """Triangles of the boundary (3D) or of the cells (2D) with their vertex positions."""

    reference: np.ndarray  # (n, 3) vertex positions X
    deformed: np.ndarray  # (n, 3) Phi(X) = X + u(X)
    triangles: np.ndarray  # (m, 3) indices into the positions
    values: np.ndarray | None  # (n,) a field at the vertices, or None


def surface(u: dolfinx.fem.Function, field: dolfinx.fem.Function | None = None) -> Surface:
    """The body's boundary triangles (its cells in 2D), deformed by the displacement ``u``
    and coloured by the scalar ``field`` (both evaluated at the vertices)."""
    mesh = u.function_space.mesh
    comm, tdim = mesh.comm, mesh.topology.dim
    if tdim == 3:  # the boundary facets by their vertices
        nodes = _triangles(compat.entities_to_geometry(mesh, tdim - 1, boundary_facets(mesh)))
    else:  # the cells by all their geometry nodes (a 9-node quadrilateral follows its curve)
        owned = mesh.topology.index_map(tdim).size_local
        nodes = _triangles(compat.geometry_nodes(mesh)[:owned])
    x = mesh.geometry.x
    used = np.unique(nodes)
    pieces = comm.allgather((x[used], nodes, used))
    points, triangles, offset = [], [], 0
    for coords, tri, used in pieces:
        local = np.searchsorted(used, tri)
        points.append(coords)
        triangles.append(local + offset)
        offset += len(coords)
    X = np.concatenate(points)
    tri = np.concatenate(triangles).astype(int)
    disp = compat.evaluate_at_points(u, X)
    disp = np.nan_to_num(disp)
    shift = np.zeros_like(X)
    shift[:, :disp.shape[1]] = disp
    values = None if field is None else compat.evaluate_at_points(field, X)[:, 0]
    return Surface(X, X + shift, tri, values)


# Triangles of a facet (or 2D cell) from its geometry nodes in dolfinx's order: a quadrilateral
# is tensor-product ordered (corners (0,0) (1,0) (0,1) (1,1), then the edges' mid-nodes on
# edges 0-1, 0-2, 1-3, 2-3, then the centre), so a 9-node one is split through its mid-nodes
# into 8 triangles that follow its curvature
_SPLITS = {
    3: [(0, 1, 2)],
    4: [(0, 1, 3), (0, 3, 2)],
    9: [(0, 4, 8), (0, 8, 5), (4, 1, 6), (4, 6, 8), (5, 8, 7), (5, 7, 2), (8, 6, 3), (8, 3, 7)],
}


def _triangles(nodes: np.ndarray) -> np.ndarray:
    """(m, 3) triangles of facets or cells given by their geometry nodes (rows); a 6-node
    triangle by its corners (straight-sided)."""
    split = _SPLITS.get(nodes.shape[1], _SPLITS[3])
    return np.concatenate([nodes[:, list(t)] for t in split]) if len(nodes) else nodes[:, :3]


def draw(ax, surf: Surface, deformed: bool = True, cmap: str = "viridis",
         alpha: float = 1.0, edgecolor=None, clim=None,
         plane: tuple[int, int] = (0, 1), facecolor: tuple[float, float, float] | None = None,
         linewidth: float = 0.2):
    """Draw on a matplotlib axis: 3D axes show the surface, 2D axes its projection on the
    coordinate ``plane`` ((0, 2): a side view X1-X3); returns the mappable."""
    P = surf.deformed if deformed else surf.reference
    if getattr(ax, "name", "") == "3d":
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection

        faces = P[surf.triangles]
        poly = Poly3DCollection(faces, alpha=alpha, linewidths=linewidth,
                                edgecolor=edgecolor or (0, 0, 0, 0.15))
        if surf.values is not None:
            poly.set_array(surf.values[surf.triangles].mean(axis=1))
            poly.set_cmap(cmap)
            if clim is not None:
                poly.set_clim(*clim)
        else:
            poly.set_facecolor((*(facecolor or (0.55, 0.7, 0.9)), alpha))
        ax.add_collection3d(poly)
        equal_axes_3d(ax, P)
        return poly
    import matplotlib.tri as mtri

    triang = mtri.Triangulation(P[:, plane[0]], P[:, plane[1]], surf.triangles)
    if surf.values is not None:
        artist = ax.tripcolor(triang, surf.values, shading="gouraud", cmap=cmap)
        if clim is not None:
            artist.set_clim(*clim)
    else:
        artist = None
    ax.triplot(triang, color=edgecolor or "0.3", lw=0.3)
    ax.set_aspect("equal")
    return artist


def equal_axes_3d(ax, P: np.ndarray) -> None:
    """Equal scales on a 3D axis, around the points (n, 3)."""
    lo, hi = P.min(axis=0), P.max(axis=0)
    centre, half = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))


Place = Callable[[np.ndarray], np.ndarray]  # the body's points (mesh coordinates) as compared


def placed(surf: Surface, place: Place | None, gdim: int) -> Surface:
    """``surf`` (of a mesh of dimension ``gdim``) with its deformed points moved by
    ``place`` (objective.placement: fitted)."""
    if place is None:
        return surf
    moved = surf.deformed.copy()
    moved[:, :gdim] = place(surf.deformed[:, :gdim])
    return Surface(surf.reference, moved, surf.triangles, surf.values)


def write_shape_png(path, u: dolfinx.fem.Function, field: dolfinx.fem.Function,
                    target_points: np.ndarray, label: str, place: Place | None = None) -> None:
    """The deformed body coloured by ``field`` (placed by ``place``) with the target's sample
    points as dots, seen along the axis in which the body is thinnest (a side view of a beam,
    the plane of a 2D body).  Collective; rank 0 writes."""
    comm = u.function_space.mesh.comm
    surf = placed(surface(u, field), place, u.function_space.mesh.geometry.dim)
    target = np.concatenate(comm.allgather(np.asarray(target_points)))
    if comm.rank != 0:
        return
    from matplotlib.figure import Figure

    target3 = np.zeros((len(target), 3))
    target3[:, :target.shape[1]] = target
    extent = np.ptp(np.vstack([surf.deformed, target3]), axis=0)
    plane = tuple(sorted(np.argsort(extent)[-2:])) if u.function_space.mesh.geometry.dim == 3 \
        else (0, 1)
    span = extent[list(plane)]
    fig = Figure(figsize=(7.0, max(2.4, min(6.0, 7.0 * span[1] / max(span[0], 1e-12)))),
                 dpi=120)
    ax = fig.subplots()
    artist = draw(ax, surf, plane=plane, edgecolor="0.85")
    every = max(1, len(target3) // 4000)
    ax.plot(target3[::every, plane[0]], target3[::every, plane[1]], ".", ms=1.2, color="k",
            alpha=0.35, label="target")
    if artist is not None:
        fig.colorbar(artist, ax=ax, label=label)
    ax.set_xlabel(f"$x_{plane[0] + 1}$")
    ax.set_ylabel(f"$x_{plane[1] + 1}$")
    ax.legend(loc="best", fontsize=7, markerscale=6)
    fig.tight_layout()
    fig.savefig(path)


def write_frame_png(path, u: dolfinx.fem.Function, eigenvalues: list[dolfinx.fem.Function],
                    angle: dolfinx.fem.Function, target_points: np.ndarray) -> None:
    """The eigenvector field of a free 2D frame on the deformed body: v1 (dark) and v2
    (light) at the vertices, each drawn with length proportional to its stretch
    sqrt(lambda_i), over the body coloured by lambda_hat_1 and the target's points.
    Collective; rank 0 writes."""
    comm = u.function_space.mesh.comm
    surf = surface(u, eigenvalues[0])
    lam2 = compat.evaluate_at_points(eigenvalues[1], surf.reference)[:, 0]
    a = compat.evaluate_at_points(angle, surf.reference)[:, 0]
    target = np.concatenate(comm.allgather(np.asarray(target_points)))
    if comm.rank != 0:
        return
    from matplotlib.figure import Figure

    fig = Figure(figsize=(6.4, 5.6), dpi=120)
    ax = fig.subplots()
    artist = draw(ax, surf, edgecolor="0.85")
    every = max(1, len(target) // 4000)
    ax.plot(target[::every, 0], target[::every, 1], ".", ms=1.0, color="r", alpha=0.25)
    assert surf.values is not None  # coloured by lambda_1
    pick = slice(None, None, max(1, len(a) // 500))  # at most ~500 glyphs
    P, a, lam1, lam2 = surf.deformed[pick], a[pick], surf.values[pick], lam2[pick]
    span = np.ptp(surf.deformed[:, :2], axis=0).max()
    scale = 0.05 * span / np.sqrt(max(lam1.max(), lam2.max()))
    for v, lam, colour in (((np.cos(a), np.sin(a)), lam1, "k"),
                           ((-np.sin(a), np.cos(a)), lam2, "0.55")):
        length = scale * np.sqrt(lam)
        ax.quiver(P[:, 0], P[:, 1], v[0] * length, v[1] * length, color=colour, pivot="mid",
                  angles="xy", scale_units="xy", scale=1.0, headwidth=0, headlength=0,
                  headaxislength=0, width=0.004)
    fig.colorbar(artist, ax=ax, label="lambda_hat_1")
    ax.set_title("eigenvectors v1 (dark), v2 (light), length ~ sqrt(lambda_i)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
