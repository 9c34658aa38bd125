"""Reference bodies: built with gmsh (builders.py), cached under ``meshes/`` by every
parameter that shapes them, and read into dolfinx as a :class:`Domain` with its named
boundaries."""

from __future__ import annotations

import hashlib
import json
import logging
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from mpi4py import MPI

if TYPE_CHECKING:
    import dolfinx.mesh

from ..config import BOUNDARIES, GEOMETRY_PARAMS, LAYERED, Config, ConfigError, resolved
from .builders import BUILDER_VERSION, build
from .hex_builders import build_hex

log = logging.getLogger(__name__)


@dataclass
class Domain:
    """A distributed dolfinx mesh with its named boundaries."""

    mesh: dolfinx.mesh.Mesh
    facet_tags: Any  # dolfinx.mesh.MeshTags (0.5: made by a metaclass, not a type)
    boundaries: dict[str, int]
    kind: str
    path: Path

    @property
    def dim(self) -> int:
        return self.mesh.topology.dim

    def facets(self, names: tuple[str, ...]) -> np.ndarray:
        """The local facets of the named boundaries, sorted, each once."""
        return np.unique(np.concatenate(
            [self.facet_tags.find(self.boundaries[name]) for name in names])).astype(np.int32)


def _params(cfg: Config) -> dict[str, float | int | str]:
    geo = cfg.geometry
    params: dict[str, float | int | str] = {"kind": geo.kind, "size": cfg.mesh.size,
                                            "builder": BUILDER_VERSION}
    for name in GEOMETRY_PARAMS[geo.kind]:
        params[name] = getattr(geo, name)
    if cfg.section.reduced:
        params["section"] = resolved(cfg.model.plane)
    if geo.kind in LAYERED:
        params["layers"] = cfg.mesh.layers
    if cfg.mesh.refine:
        params["refine"] = cfg.mesh.refine
    if cfg.mesh.cells != "simplex":  # simplex meshes keep the keys they had
        params["cells"] = cfg.mesh.cells
    if cfg.mesh.clamp_size is not None:
        params["clamp_size"], params["grading"] = cfg.mesh.clamp_size, cfg.mesh.grading
    return params


def mesh_path(cfg: Config) -> Path:
    """Cache file of the config's mesh, keyed by every parameter that shapes it."""
    params = _params(cfg)
    key = hashlib.sha1(json.dumps(params, sort_keys=True).encode()).hexdigest()[:12]
    return Path(cfg.mesh.cache_dir) / f"{cfg.geometry.kind}-{key}.msh"


def ensure_mesh(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> tuple[Path, bool]:
    """Build the mesh file on rank 0 unless cached; returns (path, built_now)."""
    path = mesh_path(cfg)
    built, failure = False, ""
    if comm.rank == 0 and not path.is_file():
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp.msh")
            # hexahedra: structured, second order, refined by regenerating (hex_builders.py)
            (build_hex if cfg.mesh.cells == "hex" else build)(cfg, tmp)
            os.replace(tmp, path)  # atomic: a concurrent reader never sees half a file
            path.with_suffix(".json").write_text(json.dumps(_params(cfg), indent=1))
            built = True
        except Exception as err:  # every rank raises it, none waits for a mesh (a hang)
            failure = f"{type(err).__name__}: {err}"
    built, failure = comm.bcast((built, failure), root=0)
    if failure:
        raise RuntimeError(f"building the mesh of {cfg.name} failed: {failure}")
    comm.barrier()
    return path, built


def load_domain(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> Domain:
    """The config's mesh (built or taken from the cache), distributed over ``comm``."""
    from ..compat import read_gmsh

    path, built = ensure_mesh(cfg, comm)
    mesh, _, facet_tags = read_gmsh(path, comm, gdim=cfg.model.dim)
    boundaries = {name: i + 1 for i, name in enumerate(BOUNDARIES[cfg.geometry.kind])}
    cells = comm.allreduce(mesh.topology.index_map(mesh.topology.dim).size_local, MPI.SUM)
    log.info("mesh %s: %d cells%s", path, cells, " (built)" if built else " (cached)")
    check_cells(mesh)
    return Domain(mesh, facet_tags, boundaries, cfg.geometry.kind, path)


def check_cells(mesh, flat: float = 1e-8) -> None:
    """Refuse meshes with flat (or collapsed) cells: |det J| below ``flat`` times the
    median.  Newton would meet a singular tangent there, far from the cause."""
    import dolfinx.fem
    import ufl

    from ..compat import interpolate_expression, scalar_space

    dg0 = dolfinx.fem.Function(scalar_space(mesh, 0, "DG"))
    interpolate_expression(dg0, abs(ufl.JacobianDeterminant(mesh)))
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    det = dg0.x.array[:n]
    comm = mesh.comm
    every = np.concatenate(comm.allgather(det))
    median = float(np.median(every)) if len(every) else 0.0
    bad = int(np.sum(every <= flat * median)) if median > 0 else len(every)
    if bad:
        raise ConfigError([f"mesh.size: {bad} of {len(every)} cells are flat or collapsed "
                           f"(volume below {flat:g} of the median); refine the mesh or check "
                           "the geometry"])


# The edges of each reference cell by its vertices, in dolfinx's numbering (the first nodes of
# a cell's geometry are its vertices, whatever its degree)
_EDGES = {
    "triangle": [(0, 1), (0, 2), (1, 2)],
    "tetrahedron": [(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)],
    "quadrilateral": [(0, 1), (0, 2), (1, 3), (2, 3)],
    "hexahedron": [(0, 1), (0, 2), (0, 4), (1, 3), (1, 5), (2, 3), (2, 6), (3, 7), (4, 5),
                   (4, 6), (5, 7), (6, 7)],
}


@dataclass(frozen=True)
class MeshQuality:
    """What a thin wall's mesh is made of: its cells, their aspect ratios (longest over
    shortest edge of each cell: a wall meshed with cells many thicknesses long has large
    ones), and, for a layered body, the elements through its thickness as built."""

    cells: int
    cell_type: str
    geometry_degree: int
    aspect_median: float
    aspect_max: float
    layers: int | None  # elements through the wall or thickness (layered bodies)

    def describe(self) -> str:
        through = f", {self.layers} through the thickness" if self.layers else ""
        return (f"{self.cells} {self.cell_type} cells of degree {self.geometry_degree}"
                f"{through}; aspect ratio median {self.aspect_median:.3g}, "
                f"max {self.aspect_max:.3g}")


def mesh_quality(domain: Domain, cfg: Config) -> MeshQuality:
    """The quality of ``domain``'s mesh (collective)."""
    from ..compat import geometry_degree, geometry_nodes

    mesh = domain.mesh
    tdim = mesh.topology.dim
    name = mesh.topology.cell_type.name
    owned = mesh.topology.index_map(tdim).size_local
    x = mesh.geometry.x[geometry_nodes(mesh)[:owned]]
    edges = np.stack([np.linalg.norm(x[:, a] - x[:, b], axis=1) for a, b in _EDGES[name]],
                     axis=1)
    ratios = edges.max(axis=1) / edges.min(axis=1)
    every = np.concatenate(mesh.comm.allgather(ratios))
    return MeshQuality(int(len(every)), name, geometry_degree(mesh),
                       float(np.median(every)), float(every.max()),
                       cfg.mesh.layers if cfg.geometry.kind in LAYERED else None)
