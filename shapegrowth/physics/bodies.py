"""Bodies from files (``geometry.kind: file``): a CAD part meshed here, or a gmsh mesh read as
it is, written once into the mesh cache in the form the built-in bodies take.

* A CAD part (STEP, IGES, BREP) is imported by gmsh's OpenCASCADE kernel (a skin of faces
  without its solid, as IGES files often are, sewn into one), scaled by
  ``geometry.scale``, meshed with simplices of size ``mesh.size`` (or, ``mesh.cells: hex``,
  structured hexahedra where gmsh can sweep it: blocks) and second order (its curved faces
  followed by the cells' edges), and refined ``mesh.refine`` times (gmsh's uniform
  refinement, the new nodes on the part's faces).
* A ``.msh`` (any version gmsh reads, any order) keeps its cells and nodes; its physical
  groups of the boundary's dimension become boundary names; ``mesh.refine`` refines it
  uniformly; ``geometry.scale`` multiplies its coordinates once read.
* An XDMF mesh dolfinx wrote (its data in HDF5; simplices of degree 1 or 2, or linear
  hexahedra or quadrilaterals) is read the same way, each value N of its facet tags a
  boundary named ``tag_N``.

Either way each face (a CAD face, or a geometric entity of the mesh's boundary) is tagged by
its own number in the cached mesh, and the names of the file's physical groups are kept, with
the faces each holds, beside it (``groups`` in the cache's ``.json``).  What cannot be made a
body is refused with one line naming the key: an unreadable file, no cell of the model's
dimension, cells of two kinds, a plane part off the plane x3 = 0, a mesh size absurd for the
part.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..config import Config, ConfigError
from ..config.sections import CAD_FORMATS

log = logging.getLogger(__name__)

# a CAD part meshed with more than this many elements along its diagonal is taken for a unit
# mistake (a part in millimetres meshed with a size in metres), as is one smaller than a cell
MAX_CELLS_ACROSS = 1000
READER_VERSION = 2  # bump when a file body's mesh changes, so cached ones are made anew
# the gaps a skin of faces is sewn across, tried in turn, relative to the part's diagonal
# (an IGES hammer of OpenCASCADE's samples closes at 1e-5)
HEALING = (1e-8, 1e-7, 1e-6, 1e-5, 1e-4)
# what gmsh's high-order optimisation says of cells it left below its quality goal
OPTIMISER_SHORT = "Failed to reach critical value"


def file_key(cfg: Config) -> dict[str, Any]:
    """What shapes a file body's mesh: the file's content and the keys that mesh it."""
    geo = cfg.geometry
    path = Path(str(geo.path))
    digest = hashlib.sha1(path.read_bytes()).hexdigest()[:16]
    key: dict[str, Any] = {"file": digest, "format": path.suffix.lower(), "dim": cfg.model.dim,
                           "reader": READER_VERSION}
    if is_cad(cfg):
        key.update(size=cfg.mesh.size, scale=geo.scale, cells=cfg.mesh.cells)
        if cfg.mesh.clamp_size is not None:
            key.update(clamp_size=cfg.mesh.clamp_size, grading=cfg.mesh.grading,
                       clamp=list(cfg.boundary.clamped),
                       selectors={n: geo.boundaries.get(n) for n in cfg.boundary.clamped})
    return key


def is_cad(cfg: Config) -> bool:
    return Path(str(cfg.geometry.path)).suffix.lower() in CAD_FORMATS


def build_file_body(cfg: Config, out: Path) -> dict[str, list[int]]:
    """Write ``cfg``'s file body as a tagged mesh to ``out`` (rank 0 only); returns the
    file's named groups, name -> the face tags each holds.  Raises ConfigError."""
    import gmsh

    path = Path(str(cfg.geometry.path))
    tdim = cfg.model.dim
    gmsh.initialize()
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("file")
        if is_cad(cfg):
            _mesh_cad(gmsh, cfg, path, tdim)
            groups: dict[str, list[int]] = {}
        elif path.suffix.lower() == ".xdmf":
            groups = _read_xdmf(gmsh, path, tdim)
        else:
            groups = _read_msh(gmsh, path, tdim)
        for _ in range(cfg.mesh.refine):
            gmsh.model.mesh.refine()
        if cfg.mesh.refine and is_cad(cfg):  # gmsh's refinement leaves hexahedra linear
            gmsh.model.mesh.setOrder(2)  # (new nodes on the part's faces)
        gmsh.model.removePhysicalGroups()
        for _, tag in gmsh.model.getEntities(tdim - 1):
            if len(gmsh.model.mesh.getElementTypes(tdim - 1, tag)):  # a .msh may leave
                gmsh.model.addPhysicalGroup(tdim - 1, [tag], tag)  # some faces unmeshed
        gmsh.model.addPhysicalGroup(tdim, [t for _, t in gmsh.model.getEntities(tdim)], 1)
        gmsh.option.setNumber("Mesh.MshFileVersion", 4.1)
        gmsh.write(str(out))
        return groups
    finally:
        gmsh.finalize()


def _refuse(problem: str, key: str = "geometry.path") -> ConfigError:
    return ConfigError([f"{key}: {problem}"])


def _mesh_cad(gmsh, cfg: Config, path: Path, tdim: int) -> None:
    """Import, scale and mesh a CAD part (second order)."""
    occ = gmsh.model.occ
    _import(gmsh, path)
    solids = gmsh.model.getEntities(tdim)
    faces = gmsh.model.getEntities(tdim - 1)
    if not solids and tdim == 3 and faces:  # IGES and some exports carry the skin alone
        for tolerance in HEALING:  # the tightest first that closes its gaps
            # the whole model: gmsh 4.13 makes no solid of the faces given as a list
            occ.healShapes([], tolerance * _diagonal(gmsh), True, True, True, True, True)
            occ.synchronize()
            solids = gmsh.model.getEntities(tdim)
            if solids:
                log.info("geometry.path: the %d faces of '%s' sewn into %d solid(s) (gaps "
                         "up to %.0e of its size closed)", len(faces), path, len(solids),
                         tolerance)
                break
            gmsh.model.remove()
            gmsh.model.add("file")
            _import(gmsh, path)
    if not solids:
        what = "solid" if tdim == 3 else "face"
        raise _refuse(f"'{path}' holds no {what} (a {tdim}D model meshes a "
                      f"{what}); export the part as a {what}"
                      + (", or set model.dim: 2 for a plane face" if tdim == 3 else ""))
    loose = [(tdim - 1, t) for _, t in gmsh.model.getEntities(tdim - 1)  # faces bounding
             if not len(gmsh.model.getAdjacencies(tdim - 1, t)[0])]  # no solid (a skin sewn)
    if loose:
        occ.remove(loose, recursive=True)
        occ.synchronize()
    if cfg.geometry.scale != 1.0:
        s = cfg.geometry.scale
        occ.dilate(gmsh.model.getEntities(tdim), 0.0, 0.0, 0.0, s, s, s)
        occ.synchronize()
    diagonal = _diagonal(gmsh)
    size = cfg.mesh.size
    if diagonal / size > MAX_CELLS_ACROSS or diagonal < size:
        raise _refuse(
            f"{size:g} against a part {diagonal:.4g} across (after geometry.scale "
            f"{cfg.geometry.scale:g}) makes {diagonal / size:.3g} cells along it; give a size "
            f"between {diagonal / MAX_CELLS_ACROSS:.3g} and {diagonal:.3g}, or the scale of "
            "the file's unit (0.001 for millimetres)", "mesh.size")
    gmsh.option.setNumber("Mesh.MeshSizeMax", size)
    if cfg.mesh.clamp_size is not None:
        _graded_towards_clamp(gmsh, cfg, tdim)
    if cfg.mesh.cells == "hex":  # structured, where gmsh can sweep the part: blocks
        gmsh.model.mesh.setTransfiniteAutomatic()
        gmsh.option.setNumber("Mesh.RecombineAll", 1)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.ElementOrder", 2)
    if cfg.mesh.cells == "simplex":  # curved second-order cells on a coarse mesh of a
        # curved part can tangle: gmsh's elastic analogy and optimisation move their nodes
        # until each Jacobian is positive (it takes no pyramids: a failed sweep makes some)
        gmsh.option.setNumber("Mesh.HighOrderOptimize", 2)
    try:
        gmsh.model.mesh.generate(tdim)
    except Exception as err:
        # gmsh's high-order optimisation reports the cells it left below its goal (a scaled
        # Jacobian of 0.1) as an error after the mesh is made: the mesh is kept, its tangled
        # cells (if any) made straight-sided below
        if OPTIMISER_SHORT not in str(err):
            raise _refuse(f"gmsh could not mesh '{path}' at size {size:g} ({err}); repair "
                          "the part or change mesh.size") from None
        log.warning("mesh.size: gmsh left some curved cells of '%s' below its quality goal "
                    "(%s)", path, err)
    if cfg.mesh.cells == "simplex":
        straightened = _straighten_tangled(gmsh, tdim)
        if straightened < 0:
            raise _refuse(f"gmsh could not mesh '{path}' at size {size:g} (cells tangled "
                          "even with straight sides); repair the part or change mesh.size")
        if straightened:
            log.warning("mesh.size: %d curved cells of '%s' were tangled (a Jacobian not "
                        "positive at a node or Gauss point): their edges are made straight",
                        straightened, path)
    if tdim == 2:  # the nodes, not OpenCASCADE's box (widened by the part's tolerance)
        _check_plane(_node_box(gmsh), path)
    kinds = [gmsh.model.mesh.getElementProperties(t)[0]
             for t in gmsh.model.mesh.getElementTypes(tdim)]
    if cfg.mesh.cells == "hex" and (len(kinds) != 1 or not kinds[0].startswith(
            ("Hexahedron", "Quadrilateral"))):
        raise _refuse(f"hex needs a part gmsh can sweep (each solid a block of six four-sided "
                      f"faces; each face four-sided in 2D), and '{path}' meshes as "
                      f"{' and '.join(kinds)}; use cells: simplex, or give a .msh of "
                      "hexahedra", "mesh.cells")


def _tangled(gmsh, kind: int, tdim: int) -> np.ndarray:
    """Which cells of gmsh's element type ``kind`` have a Jacobian determinant not positive
    at a node or at a point of a degree-4 Gauss rule (a boolean per element)."""
    nodes = gmsh.model.mesh.getElementProperties(kind)[4]
    gauss = gmsh.model.mesh.getIntegrationPoints(kind, "Gauss4")[0]
    points = np.concatenate([np.asarray(nodes, dtype=float).reshape(-1, tdim),
                             np.asarray(gauss, dtype=float).reshape(-1, 3)[:, :tdim]])
    local = np.zeros((len(points), 3))
    local[:, :tdim] = points
    determinants = np.asarray(gmsh.model.mesh.getJacobians(kind, local.reshape(-1))[1])
    return np.min(determinants.reshape(-1, len(points)), axis=1) <= 0.0


def _straighten_tangled(gmsh, tdim: int, rounds: int = 20) -> int:
    """Moves each mid-edge node of a tangled curved cell to its edge's midpoint, round
    after round (a straightened edge is shared by neighbours), until no cell is tangled:
    a straight-sided second-order cell is its linear cell, positive where gmsh's first-order
    mesh is.  The number of cells straightened, -1 where some stay tangled."""
    done: set[int] = set()
    for _ in range(rounds):
        left = 0
        for kind in gmsh.model.mesh.getElementTypes(tdim):
            _, _, order, count, reference, corners = gmsh.model.mesh.getElementProperties(kind)
            bad = _tangled(gmsh, kind, tdim)
            if order < 2 or not bad.any():
                continue
            tags, nodes = gmsh.model.mesh.getElementsByType(kind)
            nodes = np.asarray(nodes, dtype=np.int64).reshape(-1, count)
            reference = np.asarray(reference, dtype=float).reshape(count, tdim)
            # each higher-order node as the midpoint of two corners (second order)
            pairs = [(k, i, j) for k in range(corners, count)
                     for i in range(corners) for j in range(i + 1, corners)
                     if np.allclose(reference[k], 0.5 * (reference[i] + reference[j]))]
            for cell in np.flatnonzero(bad):
                done.add(int(tags[cell]))
                left += 1
                for k, i, j in pairs:
                    a = np.asarray(gmsh.model.mesh.getNode(int(nodes[cell, i]))[0])
                    b = np.asarray(gmsh.model.mesh.getNode(int(nodes[cell, j]))[0])
                    gmsh.model.mesh.setNode(int(nodes[cell, k]), list(0.5 * (a + b)), [])
        if not left:
            return len(done)
    return -1


def _import(gmsh, path: Path) -> None:
    """The part into the current model; OpenCASCADE's reports (it writes them to the
    process's output, past gmsh's logger) go nowhere."""
    try:
        with _quiet():
            gmsh.model.occ.importShapes(str(path))
        gmsh.model.occ.synchronize()
    except Exception as err:  # gmsh raises a bare Exception with its log's last line
        raise _refuse(f"cannot read '{path}' as a CAD part ({err})") from None


@contextlib.contextmanager
def _quiet():
    """The process's standard output closed for the duration (file descriptor 1)."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def _graded_towards_clamp(gmsh, cfg: Config, tdim: int) -> None:
    """``mesh.clamp_size`` on the faces the clamp names (a ``face N`` selector's, or those
    whose centre a condition holds at), growing by ``mesh.grading`` per unit distance up to
    ``mesh.size`` (a size field, as the built-in bodies are graded)."""
    from ..config.expressions import coordinate_env
    from ..config.selectors import parse_selector

    faces: set[int] = set()
    every = [t for _, t in gmsh.model.getEntities(tdim - 1)]
    for name in cfg.boundary.clamped:
        selector = parse_selector(name, cfg.geometry.boundaries.get(name, ""), (),
                                  cfg.expression_params)
        if selector.kind == "faces":
            faces.update(selector.faces)
        elif selector.condition is not None:
            centres = np.array([gmsh.model.occ.getCenterOfMass(tdim - 1, t) for t in every]).T
            env: dict[str, Any] = dict(cfg.expression_params)
            env.update(coordinate_env(centres, cfg.cylinder_axis))
            held = np.broadcast_to(np.asarray(selector.condition(env), bool), (len(every),))
            faces.update(t for t, h in zip(every, held) if h)
    if not faces:
        raise _refuse(f"the clamp {list(cfg.boundary.clamped)} holds no face of the part "
                      "(its conditions judged at each face's centre) to grade towards; "
                      "name its faces ('face N'), or remove the key", "mesh.clamp_size")
    field = gmsh.model.mesh.field
    distance = field.add("Distance")
    field.setNumbers(distance, "SurfacesList" if tdim == 3 else "CurvesList", sorted(faces))
    ramp = field.add("MathEval")
    h, h_min, rate = cfg.mesh.size, cfg.mesh.clamp_size, cfg.mesh.grading
    field.setString(ramp, "F", f"min({h}, {h_min} + {rate} * F{distance})")
    field.setAsBackgroundMesh(ramp)
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def _diagonal(gmsh) -> float:
    box = np.array(gmsh.model.getBoundingBox(-1, -1))
    return float(np.linalg.norm(box[3:] - box[:3]))


def _read_msh(gmsh, path: Path, tdim: int) -> dict[str, list[int]]:
    """Merge a .msh, check its cells, and return its boundary's named groups."""
    try:
        gmsh.merge(str(path))
    except Exception as err:
        raise _refuse(f"cannot read '{path}' as a gmsh mesh ({err})") from None
    kinds = [t for t in gmsh.model.mesh.getElementTypes(tdim)]
    if not kinds:
        lower = [d for d in (2, 1) if len(gmsh.model.mesh.getElementTypes(d))]
        holds = f" (its cells are {lower[0]}D)" if lower else " (it has no cells)"
        raise _refuse(f"'{path}' holds no {tdim}D cells{holds}; give a mesh of the body"
                      + ("'s volume, or set model.dim: 2 for a plane part" if tdim == 3
                         else ""))
    if len(kinds) > 1:
        names = [gmsh.model.mesh.getElementProperties(t)[0] for t in kinds]
        raise _refuse(f"'{path}' mixes {' and '.join(names)}; dolfinx takes one cell kind: "
                      "give a mesh of one")
    if tdim == 2:
        _check_plane(_node_box(gmsh), path)
    groups: dict[str, list[int]] = {}
    for dim, tag in gmsh.model.getPhysicalGroups(tdim - 1):
        name = gmsh.model.getPhysicalName(dim, tag) or f"group_{tag}"
        groups[name] = [int(e) for e in gmsh.model.getEntitiesForPhysicalGroup(dim, tag)]
    return groups


# XDMF's cell kinds that dolfinx writes, as gmsh's element types with the permutation from
# XDMF's (VTK's) node order to gmsh's (a 10-node tetrahedron numbers its last two edges the
# other way round); the 27-node hexahedron and 9-node quadrilateral are left to .msh files
_XDMF_CELLS: dict[str, tuple[int, tuple[int, ...]]] = {
    "PolyLine": (1, (0, 1)), "Edge_3": (8, (0, 1, 2)),
    "Triangle": (2, (0, 1, 2)), "Triangle_6": (9, tuple(range(6))),
    "Quadrilateral": (3, (0, 1, 2, 3)),
    "Tetrahedron": (4, (0, 1, 2, 3)), "Tetrahedron_10": (11, (0, 1, 2, 3, 4, 5, 6, 7, 9, 8)),
    "Hexahedron": (5, tuple(range(8))),
}
_XDMF_DIM = {"PolyLine": 1, "Edge_3": 1, "Triangle": 2, "Triangle_6": 2, "Quadrilateral": 2,
             "Tetrahedron": 3, "Tetrahedron_10": 3, "Hexahedron": 3}


def _read_xdmf(gmsh, path: Path, tdim: int) -> dict[str, list[int]]:
    """A mesh dolfinx wrote as XDMF (its data in HDF5) into the gmsh model: the cells, and
    each value N of its facet tags as the group ``tag_N``."""
    import xml.etree.ElementTree as ET

    from ..compat import h5py

    try:
        grids = ET.parse(path).getroot().iter("Grid")
        read = h5py()

        def data(parent, child: str) -> np.ndarray:
            """The HDF5 array of ``parent``'s ``child``'s DataItem."""
            node = parent.find(child) if child else parent
            item = node.find("DataItem") if node is not None else None
            if item is None or item.text is None:
                raise ValueError(f"a {child or 'grid'} without its data")
            if item.get("Format") != "HDF":
                raise ValueError("its data are not in HDF5 (write it with dolfinx)")
            file, dataset = item.text.strip().split(":", 1)
            with read.File(path.parent / file, "r") as h5:
                return np.asarray(h5[dataset])

        mesh = None
        facets: list[tuple[str, np.ndarray, np.ndarray]] = []
        for grid in grids:
            topology = grid.find("Topology")
            kind = topology.get("TopologyType") if topology is not None else None
            if kind not in _XDMF_CELLS:
                raise ValueError(f"its cells '{kind}' are not read here (give it as .msh)")
            if grid.find("Geometry") is not None and _XDMF_DIM[kind] == tdim and mesh is None:
                mesh = (kind, data(grid, "Topology"), data(grid, "Geometry"))
            elif _XDMF_DIM[kind] == tdim - 1 and grid.find("Attribute") is not None:
                facets.append((kind, data(grid, "Topology"),
                               data(grid, "Attribute").ravel()))
    except (OSError, ET.ParseError, ValueError, KeyError, AttributeError) as err:
        raise _refuse(f"cannot read '{path}' as a dolfinx XDMF mesh ({err})") from None
    if mesh is None:
        raise _refuse(f"'{path}' holds no {tdim}D cells; give a mesh of the body"
                      + ("'s volume, or set model.dim: 2 for a plane part" if tdim == 3
                         else ""))
    kind, cells, x = mesh
    xyz = np.zeros((len(x), 3))
    xyz[:, :x.shape[1]] = x
    gmsh.model.addDiscreteEntity(tdim, 1)
    gmsh.model.mesh.addNodes(tdim, 1, np.arange(1, len(xyz) + 1), xyz.ravel())
    element, order = _XDMF_CELLS[kind]
    gmsh.model.mesh.addElementsByType(1, element, [], (cells[:, order] + 1).ravel())
    if tdim == 2:
        _check_plane(_node_box(gmsh), path)
    groups: dict[str, list[int]] = {}
    for kind, nodes, values in facets:
        element, order = _XDMF_CELLS[kind]
        for value in np.unique(values):
            entity = gmsh.model.addDiscreteEntity(tdim - 1)
            chosen = nodes[values == value][:, order] + 1
            gmsh.model.mesh.addElementsByType(entity, element, [], chosen.ravel())
            groups.setdefault(f"tag_{int(value)}", []).append(int(entity))
    return groups


def _node_box(gmsh) -> np.ndarray:
    """(lo, hi) of the mesh's nodes, six numbers."""
    _, coords, _ = gmsh.model.mesh.getNodes()
    xyz = np.asarray(coords).reshape(-1, 3)
    return np.concatenate([xyz.min(axis=0), xyz.max(axis=0)])


def _check_plane(box: np.ndarray, path: Path) -> None:
    """A plane part lies in x3 = 0 (model.plane x1x2)."""
    extent = float(np.max(box[3:] - box[:3]))
    if max(abs(box[2]), abs(box[5])) > 1e-9 * max(extent, 1.0):
        raise _refuse(f"'{path}' is a plane part off the plane x3 = 0 (x3 from {box[2]:.4g} "
                      f"to {box[5]:.4g}); a plane model's part lies in x1x2")
