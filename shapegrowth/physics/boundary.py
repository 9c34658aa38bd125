"""Dirichlet data: clamped named boundaries, components held on others (``boundary.fix``:
rollers, symmetry planes), or the removal of rigid motions only.

``clamp: rigid`` pins three vertices in the 3-2-1 pattern: A, the vertex nearest
the centre of the body, in every direction; B, on the X1-line through A, in X2
and X3; C, in A's X3-plane off towards +X2, in X3 (2D: A in both directions, B
in X2).  These six (three in 2D) constraints are statically determinate: they
stop the rigid motions and, under self-equilibrated loading such as growth,
carry no reaction, so they do not constrain the deformation.  Where the mesh has
no vertex exactly on that line or plane, growth alone is still reaction-free
(the body can rotate) but dead loads would see a small reaction.
"""

from __future__ import annotations

from typing import Any

import dolfinx.fem
import dolfinx.mesh
import numpy as np
from mpi4py import MPI

from .. import compat
from .geometry import Domain


def clamp_conditions(V: Any, domain: Domain, clamp: str | tuple[str, ...],
                     axisymmetric: bool = False, collapsed: Any = None) -> list:
    """Homogeneous Dirichlet conditions for the displacement space ``V`` on the named
    boundary, or on each of a list of them.  The (R, Z) section of a body of revolution has
    one rigid motion, the translation along Z: ``rigid`` pins u_Z at A alone there.  ``V``
    may be the displacement's subspace of a mixed space, ``collapsed`` its collapse (then
    the clamp's zero is a function there)."""
    mesh = domain.mesh
    names = (clamp,) if isinstance(clamp, str) else tuple(clamp)
    if names == ("rigid",):
        return _rigid_pins(V, mesh, axisymmetric)
    if names == ("none",):
        return []  # boundary.fix holds the body
    fdim = mesh.topology.dim - 1
    facets = domain.facets(names)
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)  # 0.9 does not create it
    if collapsed is not None and collapsed is not V:  # a subspace: a zero function
        dofs = dolfinx.fem.locate_dofs_topological((V, collapsed), fdim, facets)
        zero_u = dolfinx.fem.Function(collapsed)
        return [dolfinx.fem.dirichletbc(zero_u, dofs, V)]
    dofs = dolfinx.fem.locate_dofs_topological(V, fdim, facets)
    zero = np.zeros(mesh.geometry.dim, dtype=np.float64)
    return [dolfinx.fem.dirichletbc(zero, dofs, V)]


def fixed_conditions(V: Any, domain: Domain, fix: dict[str, tuple[str, ...]],
                     axes: tuple[int, ...]) -> list:
    """Homogeneous Dirichlet conditions on some components of the displacement, per named
    boundary (``boundary.fix``: rollers, symmetry planes); ``axes``: the 3D axes of the
    mesh's components (a section's (X1, X3))."""
    mesh = domain.mesh
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    bcs = []
    for name, components in fix.items():
        facets = domain.facets((name,))
        for component in components:
            sub = V.sub(axes.index(int(component[1]) - 1))
            dofs = dolfinx.fem.locate_dofs_topological(sub, fdim, facets)
            bcs.append(dolfinx.fem.dirichletbc(np.float64(0.0), dofs, sub))
    return bcs


def body_box(mesh) -> tuple[np.ndarray, np.ndarray]:
    """Global bounding box (lo, hi) of the mesh nodes, in 3 coordinates."""
    x = mesh.geometry.x
    lo = x.min(axis=0) if len(x) else np.full(3, np.inf)
    hi = x.max(axis=0) if len(x) else np.full(3, -np.inf)
    mesh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    mesh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    return lo, hi


def vertex_coordinates(mesh) -> np.ndarray:
    """Coordinates of this rank's mesh vertices (ghosts included).  A second-order geometry
    (27-node hexahedra) has nodes that are not vertices, where no pin can sit."""
    if compat.geometry_degree(mesh) == 1:
        return mesh.geometry.x
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    imap = mesh.topology.index_map(0)
    vertices = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    return mesh.geometry.x[compat.entities_to_geometry(mesh, 0, vertices).ravel()]


def best_vertex(mesh, key) -> np.ndarray:
    """Coordinates of the mesh vertex with the smallest ``key(x) -> (n, k)`` row
    (compared lexicographically), the same on every rank and for every partition."""
    x = vertex_coordinates(mesh)
    if len(x):
        keys = np.round(key(x), 12)
        order = np.lexsort((x[:, 2], x[:, 1], x[:, 0], *keys.T[::-1]))
        local = (tuple(keys[order[0]]), tuple(x[order[0]]))
    else:
        local = ((np.inf,), (0.0, 0.0, 0.0))
    best = min(mesh.comm.allgather(local))
    return np.array(best[1])


def _rigid_pins(V, mesh, axisymmetric: bool = False) -> list:
    """Pins A (all directions), B (X2, X3), C (X3) with B on the X1-line through A
    and C in A's X3-plane when the mesh has such vertices, so that any homogeneous
    deformation about A leaves the pins without reaction."""
    gdim = mesh.geometry.dim
    lo, hi = body_box(mesh)
    centre, extent = (lo + hi) / 2, hi - lo
    a = best_vertex(mesh, lambda x: np.linalg.norm(x - centre, axis=1)[:, None])

    def off_axis(x, axis, far):
        """Rows (misalignment, distance from the ideal spot) for a partner of A."""
        d = x - a
        misaligned = np.linalg.norm(np.delete(d, [axis] + ([] if gdim == 3 else [2]), axis=1)
                                    if far else d[:, [2]], axis=1)
        too_close = d[:, axis] < 0.25 * extent[axis]
        return np.column_stack([too_close, misaligned, np.abs(d[:, axis] - 0.45 * extent[axis])])

    b = best_vertex(mesh, lambda x: off_axis(x, 0, far=True))
    pins: list[tuple[np.ndarray, list[int]]] = [(a, list(range(gdim))),
                                                (b, list(range(1, gdim)))]
    if axisymmetric:
        pins = [(a, [1])]
    elif gdim == 3:
        c = best_vertex(mesh, lambda x: off_axis(x, 1, far=False))
        pins.append((c, [2]))
    tol = 1e-10 * max(float(extent.max()), 1.0)
    bcs = []
    mesh.topology.create_connectivity(0, mesh.topology.dim)  # 0.9 does not create it
    for point, components in pins:
        vertices = dolfinx.mesh.locate_entities(
            mesh, 0, lambda x, p=point: np.linalg.norm(x - p.reshape(3, 1), axis=0) < tol)
        for component in components:
            dofs = dolfinx.fem.locate_dofs_topological(V.sub(component), 0, vertices)
            bcs.append(dolfinx.fem.dirichletbc(np.float64(0.0), dofs, V.sub(component)))
    return bcs
