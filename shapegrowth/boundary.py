"""Dirichlet data: a clamped named boundary, or the removal of rigid motions only.

``clamp: rigid`` pins three vertices in the 3-2-1 pattern: one vertex near the
centre of the body in every direction, one near the X1 end of the centre line
in X2 and X3, one near the X2 end in X3 (2D: the first in both directions, the
second in X2).  These six (three in 2D) constraints are statically determinate:
they stop the rigid motions and, under self-equilibrated loading such as growth,
carry no reaction, so they do not constrain the deformation.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

import dolfinx.fem
import dolfinx.mesh

from .geometry import Domain


def clamp_conditions(V, domain: Domain, clamp: str) -> list:
    """Homogeneous Dirichlet conditions for the displacement space ``V``."""
    mesh = domain.mesh
    if clamp == "rigid":
        return _rigid_pins(V, mesh)
    fdim = mesh.topology.dim - 1
    facets = domain.facet_tags.find(domain.boundaries[clamp])
    dofs = dolfinx.fem.locate_dofs_topological(V, fdim, facets)
    zero = np.zeros(mesh.geometry.dim, dtype=np.float64)
    return [dolfinx.fem.dirichletbc(zero, dofs, V)]


def body_box(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Global bounding box (lo, hi) of the mesh nodes, in 3 coordinates."""
    x = mesh.geometry.x
    lo = x.min(axis=0) if len(x) else np.full(3, np.inf)
    hi = x.max(axis=0) if len(x) else np.full(3, -np.inf)
    mesh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    mesh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    return lo, hi


def nearest_vertex(mesh, point: np.ndarray) -> np.ndarray:
    """Coordinates of the mesh vertex nearest to ``point``, the same on every rank and
    for every partition (ties broken by the coordinates themselves)."""
    x = mesh.geometry.x
    if len(x):
        d = np.linalg.norm(x - point, axis=1)
        i = np.lexsort((x[:, 2], x[:, 1], x[:, 0], np.round(d, 12)))[0]
        local = (round(float(d[i]), 12), tuple(x[i]))
    else:
        local = (np.inf, (0.0, 0.0, 0.0))
    best = min(mesh.comm.allgather(local))
    return np.array(best[1])


def _rigid_pins(V, mesh) -> list:
    gdim = mesh.geometry.dim
    lo, hi = body_box(mesh)
    centre, extent = (lo + hi) / 2, hi - lo
    a = nearest_vertex(mesh, centre)
    b = nearest_vertex(mesh, centre + 0.45 * extent[0] * np.eye(3)[0])
    pins = [(a, range(gdim)), (b, range(1, gdim))]
    if gdim == 3:
        c = nearest_vertex(mesh, centre + 0.45 * extent[1] * np.eye(3)[1])
        pins.append((c, [2]))
    tol = 1e-10 * max(float(extent.max()), 1.0)
    bcs = []
    for point, components in pins:
        vertices = dolfinx.mesh.locate_entities(
            mesh, 0, lambda x, p=point: np.linalg.norm(x - p.reshape(3, 1), axis=0) < tol)
        for c in components:
            dofs = dolfinx.fem.locate_dofs_topological(V.sub(c), 0, vertices)
            bcs.append(dolfinx.fem.dirichletbc(np.float64(0.0), dofs, V.sub(c)))
    return bcs
