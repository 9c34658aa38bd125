"""Reference bodies: built with gmsh (builders.py), cached under ``meshes/`` by every
parameter that shapes them, and read into dolfinx as a :class:`Domain` with its named
boundaries."""

from __future__ import annotations

import hashlib
import json
import logging
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from mpi4py import MPI

if TYPE_CHECKING:
    import dolfinx.mesh

from ..config import BOUNDARIES, GEOMETRY_PARAMS, LAYERED, Config, ConfigError, resolved
from ..config.expressions import coordinate_env
from ..config.selectors import parse_selector
from .bodies import build_file_body, file_key, is_cad
from .builders import BUILDER_VERSION, build
from .hex_builders import build_hex

log = logging.getLogger(__name__)


@dataclass
class Domain:
    """A distributed dolfinx mesh with its named boundaries: each name's local facets
    (sorted; a facet may lie in several), and one MeshTags of them for every surface
    integral (UFL takes one per form): a facet's tag numbers the set of names it lies in,
    and ``ids[name]`` lists the tags of the sets that hold the name."""

    mesh: dolfinx.mesh.Mesh
    boundaries: dict[str, np.ndarray]
    kind: str
    path: Path
    facet_tags: Any = None  # dolfinx.mesh.MeshTags (0.5: made by a metaclass, not a type)
    ids: dict[str, tuple[int, ...]] = field(default_factory=dict)
    faces: dict[int, np.ndarray] = field(default_factory=dict)  # a file's faces, by number

    def __post_init__(self) -> None:
        if self.facet_tags is None:
            self.facet_tags, self.ids = _membership_tags(self.mesh, self.boundaries)

    @property
    def dim(self) -> int:
        return self.mesh.topology.dim

    def facets(self, names: tuple[str, ...]) -> np.ndarray:
        """The local facets of the named boundaries, sorted, each once."""
        return np.unique(np.concatenate(
            [self.boundaries[name] for name in names])).astype(np.int32)

    def ds(self, name: str, metadata: dict[str, Any]) -> Any:
        """The surface measure of the named boundary (a ufl Measure over its tags)."""
        import ufl

        measure = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.facet_tags,
                              metadata=metadata)
        ids = self.ids[name]
        return measure(ids if len(ids) != 1 else ids[0]) if ids else measure(_NOWHERE)


_NOWHERE = 2 ** 30  # the tag of no facet: a boundary off this mesh (a box's x2_min on its
#                    section) integrates to zero


def _membership_tags(mesh, boundaries: dict[str, np.ndarray]
                     ) -> tuple[Any, dict[str, tuple[int, ...]]]:
    """One MeshTags whose value on a facet numbers the set of names holding it (numbered
    alike on every rank), and each name's values (collective)."""
    import dolfinx.mesh as dmesh

    names = list(boundaries)
    member: dict[int, int] = {}
    for bit, name in enumerate(names):
        for facet in boundaries[name]:
            member[int(facet)] = member.get(int(facet), 0) | (1 << bit)
    every = sorted(set().union(*mesh.comm.allgather(set(member.values()))))
    number = {mask: i + 1 for i, mask in enumerate(every)}
    facets = np.array(sorted(member), dtype=np.int32)
    values = np.array([number[member[f]] for f in facets], dtype=np.int32)
    tags = dmesh.meshtags(mesh, mesh.topology.dim - 1, facets, values)
    ids = {name: tuple(number[m] for m in every if m >> bit & 1)
           for bit, name in enumerate(names)}
    return tags, ids


def _params(cfg: Config) -> dict[str, Any]:
    geo = cfg.geometry
    if geo.kind == "file":
        return {"kind": "file", **file_key(cfg), "refine": cfg.mesh.refine,
                "builder": BUILDER_VERSION}
    params: dict[str, Any] = {"kind": geo.kind, "size": cfg.mesh.size,
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
    stem = cfg.geometry.kind if cfg.geometry.kind != "file" else \
        f"file-{Path(str(cfg.geometry.path)).stem}"
    return Path(cfg.mesh.cache_dir) / f"{stem}-{key}.msh"


def ensure_mesh(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> tuple[Path, bool]:
    """Build the mesh file on rank 0 unless cached; returns (path, built_now)."""
    path = mesh_path(cfg)
    built, failure, refused = False, "", False
    if comm.rank == 0 and not path.is_file():
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp.msh")
            record = _params(cfg)
            if cfg.geometry.kind == "file":
                record["groups"] = build_file_body(cfg, tmp)
            else:  # hexahedra: structured, second order, refined by regenerating
                (build_hex if cfg.mesh.cells == "hex" else build)(cfg, tmp)
            path.with_suffix(".json").write_text(json.dumps(record, indent=1))
            os.replace(tmp, path)  # atomic: a concurrent reader never sees half a file
            built = True
        except ConfigError as err:  # the file is not a body: one line naming the key
            failure, refused = str(err), True
        except Exception as err:  # every rank raises it, none waits for a mesh (a hang)
            failure = f"{type(err).__name__}: {err}"
    built, failure, refused = comm.bcast((built, failure, refused), root=0)
    if refused:
        raise ConfigError(failure.splitlines())
    if failure:
        raise RuntimeError(f"building the mesh of {cfg.name} failed: {failure}")
    comm.barrier()
    return path, built


def load_domain(cfg: Config, comm: MPI.Comm = MPI.COMM_WORLD) -> Domain:
    """The config's mesh (built or taken from the cache), distributed over ``comm``."""
    from ..compat import read_gmsh

    path, built = ensure_mesh(cfg, comm)
    mesh, _, facet_tags = read_gmsh(path, comm, gdim=cfg.model.dim)
    cells = comm.allreduce(mesh.topology.index_map(mesh.topology.dim).size_local, MPI.SUM)
    log.info("mesh %s: %d cells%s", path, cells, " (built)" if built else " (cached)")
    key = "geometry.path" if cfg.geometry.kind == "file" else "mesh.size"
    if cfg.geometry.kind == "file":
        if not is_cad(cfg) and cfg.geometry.scale != 1.0:
            mesh.geometry.x[:] *= cfg.geometry.scale
        check_extent(mesh)
    check_cells(mesh, key)
    groups = {name: tuple(tags) for name, tags in json.loads(
        path.with_suffix(".json").read_text()).get("groups", {}).items()}
    faces: dict[int, np.ndarray] = {}
    if cfg.geometry.kind == "file":
        numbers = np.unique(np.concatenate(comm.allgather(np.unique(facet_tags.values))))
        faces = {int(n): np.asarray(facet_tags.find(n), dtype=np.int32) for n in numbers}
    return Domain(mesh, named_boundaries(cfg, mesh, facet_tags, groups), cfg.geometry.kind,
                  path, faces=faces)


@dataclass(frozen=True)
class Patch:
    """A part of the boundary as ``shapegrowth mesh`` lists it: its facets, area (of the
    facets' chords) and centre."""

    name: str
    facets: int
    area: float
    centre: tuple[float, ...]

    def describe(self) -> str:
        centre = ", ".join(f"{c:.4g}" for c in self.centre)
        return f"{self.name}: {self.facets} facets, area {self.area:.4g}, centre ({centre})"


def patches(domain: Domain) -> list[Patch]:
    """The named boundaries, then a file's faces (``face N``), each measured (collective)."""
    from ..compat import entities_to_geometry

    mesh = domain.mesh
    fdim = mesh.topology.dim - 1
    owned = mesh.topology.index_map(fdim).size_local
    corners = {1: 2, 2: 4 if mesh.topology.cell_type.name == "hexahedron" else 3}[fdim]
    named = [*domain.boundaries.items(), *((f"face {n}", f) for n, f in domain.faces.items())]
    out = []
    for name, facets in named:
        mine = facets[facets < owned]
        x = mesh.geometry.x[entities_to_geometry(mesh, fdim, mine)[:, :corners]] if len(
            mine) else np.zeros((0, corners, 3))
        if corners == 2:
            areas = np.linalg.norm(x[:, 1] - x[:, 0], axis=1)
        else:  # triangles, or quadrilaterals (corners 0 1 / 2 3) as two triangles
            areas = 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1)
            if corners == 4:
                areas += 0.5 * np.linalg.norm(np.cross(x[:, 1] - x[:, 3], x[:, 2] - x[:, 3]),
                                              axis=1)
        sums = np.concatenate([[len(mine), areas.sum()], areas @ x.mean(axis=1)
                               if len(mine) else np.zeros(3)])
        mesh.comm.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        centre = sums[2:2 + mesh.geometry.dim] / sums[1] if sums[1] > 0 else \
            np.zeros(mesh.geometry.dim)
        out.append(Patch(name, int(sums[0]), float(sums[1]), tuple(float(c) for c in centre)))
    return out


def named_boundaries(cfg: Config, mesh, facet_tags, groups: dict[str, tuple[int, ...]]
                     ) -> dict[str, np.ndarray]:
    """Each boundary name's local facets: a built-in body's by its tags, a file's physical
    groups by theirs, geometry.boundaries' selectors by what they select (collective).
    A condition selects the boundary facets whose centre (the mean of their corners) it
    holds at.  A selector that selects nothing, or a face the part does not have, is
    refused."""
    import dolfinx.mesh as dmesh

    from ..compat import entities_to_geometry

    def tagged(tags) -> np.ndarray:
        return np.unique(np.concatenate([np.zeros(0, np.int32), *(
            facet_tags.find(t) for t in tags)])).astype(np.int32)

    names = {name: tagged([i + 1]) for i, name in enumerate(BOUNDARIES[cfg.geometry.kind])}
    names.update({name: tagged(tags) for name, tags in groups.items()})
    fdim = mesh.topology.dim - 1
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    section = cfg.section
    params = cfg.expression_params
    known = np.unique(np.concatenate(mesh.comm.allgather(np.unique(facet_tags.values))))
    exterior = np.sort(dmesh.locate_entities_boundary(
        mesh, fdim, lambda x: np.ones(x.shape[1], dtype=bool))).astype(np.int32)
    corners = {1: 2, 2: 4 if mesh.topology.cell_type.name == "hexahedron" else 3}[fdim]
    nodes = entities_to_geometry(mesh, fdim, exterior)[:, :corners] if len(exterior) else \
        np.zeros((0, corners), dtype=np.int32)
    centres = mesh.geometry.x[nodes].mean(axis=1).T  # (3, n): each facet's centre
    for name, text in cfg.geometry.boundaries.items():
        key = f"geometry.boundaries.{name}"
        selector = parse_selector(name, text, groups, params)
        if selector.kind == "group":
            facets = names[str(selector.group)]
        elif selector.kind == "faces":
            missing = [n for n in selector.faces if n not in known]
            if missing:
                raise ConfigError([f"{key}: the part has no face {missing[0]} (its faces: "
                                   f"{_ranges(known)})"])
            facets = tagged(selector.faces)
        else:
            condition = selector.condition
            assert condition is not None  # a condition selector carries it
            env: dict[str, Any] = dict(params)
            env.update(coordinate_env(section.embed(centres[:len(section.axes)]),
                                      cfg.cylinder_axis))
            chosen = np.broadcast_to(np.asarray(condition(env), dtype=bool), (len(exterior),))
            facets = exterior[chosen]
        owned = mesh.topology.index_map(fdim).size_local
        if mesh.comm.allreduce(int(np.sum(facets < owned)), MPI.SUM) == 0:
            raise ConfigError([f"{key}: '{text}' selects no facet of the body's boundary; "
                               "check it against the body's coordinates (a condition holds "
                               "at a facet's centre)"])
        names[name] = facets
    b = cfg.boundary
    wanted = [("boundary.clamp", n) for n in b.clamped if n not in ("rigid", "none")] + [
        (f"{key}.{n}", n) for key, named in (("boundary.fix", b.fix), (
            "loads.traction", cfg.loads.traction), ("loads.pressure", cfg.loads.pressure))
        for n in named]
    for key, name in wanted:  # an XDMF body's tag_N, known once its file is read
        if name not in names:
            raise ConfigError([f"{key}: '{name}' is not a boundary of the body (its names: "
                               f"{', '.join(names) or 'none'})"])
    return names


def _ranges(tags: np.ndarray) -> str:
    tags = np.asarray(sorted(int(t) for t in tags))
    if len(tags) and tags[-1] - tags[0] + 1 == len(tags):
        return f"{tags[0]} to {tags[-1]}"
    return ", ".join(str(t) for t in tags)


def check_extent(mesh, low: float = 1e-6, high: float = 1e6) -> None:
    """Refuse a file body whose size says its unit is wrong: a diagonal outside
    [low, high] (a part in micrometres or kilometres of the material's length unit)."""
    x = mesh.geometry.x
    lo = x.min(axis=0).copy() if len(x) else np.full(3, np.inf)
    hi = x.max(axis=0).copy() if len(x) else np.full(3, -np.inf)
    mesh.comm.Allreduce(MPI.IN_PLACE, lo, op=MPI.MIN)
    mesh.comm.Allreduce(MPI.IN_PLACE, hi, op=MPI.MAX)
    diagonal = float(np.linalg.norm(hi - lo))
    if not low <= diagonal <= high:
        raise ConfigError([f"geometry.scale: the body is {diagonal:.3g} across; give the "
                           "scale that brings the file's unit to the model's (e.g. 0.001 for "
                           "millimetres to metres)"])


def check_cells(mesh, key: str = "mesh.size", flat: float = 1e-8) -> None:
    """Refuse meshes with flat (or collapsed) cells: |det J| below ``flat`` times the
    median.  Newton would meet a singular tangent there, far from the cause."""
    import dolfinx.fem
    import ufl

    from ..compat import (
        evaluate_expression,
        geometry_degree,
        interpolate_expression,
        scalar_space,
    )

    dg0 = dolfinx.fem.Function(scalar_space(mesh, 0, "DG"))
    interpolate_expression(dg0, abs(ufl.JacobianDeterminant(mesh)))
    n = mesh.topology.index_map(mesh.topology.dim).size_local
    det = dg0.x.array[:n].copy()
    if geometry_degree(mesh) > 1:  # a curved cell is inverted where det J changes sign
        import basix

        cell = getattr(basix.CellType, mesh.topology.cell_type.name)
        points = basix.create_lattice(cell, 2, basix.LatticeType.equispaced, True)
        signed = evaluate_expression(ufl.JacobianDeterminant(mesh), points, mesh,
                                     np.arange(n, dtype=np.int32)).reshape(n, -1)
        det[(signed.min(axis=1) < 0) & (signed.max(axis=1) > 0)] = 0.0
    comm = mesh.comm
    every = np.concatenate(comm.allgather(det))
    median = float(np.median(every)) if len(every) else 0.0
    bad = int(np.sum(every <= flat * median)) if median > 0 else len(every)
    if bad:
        raise ConfigError([f"{key}: {bad} of {len(every)} cells are flat, collapsed or "
                           f"inverted (volume below {flat:g} of the median, or a Jacobian "
                           "changing sign in the cell); refine the mesh or check the geometry"])


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
