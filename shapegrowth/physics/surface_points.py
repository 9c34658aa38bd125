"""Fields of a surface mesh in space (a triangle mesh of gdim 3, curved cells included) at
points near it: each point's nearest point of the discrete surface, found cell by cell, and
the field's value there.

dolfinx's point location takes a point in a cell, which a point of a curved surface is not
(it lies on the second-order cell's surface, outside the convex hull of its nodes, or off
it by the geometry's error): measured on the tube of 8 cells round, none of 200 points of
the exact cylinder was found.  Here the point nearest each given point is found on the
cells nearest it (Gauss-Newton on the cell's map, held in the reference triangle), and the
field's Lagrange basis is tabulated there.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import basix
import dolfinx.fem
import numpy as np
from scipy.spatial import cKDTree

from .. import compat

CANDIDATES = 8  # cells tried per point, the nearest by their centroids
NEWTON_STEPS = 8


@dataclass(frozen=True)
class SurfacePoints:
    """Where given points fall on this rank's cells: the cell (local index), the
    reference coordinates in it, and the distance from the point (inf: no cell here)."""

    cells: np.ndarray
    reference: np.ndarray
    distance: np.ndarray


def _triangle(degree: int):
    return basix.create_element(basix.ElementFamily.P, basix.CellType.triangle, degree,
                                basix.LagrangeVariant.gll_warped)


def _clamped(X: np.ndarray) -> np.ndarray:
    """Reference points held in the triangle X1, X2 >= 0, X1 + X2 <= 1 (projected where
    outside)."""
    X = np.maximum(X, 0.0)
    over = X.sum(axis=-1) > 1.0
    X[over] = X[over] / X[over].sum(axis=-1, keepdims=True)
    return X


def locate(mesh, points: np.ndarray) -> SurfacePoints:
    """The nearest point of this rank's owned cells of the surface ``mesh`` to each of
    ``points`` (n, 3)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    nodes = compat.geometry_nodes(mesh)[:owned]
    n = len(points)
    if owned == 0 or n == 0:
        return SurfacePoints(np.zeros(n, np.int32), np.zeros((n, 2)), np.full(n, np.inf))
    x = mesh.geometry.x[nodes]  # (cells, nodes, 3)
    element = _triangle(compat.geometry_degree(mesh))
    _, near = cKDTree(x[:, :3].mean(axis=1)).query(points, k=min(CANDIDATES, owned))
    near = near.reshape(n, -1)
    X = np.full(near.shape + (2,), 1.0 / 3.0)
    for _ in range(NEWTON_STEPS):
        table = element.tabulate(1, X.reshape(-1, 2))[:, :, :, 0]  # (3, pairs, nodes)
        cell_x = x[near.ravel()]  # (pairs, nodes, 3)
        where = np.einsum("pn,pnk->pk", table[0], cell_x)
        jac = np.stack([np.einsum("pn,pnk->pk", table[1 + j], cell_x) for j in range(2)],
                       axis=-1)  # (pairs, 3, 2)
        gap = np.repeat(points, near.shape[1], axis=0) - where
        # b as a stack of columns: numpy 2 takes a 2D b as a stack of matrices
        step = np.linalg.solve(np.einsum("pki,pkj->pij", jac, jac),
                               np.einsum("pki,pk->pi", jac, gap)[..., None])[..., 0]
        X = _clamped(X + step.reshape(X.shape))
    table = element.tabulate(0, X.reshape(-1, 2))[0, :, :, 0]
    where = np.einsum("pn,pnk->pk", table, x[near.ravel()]).reshape(near.shape + (3,))
    distance = np.linalg.norm(where - points[:, None, :], axis=-1)
    best = distance.argmin(axis=1)
    rows = np.arange(n)
    return SurfacePoints(near[rows, best].astype(np.int32), X[rows, best],
                         distance[rows, best])


def surface_values(fields: Sequence[dolfinx.fem.Function], points: np.ndarray
                   ) -> tuple[list[np.ndarray], np.ndarray]:
    """The values of each of ``fields`` (Lagrange of degree 1 or 2, scalar or blocked, on
    one surface mesh in space) at the surface's points nearest this rank's ``points``
    (n, 3), the points found once for all of them, and their distances from them
    (collective: each rank asks for its own points)."""
    mesh = fields[0].function_space.mesh
    comm = mesh.comm
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    asked = comm.allgather(points)
    offset = sum(len(p) for p in asked[:comm.rank])
    found = locate(mesh, np.concatenate(asked))
    here = np.isfinite(found.distance)
    mine = slice(offset, offset + len(points))
    # every rank's answer for this rank's points: the nearest cell of all wins
    distances = np.array(comm.allgather(found.distance))[:, mine]  # (ranks, n)
    winner = distances.argmin(axis=0)
    chosen = []
    for f in fields:
        space = f.function_space
        bs = space.dofmap.index_map_bs
        values = np.full((len(found.cells), bs), np.nan)
        if here.any():
            table = _triangle(compat.space_degree(space)).tabulate(
                0, found.reference[here])[0, :, :, 0]  # (points, dofs)
            dofs = np.array([space.dofmap.cell_dofs(c) for c in found.cells[here]])
            local = f.x.array.reshape(-1, bs)[dofs]  # (points, dofs, bs)
            values[here] = np.einsum("pn,pnb->pb", table, local)
        everyone = np.array(comm.allgather(values))[:, mine]  # (ranks, n, bs)
        chosen.append(everyone[winner, np.arange(len(points))].reshape(-1, bs))
    return chosen, distances.min(axis=0)
