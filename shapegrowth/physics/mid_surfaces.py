"""Mid-surfaces of the built-in thin bodies, as a growth shell's reference: meshes of
second-order triangles whose nodes lie on the surface, with the frame on them."""

from __future__ import annotations

import numpy as np
import ufl
from mpi4py import MPI

from .. import compat
from .shell_forms import Reference

# a P2 triangle's nodes in DOLFINx's order, each as the pair of corners it is the midpoint of
_P2_TRIANGLE = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))


def _closed_grid(around: int, along: int) -> np.ndarray:
    """P2 triangles on a grid of 2 around x (2 along + 1) nodes (node (i, k) numbered
    i (2 along + 1) + k), closed round i: each of the around x along squares cut in two."""
    corners = 2 * around
    cells = []
    for a in range(around):
        for b in range(along):
            ll, lr = (2 * a, 2 * b), (2 * a + 2, 2 * b)
            ul, ur = (2 * a, 2 * b + 2), (2 * a + 2, 2 * b + 2)
            for triangle in ((ll, lr, ur), (ll, ur, ul)):
                cells.append([(triangle[p][0] + triangle[q][0]) // 2 % corners
                              * (2 * along + 1) + (triangle[p][1] + triangle[q][1]) // 2
                              for p, q in _P2_TRIANGLE])
    return np.asarray(cells, dtype=np.int64)


def _grid_angles(around: int, along: int) -> tuple[np.ndarray, np.ndarray]:
    """The angle round and the share along (0 to 1) of each node of :func:`_closed_grid`."""
    i, k = np.meshgrid(np.arange(2 * around), np.arange(2 * along + 1), indexing="ij")
    return np.pi * i.ravel() / around, k.ravel() / (2 * along)


def tube_surface(comm: MPI.Comm, radius: float, length: float, around: int,
                 along: int, axis: int = 2) -> Reference:
    """The cylinder of ``radius`` about the X3 axis (``axis`` 2) or the X1 axis (0, the
    built-in tube's) from 0 to ``length`` along it: ``around`` x ``along`` squares of the
    (angle, along) grid, each cut in two, closed round the axis; the normal n outwards, the
    frame t1 along the axis, t2 = n x t1 round it."""
    if around < 3 or along < 1:
        raise ValueError("a tube's mesh has at least 3 cells round it and 1 along it")
    if axis not in (0, 2):
        raise ValueError("a tube's axis is X1 (0) or X3 (2)")
    # the coordinates (across, across, along) in the mesh's order
    order = [0, 1, 2] if axis == 2 else [2, 0, 1]
    if comm.rank == 0:
        angle, share = _grid_angles(around, along)
        x = np.column_stack([radius * np.cos(angle), radius * np.sin(angle),
                             length * share])[:, order]
        topology = _closed_grid(around, along)
    else:
        x, topology = np.zeros((0, 3)), np.zeros((0, 6), dtype=np.int64)
    mesh = compat.create_mesh(comm, topology, x, "triangle", degree=2)
    X = ufl.SpatialCoordinate(mesh)
    a, b = [i for i in range(3) if i != axis]
    r = ufl.sqrt(X[a] ** 2 + X[b] ** 2)
    normal = [0.0, 0.0, 0.0]
    normal[a], normal[b] = X[a] / r, X[b] / r
    along_axis = (float(axis == 0), 0.0, float(axis == 2))
    return Reference.surface(mesh, ufl.as_vector(normal), along_axis)


def annulus_surface(comm: MPI.Comm, inner: float, outer: float, around: int,
                    across: int) -> Reference:
    """The annulus inner <= r <= outer of the (X1, X2) plane: ``around`` x ``across`` cells
    of the (angle, r) grid, each cut in two, its circles' nodes on the circles."""
    if around < 3 or across < 1 or not 0.0 < inner < outer:
        raise ValueError("an annulus's mesh has 0 < inner < outer, at least 3 cells round "
                         "it and 1 across")
    if comm.rank == 0:
        angle, share = _grid_angles(around, across)
        r = inner + (outer - inner) * share
        x = np.column_stack([r * np.cos(angle), r * np.sin(angle)])
        topology = _closed_grid(around, across)
    else:
        x, topology = np.zeros((0, 2)), np.zeros((0, 6), dtype=np.int64)
    return Reference.plane(compat.create_mesh(comm, topology, x, "triangle", degree=2))
