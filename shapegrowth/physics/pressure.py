"""A follower pressure on a named boundary (``loads.pressure``), as the potential of the volume
the boundary encloses.

A pressure p pushes the deformed surface Gamma along minus its outward normal n: its virtual
work is -p int_Gamma n . du da, which is p dV, V the volume enclosed by Gamma (minus the body:
a cavity's),

    V(u) = -1/d int_Gamma (x - x0) . n da = -1/d int_Gamma0 (x - x0) . cof(F) N dA,

x = X + u, whenever Gamma is closed, or its rim is held (clamped: du = 0), or its rim slides
in symmetry planes through x0 (``boundary.fix`` holding the plane's normal component, x0 on
the plane: the rim's term (x - x0) x du . dl vanishes).  The load is then the energy
-p V(u): its residual, its exact tangent (symmetric, so the LDL^T solvers and the adjoint
stay as they are) and its derivatives come from UFL like the elastic energy's.  A surface
whose rim is free has no such potential and is refused, naming the key.

d is the mesh's dimension (a plane body's pressure is per unit thickness).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import ufl
from mpi4py import MPI

from ..config import Config, ConfigError
from .geometry import Domain

# the edges of a facet by its vertices in dolfinx's numbering (2D: a facet is an edge)
_FACET_EDGES = {"triangle": [(0, 1), (0, 2), (1, 2)],
                "quadrilateral": [(0, 1), (0, 2), (1, 3), (2, 3)]}


def pressure_energy(domain: Domain, cfg: Config, u: Any, metadata: dict[str, Any],
                    scale: Any) -> Any:
    """-p V(u) summed over loads.pressure's boundaries (a UFL form), or None without any."""
    mesh = domain.mesh
    d = mesh.geometry.dim
    F = ufl.Identity(d) + ufl.grad(u)
    N = ufl.FacetNormal(mesh)
    x = ufl.SpatialCoordinate(mesh) + u
    energy = None
    for name, p in cfg.loads.pressure.items():
        if p == 0:
            continue
        x0 = reference_point(domain, cfg, name)
        term = scale * float(p) / d * ufl.dot(x - ufl.as_vector(x0[:d]), ufl.cofac(F) * N) \
            * domain.ds(name, metadata)
        energy = term if energy is None else energy + term
    return energy


def enclosed_volume(domain: Domain, cfg: Config, name: str, u: Any) -> Any:
    """V(u) of the named boundary as a UFL form (a volume, per unit thickness in 2D)."""
    mesh = domain.mesh
    d = mesh.geometry.dim
    F = ufl.Identity(d) + ufl.grad(u)
    x = ufl.SpatialCoordinate(mesh) + u
    x0 = reference_point(domain, cfg, name)
    return -1.0 / d * ufl.dot(x - ufl.as_vector(x0[:d]), ufl.cofac(F) * ufl.FacetNormal(mesh)) \
        * domain.ds(name, {"quadrature_degree": cfg.quadrature_degree})


def reference_point(domain: Domain, cfg: Config, name: str) -> np.ndarray:
    """x0 of the named boundary's volume: on the symmetry planes its rim slides in (the
    origin's coordinate elsewhere).  Refuses a rim that is neither closed, clamped nor on
    such a plane (collective)."""
    mesh = domain.mesh
    rim, coords = _rim(mesh, domain.facets((name,)))
    x0 = np.zeros(3)
    if not len(rim):
        return x0  # a closed surface: any x0
    clamped = () if cfg.boundary.clamped in (("rigid",), ("none",)) else cfg.boundary.clamped
    held = _entities(mesh, domain.facets(tuple(clamped))) if clamped else set()
    free = [e for e in rim if e not in held]
    for fixed, components in cfg.boundary.fix.items():
        if not free:
            break
        on = _entities(mesh, domain.facets((fixed,)))
        sliding = [e for e in free if e in on]
        if not sliding:
            continue
        points = np.array([coords[v] for e in sliding for v in e])
        for component in components:
            k = int(component[1]) - 1
            if k < mesh.geometry.dim and np.ptp(points[:, k]) <= 1e-9 * max(
                    1.0, float(np.ptp(points))):
                x0[k] = points[0, k]  # the rim slides in the plane X_k = x0_k
                free = [e for e in free if e not in set(sliding)]
                break
    if free:
        raise ConfigError([f"loads.pressure.{name}: the surface's rim is free ({len(free)} "
                           "edges neither clamped nor in a symmetry plane of boundary.fix), "
                           "where a follower pressure has no potential; name the whole "
                           "closed surface (a cavity's every wall), or clamp its rim"])
    return x0


def _rim(mesh, facets: np.ndarray) -> tuple[list[tuple[int, ...]], dict[int, np.ndarray]]:
    """The rim of a set of boundary facets: the edges (3D; vertices in 2D) that only one of
    them has, as sorted tuples of global vertex numbers, the same on every rank, with the
    coordinates of their vertices."""
    tdim = mesh.topology.dim
    fdim = tdim - 1
    owned = facets[facets < mesh.topology.index_map(fdim).size_local]
    local = _facet_vertices(mesh, owned)
    counts: dict[tuple[int, ...], int] = {}
    for facet in mesh.comm.allgather(_pieces(mesh, local)):
        for piece in facet:
            counts[piece] = counts.get(piece, 0) + 1
    rim = sorted(p for p, c in counts.items() if c == 1)
    coords = _vertex_coordinates(mesh, local)
    every: dict[int, np.ndarray] = {}
    for part in mesh.comm.allgather(coords):
        every.update(part)
    return rim, every


def _entities(mesh, facets: np.ndarray) -> set[tuple[int, ...]]:
    """Every rim-kind piece (edges in 3D, vertices in 2D) of the facets, on every rank."""
    local = _facet_vertices(mesh, facets)
    return {p for part in mesh.comm.allgather(_pieces(mesh, local)) for p in part}


def _facet_vertices(mesh, facets: np.ndarray) -> np.ndarray:
    """(n, k) global vertex numbers of the facets' corners, in dolfinx's order."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, 0)
    f2v = mesh.topology.connectivity(tdim - 1, 0)
    rows = [f2v.links(int(f)) for f in facets]
    k = 2 if tdim == 2 else (4 if mesh.topology.cell_type.name == "hexahedron" else 3)
    local = np.array(rows, dtype=np.int32).reshape(-1, k)
    return np.asarray(mesh.topology.index_map(0).local_to_global(local.ravel())).reshape(-1, k) \
        if len(local) else np.zeros((0, k), dtype=np.int64)


def _pieces(mesh, vertices: np.ndarray) -> list[tuple[int, ...]]:
    if mesh.topology.dim == 2:
        return [(int(v),) for v in vertices.ravel()]
    kind = "quadrilateral" if vertices.shape[1] == 4 else "triangle"
    return [tuple(sorted((int(row[a]), int(row[b])))) for row in vertices
            for a, b in _FACET_EDGES[kind]]


def _vertex_coordinates(mesh, global_vertices: np.ndarray) -> dict[int, np.ndarray]:
    """Coordinates of this rank's vertices among ``global_vertices``, by global number."""
    from .. import compat

    imap = mesh.topology.index_map(0)
    n = imap.size_local + imap.num_ghosts
    local = np.arange(n, dtype=np.int32)
    numbers = np.asarray(imap.local_to_global(local))
    wanted = np.isin(numbers, global_vertices.ravel())
    if not wanted.any():
        return {}  # (dolfinx 0.9's entities_to_geometry divides by zero on no entities)
    mesh.topology.create_connectivity(0, mesh.topology.dim)
    nodes = compat.entities_to_geometry(mesh, 0, local[wanted]).ravel()
    return {int(g): mesh.geometry.x[node].copy() for g, node in zip(numbers[wanted], nodes)}


def total(form: Any, comm: MPI.Comm) -> float:
    """A scalar form assembled over every rank."""
    import dolfinx.fem

    return comm.allreduce(dolfinx.fem.assemble_scalar(dolfinx.fem.form(form)), MPI.SUM)
